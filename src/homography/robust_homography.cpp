#include "homography_teach_repeat/homography/homography.h"
#include "homography_teach_repeat/homography/robust_homography.h"

#include "homography_teach_repeat/homography/homography_refinement.h"

#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>
#include <random>
#include <stdexcept>

namespace homography_teach_repeat {
namespace {

// The selector runs again at the measured scale when that is below this share of its threshold.
constexpr double kReselectionScaleRatio = 0.8;

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

// Transfer error of every match under H: computed once per refit round, then shared by the
// threshold estimate, the re-selection, the RMS and the MSAC cost.
std::vector<double> transferErrors(const Eigen::Matrix3d& H, const PointMatches& matches) {
  std::vector<double> errors;
  errors.reserve(matches.size());
  for (const auto& match : matches) errors.push_back(transferError(H, match));
  return errors;
}

std::vector<int> selectInliers(const std::vector<double>& errors, double threshold_px) {
  std::vector<int> inliers;
  for (std::size_t i = 0; i < errors.size(); ++i) {
    if (errors[i] < threshold_px) inliers.push_back(static_cast<int>(i));
  }
  return inliers;
}

// 95% radius of the 2D transfer error, from the median error of the current inliers.
double adaptiveThreshold(const std::vector<double>& errors, const std::vector<int>& inliers,
                         const RobustHomographyOptions& options) {
  std::vector<double> inlier_errors;
  inlier_errors.reserve(inliers.size());
  for (int i : inliers) inlier_errors.push_back(errors[static_cast<std::size_t>(i)]);
  auto middle = inlier_errors.begin() + static_cast<std::ptrdiff_t>(inlier_errors.size() / 2);
  std::nth_element(inlier_errors.begin(), middle, inlier_errors.end());
  constexpr double kRayleighMedian = 1.1774;  // median of |e| for e ~ N(0, σ² I₂), in σ
  constexpr double kChi2Radius95 = 2.4477;    // sqrt(χ²₂(0.95))
  const double threshold = kChi2Radius95 * (*middle / kRayleighMedian);
  return std::clamp(threshold, options.min_adaptive_threshold_px, options.inlier_threshold_px);
}

// Σ min(e², τ²) / (n τ²) over every match under H: the MSAC cost at τ.
double msacCost(const std::vector<double>& errors, double tau) {
  const double tau_squared = tau * tau;
  double cost = 0.0;
  for (double e : errors) cost += std::isfinite(e) ? std::min(e * e, tau_squared) : tau_squared;
  return cost / (static_cast<double>(errors.size()) * tau_squared);
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
  if (hypotheses < 1) throw std::invalid_argument("hypotheses must be >= 1");
  if (!(min_adaptive_threshold_px > 0.0) || min_adaptive_threshold_px > inlier_threshold_px) {
    throw std::invalid_argument("min_adaptive_threshold_px must be in (0, inlier_threshold_px]");
  }
}

namespace {

// One selector run on the matches in the order `order`, then the iterated normalised-DLT refit.
Expected<RobustHomographyResult> selectAndRefit(const PointMatches& matches,
                                                const std::vector<int>& order,
                                                const RobustHomographyOptions& options) {
  std::vector<cv::Point2d> reference, current;
  reference.reserve(order.size());
  current.reserve(order.size());
  for (int i : order) {
    const PointMatch& m = matches[static_cast<std::size_t>(i)];
    reference.emplace_back(m.reference.x(), m.reference.y());
    current.emplace_back(m.current.x(), m.current.y());
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
  for (int k = 0; k < mask.rows; ++k) {
    if (mask.at<unsigned char>(k) != 0) inliers.push_back(order[static_cast<std::size_t>(k)]);
  }
  std::sort(inliers.begin(), inliers.end());

  RobustHomographyResult result;
  std::vector<double> errors;  // of every match under result.H
  for (int round = 0; round < options.max_refit_rounds; ++round) {
    if (static_cast<int>(inliers.size()) < options.min_inliers) {
      return Status(StatusCode::kNoConsensus,
                    std::to_string(inliers.size()) + " inliers, fewer than min_inliers=" +
                        std::to_string(options.min_inliers));
    }
    const auto refit = estimateHomographyDlt(subset(matches, inliers));
    if (!refit) return refit.status();
    result.H = *refit;
    errors = transferErrors(result.H, matches);
    result.final_threshold_px = options.adaptive_threshold
                                    ? adaptiveThreshold(errors, inliers, options)
                                    : options.inlier_threshold_px;
    std::vector<int> reselected = selectInliers(errors, result.final_threshold_px);
    // Stop when the set is stable; on the last round keep the set H was fitted on, so the
    // reported inliers are always those of the returned H.
    if (reselected == inliers || round + 1 == options.max_refit_rounds) break;
    inliers = std::move(reselected);
  }
  double sum_squared = 0.0;
  for (int i : inliers) {
    const double e = errors[static_cast<std::size_t>(i)];
    sum_squared += e * e;
  }
  result.rms_transfer_error_px = std::sqrt(sum_squared / static_cast<double>(inliers.size()));
  result.msac_cost = msacCost(errors, options.inlier_threshold_px);
  result.inliers = std::move(inliers);
  return result;
}

// `hypotheses` selector runs on permutations of the matches (permutation k seeded with k), each
// refitted; the refit with the lowest MSAC cost at options.inlier_threshold_px.
Expected<RobustHomographyResult> bestOfHypotheses(const PointMatches& matches,
                                                  const RobustHomographyOptions& options) {
  std::vector<int> order(matches.size());
  std::iota(order.begin(), order.end(), 0);
  std::optional<RobustHomographyResult> best;
  Status last_failure;
  for (int hypothesis = 0; hypothesis < options.hypotheses; ++hypothesis) {
    if (hypothesis > 0) {
      std::mt19937 rng(static_cast<unsigned>(hypothesis));
      std::shuffle(order.begin(), order.end(), rng);
    }
    auto candidate = selectAndRefit(matches, order, options);
    if (!candidate) {
      last_failure = candidate.status();
      continue;
    }
    if (!best || candidate->msac_cost < best->msac_cost) best = std::move(candidate.value());
  }
  if (!best) return last_failure;
  return std::move(*best);
}

}  // namespace

Expected<RobustHomographyResult> estimateHomographyRobust(const PointMatches& matches,
                                                          const RobustHomographyOptions& options) {
  options.validate();
  if (matches.size() < 4) {
    return Status(StatusCode::kTooFewPoints,
                  "a homography needs at least 4 matches, got " + std::to_string(matches.size()));
  }
  for (std::size_t i = 0; i < matches.size(); ++i) {
    if (!matches[i].reference.allFinite() || !matches[i].current.allFinite()) {
      return Status(StatusCode::kInvalidInput, "match " + std::to_string(i) + " is not finite");
    }
  }
  auto best = bestOfHypotheses(matches, options);
  if (!best) return best.status();
  // The selector at the measured scale: where the noise the inliers show is well below the
  // threshold the selector ran at, a compromise of two structures can have won at that threshold
  // (header). Run again with the measured threshold, and keep whichever costs less at it.
  // (Without the adaptive threshold the measured one is inlier_threshold_px, and none runs; it is
  // never below min_adaptive_threshold_px, so the options stay valid.)
  const double measured_scale = best->final_threshold_px;
  if (options.reselect_at_measured_scale &&
      measured_scale < kReselectionScaleRatio * options.inlier_threshold_px) {
    RobustHomographyOptions at_scale = options;
    at_scale.inlier_threshold_px = measured_scale;
    auto rerun = bestOfHypotheses(matches, at_scale);
    if (rerun) {
      const std::vector<double> rerun_errors = transferErrors(rerun->H, matches);
      if (msacCost(rerun_errors, measured_scale) <
          msacCost(transferErrors(best->H, matches), measured_scale)) {
        rerun->msac_cost = msacCost(rerun_errors, options.inlier_threshold_px);  // as documented
        best = std::move(rerun);
      }
    }
  }
  if (options.refine_nonlinear) {
    PointMatches inliers;
    for (const int i : best->inliers) inliers.push_back(matches[static_cast<std::size_t>(i)]);
    const auto refined = refineHomographySampson(best->H, inliers);
    if (!refined) return refined.status();
    best->H = refined->H;
    best->rms_transfer_error_px = rmsTransferError(best->H, inliers);
  }
  return std::move(*best);
}

}  // namespace homography_teach_repeat
