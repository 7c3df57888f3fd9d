#include "homography_teach_repeat/mu/line_shift.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "homography_teach_repeat/features/brief.h"
#include "homography_teach_repeat/features/feature_matcher.h"

namespace homography_teach_repeat {

VerticalLineOptions LineShiftOptions::seasonalLineOptions() {
  VerticalLineOptions lines;
  // A quarter of the image's mean |gx| (about 10 on GRIEF's images, whose means are 12-83), at
  // least 4: the same on GRIEF as an absolute 10 (docs/evaluation.md), and a dim view keeps its lines.
  lines.min_gradient = 4.0;
  lines.min_gradient_fraction = 0.25;
  lines.max_step_px = 1.5;
  lines.max_fit_rms_px = 1.5;
  return lines;
}

ImageShiftOptions LineShiftOptions::voteWithoutChanceTest() {
  ImageShiftOptions vote;
  vote.max_chance_probability = 1.0;
  return vote;
}

void LineShiftOptions::validate() const {
  lines.validate();
  if (!(min_length_fraction > 0.0 && min_length_fraction < 1.0)) {
    throw std::invalid_argument("line shift: min_length_fraction must be in (0, 1)");
  }
  if (!(max_row_gap_fraction >= 0.0 && max_row_gap_fraction < 1.0)) {
    throw std::invalid_argument("line shift: max_row_gap_fraction must be in [0, 1)");
  }
  if (!(point_spacing_px >= 1.0) || !std::isfinite(point_spacing_px)) {
    throw std::invalid_argument("line shift: point_spacing_px must be >= 1");
  }
  vote.validate();
  if (!(min_variance_px2 > 0.0) || !std::isfinite(min_variance_px2)) {
    throw std::invalid_argument("line shift: min_variance_px2 must be > 0");
  }
  if (!(ambiguity_ratio > 0.0 && ambiguity_ratio <= 1.0)) {
    throw std::invalid_argument("line shift: ambiguity_ratio must be in (0, 1]");
  }
}

LineShift::LineShift(const LineShiftOptions& options) : options_(options), brief_(createAgastBrief(1)) {
  options_.validate();
}

Expected<LineShiftFeatures> LineShift::describe(const cv::Mat& image, const PinholeCamera* camera) {
  const auto gray = toGray8(image);
  if (!gray) return gray.status();
  if (!extractor_ || extractor_rows_ != gray->rows) {
    // The lengths for this image height (the extractor keeps its work buffers between views).
    VerticalLineOptions line_options = options_.lines;
    const double rows = static_cast<double>(gray->rows);
    line_options.min_length_px = std::max(3, static_cast<int>(std::lround(options_.min_length_fraction * rows)));
    line_options.max_row_gap = static_cast<int>(std::lround(options_.max_row_gap_fraction * rows));
    extractor_.emplace(line_options);
    extractor_rows_ = gray->rows;
  }
  auto lines = extractor_->extract(*gray, camera);
  if (!lines) return lines.status();
  LineShiftFeatures described;
  described.image_size = gray->size();
  described.points.type = FeatureType::kBrief;
  std::vector<cv::KeyPoint>& points = described.points.keypoints;
  for (std::size_t i = 0; i < lines->size(); ++i) {
    // Along the edge pixels as measured (the distorted image the descriptor samples).
    const VerticalLine& line = (*lines)[i];
    const double height = line.bottom.y() - line.top.y();
    for (double along = 0.0; along <= height; along += options_.point_spacing_px) {
      const double t = height > 0.0 ? along / height : 0.0;
      const cv::Point2f at(static_cast<float>(line.top.x() + t * (line.bottom.x() - line.top.x())),
                           static_cast<float>(line.top.y() + along));
      cv::KeyPoint point(at, 48.0F);
      point.class_id = static_cast<int>(i);
      points.push_back(point);
    }
  }
  // BRIEF drops the points whose patch leaves the image; the rest vote with their line's x.
  if (!points.empty()) brief_->compute(*gray, points, described.points.descriptors);
  for (cv::KeyPoint& point : points) point.pt.x = static_cast<float>((*lines)[static_cast<std::size_t>(point.class_id)].x);
  described.lines = std::move(*lines);
  return described;
}

Expected<ShiftHeadingFix> LineShift::measure(const LineShiftFeatures& reference, const LineShiftFeatures& current,
                                             double principal_x, std::optional<double> focal_px) const {
  const Status sizes = requireSameSize(reference.image_size, current.image_size);
  if (!sizes.isOk()) return sizes;
  if (reference.points.keypoints.empty() || current.points.keypoints.empty()) {
    return Status(StatusCode::kTooFewPoints, "no vertical line in the " +
                                                 std::string(reference.points.keypoints.empty() ? "reference" : "current") +
                                                 " view");
  }
  MatchOptions mutual_nearest;
  mutual_nearest.ratio = 1.0;
  const auto matches = matchFeatures(reference.points, current.points, mutual_nearest);
  if (!matches) return matches.status();
  return shiftFixFromMatches(toPointMatches(reference.points, current.points, *matches), reference.image_size,
                             options_.vote, {options_.min_variance_px2, options_.ambiguity_ratio}, principal_x,
                             focal_px);
}

}  // namespace homography_teach_repeat
