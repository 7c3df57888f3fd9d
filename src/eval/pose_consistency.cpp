#include "homography_teach_repeat/eval/pose_consistency.h"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>

namespace homography_teach_repeat {

Expected<double> normalizedEstimationErrorSquared(const Pose2D& estimate, const Eigen::Matrix3d& covariance,
                                                  const Pose2D& truth) {
  auto reject = [](const char* why) { return Status(StatusCode::kInvalidInput, why); };
  if (!estimate.isFinite() || !truth.isFinite()) return reject("non-finite pose");
  if (!covariance.allFinite()) return reject("non-finite covariance");
  // Relative tolerance: the covariance comes from a float64 message, symmetric up to rounding.
  if ((covariance - covariance.transpose()).cwiseAbs().maxCoeff() >
      1e-9 * covariance.cwiseAbs().maxCoeff()) {
    return reject("asymmetric covariance");
  }
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(covariance);
  if (ldlt.info() != Eigen::Success || (ldlt.vectorD().array() <= 0.0).any()) {
    return reject("covariance not positive definite");
  }
  const Eigen::Vector3d error(estimate.x - truth.x, estimate.y - truth.y,
                              wrapToPi(estimate.yaw - truth.yaw));
  return error.dot(ldlt.solve(error));
}

Status PoseConsistency::add(const Pose2D& estimate, const Eigen::Matrix3d& covariance,
                            const Pose2D& truth) {
  const auto nees = normalizedEstimationErrorSquared(estimate, covariance, truth);
  if (!nees) {
    ++rejected_;
    return nees.status();
  }
  Sample s{};
  s.position_error_squared = std::pow(estimate.x - truth.x, 2) + std::pow(estimate.y - truth.y, 2);
  s.heading_error_squared = std::pow(wrapToPi(estimate.yaw - truth.yaw), 2);
  s.position_variance = covariance(0, 0) + covariance(1, 1);
  s.heading_variance = covariance(2, 2);
  s.nees = *nees;
  samples_.push_back(s);
  return Status::ok();
}

Expected<PoseConsistencySummary> PoseConsistency::summary() const {
  if (samples_.empty()) return Status(StatusCode::kTooFewPoints, "no pose scored");
  PoseConsistencySummary out;
  out.samples = samples_.size();
  std::vector<double> nees;
  nees.reserve(samples_.size());
  double position_error = 0.0, heading_error = 0.0, position_variance = 0.0, heading_variance = 0.0;
  std::size_t above = 0;
  for (const Sample& s : samples_) {
    position_error += s.position_error_squared;
    heading_error += s.heading_error_squared;
    position_variance += s.position_variance;
    heading_variance += s.heading_variance;
    out.nees_mean += s.nees;
    if (s.nees > kChiSquare3Dof95) ++above;
    nees.push_back(s.nees);
  }
  const auto n = static_cast<double>(samples_.size());
  out.position_error_rms = std::sqrt(position_error / n);
  out.heading_error_rms = std::sqrt(heading_error / n);
  out.position_sigma_rms = std::sqrt(position_variance / n);
  out.heading_sigma_rms = std::sqrt(heading_variance / n);
  out.nees_mean /= n;
  out.fraction_above_chi2_95 = static_cast<double>(above) / n;
  const auto middle = nees.begin() + static_cast<std::ptrdiff_t>(nees.size() / 2);
  std::nth_element(nees.begin(), middle, nees.end());
  out.nees_median = *middle;
  if (nees.size() % 2 == 0)
    out.nees_median = 0.5 * (out.nees_median + *std::max_element(nees.begin(), middle));
  return out;
}

Status IntegrityScore::add(const Pose2D& estimate, bool flagged, const Pose2D& truth) {
  if (!estimate.isFinite() || !truth.isFinite()) return Status(StatusCode::kInvalidInput, "integrity score: non-finite pose");
  const bool wrong = std::hypot(estimate.x - truth.x, estimate.y - truth.y) > wrong_position_ ||
                     std::abs(wrapToPi(estimate.yaw - truth.yaw)) > wrong_heading_;
  ++counts_.poses;
  if (wrong) {
    ++counts_.wrong;
    if (flagged) ++counts_.wrong_flagged;
  } else {
    ++counts_.right;
    if (flagged) ++counts_.right_flagged;
  }
  return Status::ok();
}

IntegritySummary IntegrityScore::summary() const {
  IntegritySummary s = counts_;
  s.detection = s.wrong > 0 ? static_cast<double>(s.wrong_flagged) / static_cast<double>(s.wrong) : 1.0;
  s.false_alarm = s.right > 0 ? static_cast<double>(s.right_flagged) / static_cast<double>(s.right) : 0.0;
  return s;
}

}  // namespace homography_teach_repeat
