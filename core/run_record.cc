#include "core/run_record.h"

#include <sys/resource.h>
#include <unistd.h>

#include <climits>
#include <ctime>
#include <utility>

#include "core/error.h"
#include "core/json_file.h"

#ifndef RELIT_VERSION
#error "RELIT_VERSION must be defined by the build (see core/CMakeLists.txt)"
#endif

namespace relit {

namespace {

const char* const kReservedKeys[] = {"schema",  "tool",   "version",   "start_time_utc",
                                     "hostname", "command_line", "options", "inputs",
                                     "timings_s", "total_s"};

bool IsReserved(const std::string& key) {
  for (const char* reserved : kReservedKeys) {
    if (key == reserved) return true;
  }
  return false;
}

std::string HostName() {
  char buffer[HOST_NAME_MAX + 1] = {};
  if (gethostname(buffer, sizeof(buffer) - 1) != 0) return "unknown";
  return buffer;
}

}  // namespace

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

double ProcessCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  auto seconds = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

const char* RelitVersion() { return RELIT_VERSION; }

std::string CurrentTimeIso8601Utc() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char buffer[32];
  std::strftime(buffer, sizeof(buffer), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return buffer;
}

RunRecord::RunRecord(std::string tool)
    : tool_(std::move(tool)),
      start_time_utc_(CurrentTimeIso8601Utc()),
      start_(std::chrono::steady_clock::now()),
      fields_(nlohmann::json::object()) {
  fields_["hostname"] = HostName();
  fields_["options"] = nlohmann::json::object();
  fields_["inputs"] = nlohmann::json::object();
  fields_["timings_s"] = nlohmann::json::object();
}

void RunRecord::SetCommandLine(int argc, char** argv) {
  nlohmann::json args = nlohmann::json::array();
  for (int i = 0; i < argc; ++i) args.push_back(argv[i]);
  std::lock_guard<std::mutex> lock(mutex_);
  fields_["command_line"] = std::move(args);
}

void RunRecord::SetOptions(nlohmann::json options) {
  std::lock_guard<std::mutex> lock(mutex_);
  fields_["options"] = std::move(options);
}

void RunRecord::AddInput(const std::string& role, const std::string& path) {
  std::lock_guard<std::mutex> lock(mutex_);
  fields_["inputs"][role] = path;
}

void RunRecord::Set(const std::string& key, nlohmann::json value) {
  RELIT_CHECK(!IsReserved(key));
  std::lock_guard<std::mutex> lock(mutex_);
  fields_[key] = std::move(value);
}

void RunRecord::AddTiming(const std::string& step, double seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  nlohmann::json& timings = fields_["timings_s"];
  const double previous = timings.contains(step) ? timings[step].get<double>() : 0.0;
  timings[step] = previous + seconds;
}

RunRecord::Scope RunRecord::Time(std::string step) { return Scope(this, std::move(step)); }

RunRecord::Scope::Scope(RunRecord* record, std::string step)
    : record_(record), step_(std::move(step)), start_(std::chrono::steady_clock::now()) {}

RunRecord::Scope::Scope(Scope&& other) noexcept
    : record_(other.record_), step_(std::move(other.step_)), start_(other.start_) {
  other.record_ = nullptr;
}

RunRecord::Scope::~Scope() {
  try {
    Stop();
  } catch (...) {
    // Only allocation can fail here; a missing timing is not worth a crash.
  }
}

double RunRecord::Scope::Stop() {
  if (record_ == nullptr) return 0.0;
  const double seconds = SecondsSince(start_);
  record_->AddTiming(step_, seconds);
  record_ = nullptr;
  return seconds;
}

nlohmann::json RunRecord::ToJson() const {
  std::lock_guard<std::mutex> lock(mutex_);
  nlohmann::json record = fields_;
  record["tool"] = tool_;
  record["version"] = RelitVersion();
  record["start_time_utc"] = start_time_utc_;
  record["total_s"] = SecondsSince(start_);
  return record;
}

void RunRecord::Write(const std::string& path) const {
  WriteJsonFile(path, kKind, kVersion, ToJson());
}

}  // namespace relit
