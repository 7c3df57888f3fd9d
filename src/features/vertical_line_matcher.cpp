#include "homography_teach_repeat/features/vertical_line_matcher.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace homography_teach_repeat {
namespace {

double squaredDistance(const VerticalLine& a, const VerticalLine& b, const LineMatchOptions& o) {
  const double dx = (a.x - b.x) / o.sigma_x_px;
  const double dy = (0.5 * (a.top.y() + a.bottom.y()) - 0.5 * (b.top.y() + b.bottom.y())) /
                    o.sigma_y_px;
  const double dl = (a.length - b.length) / (o.sigma_length_ratio * std::max(a.length, b.length));
  const double dbl = (a.left_brightness - b.left_brightness) / o.sigma_brightness;
  const double dbr = (a.right_brightness - b.right_brightness) / o.sigma_brightness;
  return dx * dx + dy * dy + dl * dl + dbl * dbl + dbr * dbr;
}

struct Nearest {
  int index = -1;
  double best = std::numeric_limits<double>::infinity();
  double second = std::numeric_limits<double>::infinity();
};

Nearest nearest(const VerticalLine& line, const std::vector<VerticalLine>& others,
                const LineMatchOptions& o) {
  Nearest n;
  for (std::size_t j = 0; j < others.size(); ++j) {
    const VerticalLine& other = others[j];
    if (other.polarity != line.polarity || std::abs(other.x - line.x) > o.max_disparity_px) {
      continue;
    }
    const double d = squaredDistance(line, other, o);
    if (d < n.best) {
      n.second = n.best;
      n.best = d;
      n.index = static_cast<int>(j);
    } else if (d < n.second) {
      n.second = d;
    }
  }
  return n;
}

}  // namespace

void LineMatchOptions::validate() const {
  if (!(max_disparity_px > 0.0)) throw std::invalid_argument("line matching: max_disparity_px > 0");
  if (!(sigma_x_px > 0.0) || !(sigma_y_px > 0.0) || !(sigma_length_ratio > 0.0) ||
      !(sigma_brightness > 0.0)) {
    throw std::invalid_argument("line matching: every sigma must be > 0");
  }
  if (!(max_distance > 0.0)) throw std::invalid_argument("line matching: max_distance > 0");
  if (!(ratio > 0.0 && ratio <= 1.0)) throw std::invalid_argument("line matching: ratio in (0, 1]");
}

Expected<std::vector<LineMatch>> matchVerticalLines(const std::vector<VerticalLine>& reference,
                                                    const std::vector<VerticalLine>& current,
                                                    const LineMatchOptions& options) {
  options.validate();
  for (const auto* set : {&reference, &current}) {
    for (const auto& line : *set) {
      if (!std::isfinite(line.x)) return Status(StatusCode::kInvalidInput, "a line x is not finite");
    }
  }
  std::vector<LineMatch> matches;
  const double max_squared = options.max_distance * options.max_distance;
  const double ratio_squared = options.ratio * options.ratio;
  for (std::size_t i = 0; i < reference.size(); ++i) {
    const Nearest forward = nearest(reference[i], current, options);
    if (forward.index < 0 || forward.best > max_squared) continue;
    if (forward.best > ratio_squared * forward.second) continue;
    if (options.mutual) {
      const Nearest backward =
          nearest(current[static_cast<std::size_t>(forward.index)], reference, options);
      if (backward.index != static_cast<int>(i)) continue;
    }
    matches.push_back({static_cast<int>(i), forward.index, std::sqrt(forward.best)});
  }
  return matches;
}

}  // namespace homography_teach_repeat
