#include "homography_teach_repeat/robust_homography.h"

#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace homography_teach_repeat {
namespace {

int toOpenCvMethod(RobustMethod method) {
  switch (method) {
    case RobustMethod::kRansac:
      return cv::RANSAC;
    case RobustMethod::kLmeds:
      return cv::LMEDS;
    case RobustMethod::kMagsac:
      return cv::USAC_MAGSAC;
    case RobustMethod::kLoRansac:
      return cv::USAC_DEFAULT;
  }
  return cv::USAC_DEFAULT;
}

std::vector<int> selectInliers(const Eigen::Matrix3d& H, const PointMatches& matches,
                               double threshold_px) {
  std::vector<int> inliers;
  for (std::size_t i = 0; i < matches.size(); ++i) {
    if (transferError(H, matches[i]) < threshold_px) inliers.push_back(static_cast<int>(i));
  }
  return inliers;
}

// 95% radius of the 2D transfer error, from the median error of the current inliers.
double adaptiveThreshold(const Eigen::Matrix3d& H, const PointMatches& matches,
                         const std::vector<int>& inliers, const RobustHomographyOptions& options) {
  std::vector<double> errors;
  errors.reserve(inliers.size());
  for (int i : inliers) errors.push_back(transferError(H, matches[static_cast<std::size_t>(i)]));
  auto middle = errors.begin() + static_cast<std::ptrdiff_t>(errors.size() / 2);
  std::nth_element(errors.begin(), middle, errors.end());
  constexpr double kRayleighMedian = 1.1774;  // median of |e| for e ~ N(0, σ² I₂), in σ
  constexpr double kChi2Radius95 = 2.4477;    // sqrt(χ²₂(0.95))
  const double threshold = kChi2Radius95 * (*middle / kRayleighMedian);
  return std::clamp(threshold, options.min_adaptive_threshold_px, options.inlier_threshold_px);
}

PointMatches subset(const PointMatches& matches, const std::vector<int>& indices) {
  PointMatches out;
  out.reserve(indices.size());
  for (int i : indices) out.push_back(matches[static_cast<std::size_t>(i)]);
  return out;
}

}  // namespace

RobustMethod robustMethodFromString(const std::string& name) {
  if (name == "ransac") return RobustMethod::kRansac;
  if (name == "lmeds") return RobustMethod::kLmeds;
  if (name == "magsac") return RobustMethod::kMagsac;
  if (name == "lo_ransac") return RobustMethod::kLoRansac;
  throw std::invalid_argument("unknown robust method '" + name +
                              "' (accepted: lo_ransac, ransac, lmeds, magsac)");
}

std::string toString(RobustMethod method) {
  switch (method) {
    case RobustMethod::kRansac:
      return "ransac";
    case RobustMethod::kLmeds:
      return "lmeds";
    case RobustMethod::kMagsac:
      return "magsac";
    case RobustMethod::kLoRansac:
      return "lo_ransac";
  }
  return "lo_ransac";
}

void RobustHomographyOptions::validate() const {
  if (!(inlier_threshold_px > 0.0) || !std::isfinite(inlier_threshold_px)) {
    throw std::invalid_argument("inlier_threshold_px must be finite and > 0");
  }
  if (!(confidence > 0.0 && confidence < 1.0)) {
    throw std::invalid_argument("confidence must be in (0, 1)");
  }
  if (max_iterations < 1) throw std::invalid_argument("max_iterations must be >= 1");
  if (min_inliers < 4) throw std::invalid_argument("min_inliers must be >= 4");
  if (max_refit_rounds < 1) throw std::invalid_argument("max_refit_rounds must be >= 1");
  if (!(min_adaptive_threshold_px > 0.0) || min_adaptive_threshold_px > inlier_threshold_px) {
    throw std::invalid_argument("min_adaptive_threshold_px must be in (0, inlier_threshold_px]");
  }
}

Expected<RobustHomographyResult> estimateHomographyRobust(const PointMatches& matches,
                                                          const RobustHomographyOptions& options) {
  options.validate();
  if (matches.size() < 4) {
    return Status(StatusCode::kTooFewPoints,
                  "a homography needs at least 4 matches, got " + std::to_string(matches.size()));
  }
  std::vector<cv::Point2d> reference, current;
  reference.reserve(matches.size());
  current.reserve(matches.size());
  for (std::size_t i = 0; i < matches.size(); ++i) {
    if (!matches[i].reference.allFinite() || !matches[i].current.allFinite()) {
      return Status(StatusCode::kInvalidInput, "match " + std::to_string(i) + " is not finite");
    }
    reference.emplace_back(matches[i].reference.x(), matches[i].reference.y());
    current.emplace_back(matches[i].current.x(), matches[i].current.y());
  }

  cv::Mat mask;
  const cv::Mat selector_h =
      cv::findHomography(reference, current, toOpenCvMethod(options.method),
                         options.inlier_threshold_px, mask, options.max_iterations,
                         options.confidence);
  if (selector_h.empty()) {
    return Status(StatusCode::kNoConsensus, "the inlier selector found no homography");
  }
  std::vector<int> inliers;
  for (int i = 0; i < mask.rows; ++i) {
    if (mask.at<unsigned char>(i) != 0) inliers.push_back(i);
  }

  RobustHomographyResult result;
  for (int round = 0; round < options.max_refit_rounds; ++round) {
    if (static_cast<int>(inliers.size()) < options.min_inliers) {
      return Status(StatusCode::kNoConsensus,
                    std::to_string(inliers.size()) + " inliers, fewer than min_inliers=" +
                        std::to_string(options.min_inliers));
    }
    const auto refit = estimateHomographyDlt(subset(matches, inliers));
    if (!refit) return refit.status();
    result.H = *refit;
    result.final_threshold_px = options.adaptive_threshold
                                    ? adaptiveThreshold(result.H, matches, inliers, options)
                                    : options.inlier_threshold_px;
    std::vector<int> reselected = selectInliers(result.H, matches, result.final_threshold_px);
    // Stop when the set is stable; on the last round keep the set H was fitted on, so the
    // reported inliers are always those of the returned H.
    if (reselected == inliers || round + 1 == options.max_refit_rounds) break;
    inliers = std::move(reselected);
  }
  double sum_squared = 0.0;
  for (int i : inliers) {
    const double e = transferError(result.H, matches[static_cast<std::size_t>(i)]);
    sum_squared += e * e;
  }
  result.rms_transfer_error_px = std::sqrt(sum_squared / static_cast<double>(inliers.size()));
  result.inliers = std::move(inliers);
  return result;
}

}  // namespace homography_teach_repeat
