#include "homography_teach_repeat/mu/shift_heading.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "homography_teach_repeat/features/feature_matcher.h"

namespace homography_teach_repeat {

std::vector<FeatureOptions> ShiftHeadingOptions::defaultFeatures() {
  FeatureOptions akaze;
  akaze.type = FeatureType::kAkaze;
  akaze.max_features = 1600;
  akaze.upright = true;
  FeatureOptions brief;
  brief.type = FeatureType::kBrief;
  brief.max_features = 1600;
  return {akaze, brief};
}

void ShiftHeadingOptions::validate() const {
  if (features.empty()) throw std::invalid_argument("shift heading: at least one feature type is needed");
  for (const FeatureOptions& f : features) f.validate();
  vote.validate();
  if (!(min_variance_px2 > 0.0) || !std::isfinite(min_variance_px2)) {
    throw std::invalid_argument("shift heading: min_variance_px2 must be > 0");
  }
  if (!(ambiguity_ratio > 0.0 && ambiguity_ratio <= 1.0)) {
    throw std::invalid_argument("shift heading: ambiguity_ratio must be in (0, 1]");
  }
}

bool ShiftHeadingFix::pickedBy(double predicted_mu) const {
  if (!std::isfinite(predicted_mu)) return false;
  if (!ambiguous) return true;
  return 2.0 * std::abs(mu - predicted_mu) < std::abs(shift.runner_up_shift_px - predicted_mu);
}

ShiftHeading::ShiftHeading(const ShiftHeadingOptions& options) : options_(options) {
  options_.validate();
  for (const FeatureOptions& f : options_.features) extractors_.emplace_back(f);
}

Expected<ShiftFeatures> ShiftHeading::describe(const cv::Mat& image) {
  ShiftFeatures described;
  described.image_size = image.size();
  for (FeatureExtractor& extractor : extractors_) {
    auto features = extractor.extract(image);
    if (!features) return features.status();
    described.sets.push_back(std::move(*features));
  }
  return described;
}

Status requireSameSize(const cv::Size& reference, const cv::Size& current) {
  if (reference == current) return Status::ok();
  return Status(StatusCode::kInvalidInput, "the views differ in size (" + std::to_string(reference.width) + "x" +
                                               std::to_string(reference.height) + " and " +
                                               std::to_string(current.width) + "x" + std::to_string(current.height) +
                                               ")");
}

Expected<ShiftHeadingFix> shiftFixFromMatches(const PointMatches& matches, const cv::Size& size,
                                              const ImageShiftOptions& vote, const ShiftFixRules& rules,
                                              double principal_x, std::optional<double> focal_px) {
  const auto shift = estimateImageShift(matches, size.width, vote, principal_x, focal_px);
  if (!shift) return shift.status();
  ShiftHeadingFix fix;
  fix.mu = shift->shift_px;
  fix.variance = shift->sigma_px * shift->sigma_px + rules.min_variance_px2;
  fix.shift = *shift;
  fix.matches = static_cast<int>(matches.size());
  fix.ambiguous = shift->runner_up_support >= rules.ambiguity_ratio * shift->support;
  return fix;
}

Expected<ShiftHeadingFix> ShiftHeading::measure(const ShiftFeatures& reference, const ShiftFeatures& current,
                                                double principal_x, std::optional<double> focal_px) const {
  const Status sizes = requireSameSize(reference.image_size, current.image_size);
  if (!sizes.isOk()) return sizes;
  if (reference.sets.size() != extractors_.size() || current.sets.size() != extractors_.size()) {
    return Status(StatusCode::kInvalidInput, "the views were not described with these feature types");
  }
  MatchOptions mutual_nearest;
  mutual_nearest.ratio = 1.0;
  PointMatches all;
  for (std::size_t i = 0; i < extractors_.size(); ++i) {
    const auto matches = matchFeatures(reference.sets[i], current.sets[i], mutual_nearest);
    if (!matches) return matches.status();
    const PointMatches these = toPointMatches(reference.sets[i], current.sets[i], *matches);
    all.insert(all.end(), these.begin(), these.end());
  }
  return shiftFixFromMatches(all, reference.image_size, options_.vote,
                             {options_.min_variance_px2, options_.ambiguity_ratio}, principal_x, focal_px);
}

}  // namespace homography_teach_repeat
