#include "homography_teach_repeat/eval/pose_fusion.h"

#include <Eigen/Cholesky>

#include <string>

namespace homography_teach_repeat {

Expected<PoseWithCovariance> fusePoseEstimates(const std::vector<PoseWithCovariance>& estimates) {
  if (estimates.empty()) return Status(StatusCode::kInvalidInput, "no pose estimate to fuse");
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  Eigen::Vector3d weighted_sum = Eigen::Vector3d::Zero();
  const double reference_angle = estimates.front().pose.theta;
  for (std::size_t i = 0; i < estimates.size(); ++i) {
    const auto& e = estimates[i];
    const Eigen::Matrix3d& cov = e.covariance;
    if (!e.pose.isFinite() || !cov.allFinite() ||
        !cov.isApprox(cov.transpose(), 1e-9 * (1.0 + cov.norm()))) {
      return Status(StatusCode::kInvalidInput,
                    "pose estimate " + std::to_string(i) + " is not finite or not symmetric");
    }
    const Eigen::LLT<Eigen::Matrix3d> llt(cov);
    if (llt.info() != Eigen::Success) {
      return Status(StatusCode::kInvalidInput, "covariance of pose estimate " + std::to_string(i) +
                                                   " is not positive definite");
    }
    const Eigen::Matrix3d inverse = llt.solve(Eigen::Matrix3d::Identity());
    const Eigen::Vector3d x(e.pose.x, e.pose.z,
                            reference_angle + wrapToPi(e.pose.theta - reference_angle));
    information += inverse;
    weighted_sum += inverse * x;
  }
  const Eigen::LLT<Eigen::Matrix3d> llt(information);
  if (llt.info() != Eigen::Success) {
    return Status(StatusCode::kInvalidInput, "fused information matrix is not positive definite");
  }
  PoseWithCovariance fused;
  fused.covariance = llt.solve(Eigen::Matrix3d::Identity());
  fused.covariance = 0.5 * (fused.covariance + fused.covariance.transpose());
  const Eigen::Vector3d x = fused.covariance * weighted_sum;
  fused.pose = PlanarPose(x(0), x(1), wrapToPi(x(2)));
  return fused;
}

}  // namespace homography_teach_repeat
