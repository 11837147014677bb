// The median of a list of numbers, found in linear time (std::nth_element).
#pragma once

#include <algorithm>
#include <vector>

#include "core/error.h"

namespace relit {

// The middle element of `values` in sorted order; for an even count the
// upper of the two middle ones (no average: the result is one of the
// values). Takes the list by value (pass std::move when it is not needed
// afterwards). Throws relit::Error when `values` is empty.
template <typename T>
T Median(std::vector<T> values) {
  RELIT_REQUIRE(!values.empty(), "median of no values");
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

}  // namespace relit
