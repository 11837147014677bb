// Errors: one exception type carrying a user-facing message.
// The main wrapper prints it as a single line and exits non-zero, so messages
// should name the file/frame/option involved and say what to do.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

namespace relit {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

namespace internal {
template <typename... Args>
std::string Concat(Args&&... args) {
  std::ostringstream stream;
  (stream << ... << std::forward<Args>(args));
  return stream.str();
}
}  // namespace internal

// Throws relit::Error built by streaming all arguments.
template <typename... Args>
[[noreturn]] void Fail(Args&&... args) {
  throw Error(internal::Concat(std::forward<Args>(args)...));
}

}  // namespace relit

// Checks a condition that depends on user input; the message is for the user.
#define RELIT_REQUIRE(condition, ...)    \
  do {                                   \
    if (!(condition)) {                  \
      ::relit::Fail(__VA_ARGS__);        \
    }                                    \
  } while (false)

// Checks an internal invariant; failing means a relit bug, not bad input.
#define RELIT_CHECK(condition)                                                \
  do {                                                                        \
    if (!(condition)) {                                                       \
      ::relit::Fail("internal error: check failed: ", #condition, " at ",     \
                    __FILE__, ":", __LINE__, " (please report this)");        \
    }                                                                         \
  } while (false)
