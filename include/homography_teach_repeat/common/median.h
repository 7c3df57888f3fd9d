// The median of a sample, as the route's measured noise and the keyframes' plane σ take it.
#pragma once

#include <algorithm>
#include <cstddef>
#include <optional>
#include <vector>

namespace homography_teach_repeat {

// The element at size/2 of the sorted values (the upper of the two middle ones); nullopt for none.
inline std::optional<double> upperMedian(std::vector<double> values) {
  if (values.empty()) return std::nullopt;
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

}  // namespace homography_teach_repeat
