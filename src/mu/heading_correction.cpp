#include "homography_teach_repeat/mu/heading_correction.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace homography_teach_repeat {

void HeadingCorrectionOptions::validate() const {
  matching.validate();
  homography.validate();
  if (min_inliers < 3) throw std::invalid_argument("heading correction: min_inliers must be >= 3");
  if (!(max_sigma_px > 0.0)) throw std::invalid_argument("heading correction: max_sigma_px > 0");
}

HeadingCorrector::HeadingCorrector(const HeadingCorrectionOptions& options,
                                   const LineCamera& camera)
    : options_(options), camera_(camera) {
  options_.validate();
  const Status valid = camera_.validate();
  if (!valid.isOk()) throw std::invalid_argument("heading correction: " + valid.message());
}

Expected<HeadingCorrection> HeadingCorrector::estimate(const std::vector<VerticalLine>& reference,
                                                      const std::vector<VerticalLine>& current,
                                                      double predicted_theta) const {
  if (!std::isfinite(predicted_theta)) predicted_theta = 0.0;
  // A pure rotation (docs/math.md §4.4 with t = 0): x' = f (c x + f s)/(−s x + f c), centred.
  const double c = std::cos(predicted_theta), s = std::sin(predicted_theta), f = camera_.f;
  Eigen::Matrix2d rotation;
  rotation << c, f * s, -s / f, c;
  return estimate(reference, current, rotation);
}

Expected<HeadingCorrection> HeadingCorrector::estimate(const std::vector<VerticalLine>& reference,
                                                      const std::vector<VerticalLine>& current,
                                                      const Eigen::Matrix2d& predicted_centred_H) const {
  const bool guided = predicted_centred_H.allFinite() && !predicted_centred_H.isIdentity(0.0);
  // The reference lines where the prediction puts them, for the matcher only.
  std::vector<VerticalLine> moved;
  std::vector<int> original;  // index into `reference` of each moved line
  const Eigen::Matrix2d& G = predicted_centred_H;
  for (std::size_t i = 0; i < reference.size(); ++i) {
    VerticalLine line = reference[i];
    if (guided) {
      const double x = line.x - camera_.x0;
      const double denominator = G(1, 0) * x + G(1, 1);
      if (!(denominator > 0.0)) continue;  // behind the predicted camera
      line.x = camera_.x0 + (G(0, 0) * x + G(0, 1)) / denominator;
    }
    moved.push_back(line);
    original.push_back(static_cast<int>(i));
  }
  const auto matches = matchVerticalLines(moved, current, options_.matching);
  if (!matches) return matches.status();
  std::vector<LineCorrespondence> lines;
  lines.reserve(matches->size());
  for (const auto& m : *matches) {
    lines.push_back({reference[static_cast<std::size_t>(original[static_cast<std::size_t>(m.reference)])].x,
                     current[static_cast<std::size_t>(m.current)].x});
  }
  if (lines.size() < 3) {
    return Status(StatusCode::kTooFewPoints,
                  "only " + std::to_string(lines.size()) + " vertical line matches (" +
                      std::to_string(reference.size()) + " reference / " +
                      std::to_string(current.size()) + " current lines)");
  }
  const auto homography = estimateHomography1dLmeds(lines, options_.homography);
  if (!homography) return homography.status();
  if (static_cast<int>(homography->inliers.size()) < options_.min_inliers) {
    return Status(StatusCode::kNoConsensus,
                  std::to_string(homography->inliers.size()) + " of " +
                      std::to_string(lines.size()) + " line matches agree, need " +
                      std::to_string(options_.min_inliers));
  }
  if (!(homography->sigma_px <= options_.max_sigma_px)) {
    return Status(StatusCode::kNoConsensus,
                  "the line matches do not agree on a 1D homography (noise estimate " +
                      std::to_string(homography->sigma_px) + " px > " +
                      std::to_string(options_.max_sigma_px) + " px)");
  }
  const auto mu = muOf(homography->H, camera_.x0);
  if (!mu) return mu.status();
  const auto theta = headingFromMu(homography->H, camera_);
  if (!theta) return theta.status();
  HeadingCorrection result;
  result.theta = *theta;
  result.mu = *mu;
  result.H = homography->H;
  result.line_matches = static_cast<int>(lines.size());
  result.inliers = static_cast<int>(homography->inliers.size());
  result.sigma_px = homography->sigma_px;
  return result;
}

}  // namespace homography_teach_repeat
