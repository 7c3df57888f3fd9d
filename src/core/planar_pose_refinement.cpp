#include "homography_teach_repeat/planar_pose_refinement.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include <array>
#include <cmath>
#include <string>

namespace homography_teach_repeat {
namespace {

using Matrix23d = Eigen::Matrix<double, 2, 3>;
using Matrix43d = Eigen::Matrix<double, 4, 3>;

// dπ/dq for π(q) = (q1/q3, q2/q3).
Matrix23d projectionJacobian(const Eigen::Vector3d& q) {
  Matrix23d j;
  const double w = 1.0 / q.z();
  j << w, 0.0, -q.x() * w * w, 0.0, w, -q.y() * w * w;
  return j;
}

// The model homography and its derivatives with respect to (Cx, Cz, θ12) for one plane.
struct ModelHomography {
  Eigen::Matrix3d H;
  Eigen::Matrix3d H_inverse;
  std::array<Eigen::Matrix3d, 3> dH;
};

bool buildModel(const PinholeCamera& camera, const PlanarPose& pose, const ScenePlane& plane,
                ModelHomography* model) {
  const Eigen::Matrix3d K = camera.K();
  const Eigen::Matrix3d K_inverse = camera.Kinverse();
  const Eigen::Matrix3d R21 = pose.rotation21();
  const Eigen::RowVector3d n_over_d = plane.normal.transpose() / plane.distance;
  const Eigen::Matrix3d plane_term = Eigen::Matrix3d::Identity() - pose.centre() * n_over_d;
  model->H = K * R21 * plane_term * K_inverse;
  // det H ∝ det(I − C nᵀ/d) = 1 − nᵀC/d = (distance of camera 2 to the plane)/d.
  const double relative_distance = 1.0 - n_over_d.dot(pose.centre());
  if (!(std::abs(relative_distance) > 1e-9)) return false;
  model->H_inverse = model->H.inverse();
  model->dH[0] = -K * R21 * Eigen::Vector3d::UnitX() * n_over_d * K_inverse;
  model->dH[1] = -K * R21 * Eigen::Vector3d::UnitZ() * n_over_d * K_inverse;
  // R21 = Ry(θ21), θ21 = −θ12: dR21/dθ12 = −Ry'(θ21).
  const double theta21 = -pose.theta;
  Eigen::Matrix3d d_rotation;
  d_rotation << -std::sin(theta21), 0.0, -std::cos(theta21), 0.0, 0.0, 0.0, std::cos(theta21), 0.0,
      -std::sin(theta21);
  model->dH[2] = -K * d_rotation * plane_term * K_inverse;
  return model->H.allFinite() && model->H_inverse.allFinite();
}

struct MatchLinearization {
  Eigen::Vector4d residual;
  Matrix43d jacobian;                  // ∂r/∂(Cx, Cz, θ12)
  Eigen::Matrix4d measurement_jacobian;  // ∂r/∂(u, v, u', v')
};

bool linearize(const ModelHomography& model, const PointMatch& match, MatchLinearization* out) {
  const Eigen::Vector3d p = match.reference.homogeneous();
  const Eigen::Vector3d p2 = match.current.homogeneous();
  const Eigen::Vector3d q = model.H * p;
  const Eigen::Vector3d q_back = model.H_inverse * p2;
  if (!(std::abs(q.z()) > 1e-12) || !(std::abs(q_back.z()) > 1e-12)) return false;
  out->residual.head<2>() = match.current - q.hnormalized();
  out->residual.tail<2>() = match.reference - q_back.hnormalized();
  const Matrix23d dpi = projectionJacobian(q);
  const Matrix23d dpi_back = projectionJacobian(q_back);
  for (int k = 0; k < 3; ++k) {
    out->jacobian.block<2, 1>(0, k) = -dpi * (model.dH[k] * p);
    // d(H⁻¹) = −H⁻¹ dH H⁻¹.
    out->jacobian.block<2, 1>(2, k) = dpi_back * (model.H_inverse * (model.dH[k] * q_back));
  }
  out->measurement_jacobian.setZero();
  out->measurement_jacobian.block<2, 2>(0, 0) = -dpi * model.H.leftCols<2>();
  out->measurement_jacobian.block<2, 2>(0, 2).setIdentity();
  out->measurement_jacobian.block<2, 2>(2, 0).setIdentity();
  out->measurement_jacobian.block<2, 2>(2, 2) = -dpi_back * model.H_inverse.leftCols<2>();
  return out->residual.allFinite() && out->jacobian.allFinite();
}

// Accumulates JᵀJ, Jᵀr and the cost at a pose; false when the model is degenerate there.
struct NormalEquations {
  Eigen::Matrix3d JtJ = Eigen::Matrix3d::Zero();
  Eigen::Vector3d Jtr = Eigen::Vector3d::Zero();
  Eigen::Matrix3d measurement_information = Eigen::Matrix3d::Zero();  // Σ Jᵢᵀ Rᵢ Rᵢᵀ Jᵢ
  double cost = 0.0;
};

bool accumulate(const PinholeCamera& camera, const PlanarPose& pose,
                const std::vector<PlaneMatches>& planes, bool with_covariance,
                NormalEquations* eq) {
  *eq = NormalEquations();
  MatchLinearization lin;
  for (const auto& group : planes) {
    ModelHomography model;
    if (!buildModel(camera, pose, group.plane, &model)) return false;
    for (const auto& match : group.matches) {
      if (!linearize(model, match, &lin)) return false;
      eq->JtJ.noalias() += lin.jacobian.transpose() * lin.jacobian;
      eq->Jtr.noalias() += lin.jacobian.transpose() * lin.residual;
      eq->cost += lin.residual.squaredNorm();
      if (with_covariance) {
        const Matrix43d weighted = lin.measurement_jacobian.transpose() * lin.jacobian;
        eq->measurement_information.noalias() += weighted.transpose() * weighted;
      }
    }
  }
  return std::isfinite(eq->cost);
}

}  // namespace

Eigen::Matrix3d poseHomography(const PinholeCamera& camera, const PlanarPose& pose,
                               const ScenePlane& plane) {
  return camera.K() * pose.rotation21() *
         (Eigen::Matrix3d::Identity() - pose.centre() * plane.normal.transpose() / plane.distance) *
         camera.Kinverse();
}

Expected<RefinedPlanarPose> refinePlanarPose(const PlanarPose& initial,
                                             const std::vector<PlaneMatches>& planes,
                                             const PinholeCamera& camera,
                                             const PoseRefinementOptions& options) {
  if (!initial.isFinite()) {
    return Status(StatusCode::kInvalidInput, "initial pose for the refinement is not finite");
  }
  if (options.max_iterations < 1 || !std::isfinite(options.sigma_px) || options.sigma_px < 0.0 ||
      !(options.convergence_step > 0.0)) {
    return Status(StatusCode::kInvalidInput,
                  "refinement options: max_iterations >= 1, sigma_px >= 0, convergence_step > 0");
  }
  std::size_t total = 0;
  for (const auto& group : planes) {
    const Status plane_status = group.plane.validate();
    if (plane_status.code() == StatusCode::kInvalidInput) return plane_status;
    for (const auto& m : group.matches) {
      if (!m.reference.allFinite() || !m.current.allFinite()) {
        return Status(StatusCode::kInvalidInput, "a match for the refinement is not finite");
      }
    }
    total += group.matches.size();
  }
  if (total < 2) {
    return Status(StatusCode::kTooFewPoints,
                  "pose refinement needs at least 2 matches, got " + std::to_string(total));
  }

  PlanarPose pose = initial;
  NormalEquations eq;
  if (!accumulate(camera, pose, planes, false, &eq)) {
    return Status(StatusCode::kDegenerate, "initial pose puts the camera on a plane");
  }
  double lambda = 1e-6;
  int iteration = 0;
  for (; iteration < options.max_iterations; ++iteration) {
    const double max_diagonal = eq.JtJ.diagonal().maxCoeff();
    if (!(max_diagonal > 0.0)) {
      return Status(StatusCode::kDegenerate, "pose refinement: zero Jacobian");
    }
    bool improved = false;
    Eigen::Vector3d step = Eigen::Vector3d::Zero();
    for (int attempt = 0; attempt < 20 && !improved; ++attempt) {
      Eigen::Matrix3d damped = eq.JtJ;
      damped.diagonal() += lambda * eq.JtJ.diagonal();
      const Eigen::LDLT<Eigen::Matrix3d> ldlt(damped);
      if (ldlt.info() != Eigen::Success) {
        return Status(StatusCode::kDegenerate, "pose refinement: singular normal equations");
      }
      // r = z − f(p): the Gauss-Newton step solves JᵀJ δ = −Jᵀr with J = ∂r/∂p.
      step = -ldlt.solve(eq.Jtr);
      const PlanarPose candidate(pose.x + step(0), pose.z + step(1),
                                 wrapToPi(pose.theta + step(2)));
      NormalEquations candidate_eq;
      if (accumulate(camera, candidate, planes, false, &candidate_eq) &&
          candidate_eq.cost <= eq.cost) {
        pose = candidate;
        eq = candidate_eq;
        lambda = std::max(lambda * 0.1, 1e-12);
        improved = true;
      } else {
        lambda *= 10.0;
      }
    }
    const bool converged = step.head<2>().norm() < options.convergence_step &&
                           std::abs(step(2)) < options.convergence_step;
    if (!improved || converged) {
      ++iteration;
      break;
    }
  }

  if (!accumulate(camera, pose, planes, true, &eq)) {
    return Status(StatusCode::kDegenerate, "refined pose puts the camera on a plane");
  }
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(eq.JtJ);
  if (!lu.isInvertible() || lu.rcond() < 1e-14) {
    return Status(StatusCode::kDegenerate,
                  "pose refinement: the matches do not constrain all of (x, z, θ)");
  }
  const Eigen::Matrix3d JtJ_inverse = lu.inverse();
  RefinedPlanarPose result;
  result.pose = pose;
  result.covariance = options.sigma_px * options.sigma_px * JtJ_inverse *
                      eq.measurement_information * JtJ_inverse;
  result.covariance = 0.5 * (result.covariance + result.covariance.transpose());
  result.rms_transfer_error_px = std::sqrt(eq.cost / (2.0 * static_cast<double>(total)));
  result.iterations = iteration;
  if (!result.pose.isFinite() || !result.covariance.allFinite()) {
    return Status(StatusCode::kNotFinite, "pose refinement produced a non-finite result");
  }
  return result;
}

}  // namespace homography_teach_repeat
