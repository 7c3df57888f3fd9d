#include "homography_teach_repeat/fast_hd/planar_pose_refinement.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include <array>
#include <cmath>
#include <string>

#include "homography_teach_repeat/geometry/camera_tilt.h"

namespace homography_teach_repeat {
namespace {

using Matrix23d = Eigen::Matrix<double, 2, 3>;
// Parameters: (Cx, Cz, θ12) and the nuisance (Cy, pitch, roll) of the current camera.
constexpr int kParameters = 6;
using Vector6d = Eigen::Matrix<double, kParameters, 1>;
using Matrix6d = Eigen::Matrix<double, kParameters, kParameters>;
using Matrix46d = Eigen::Matrix<double, 4, kParameters>;

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
  std::array<Eigen::Matrix3d, kParameters> dH;  // (Cx, Cz, θ12, Cy, pitch, roll)
};

// The estimated state: the planar pose plus the nuisance parameters: the camera's height offset
// Cy and the current camera's tilt (pitch about its x axis, roll about its z axis), each fixed at 0
// unless estimated (PoseRefinementOptions).
struct State {
  PlanarPose pose;
  double height = 0.0;
  double pitch = 0.0;
  double roll = 0.0;
  Eigen::Vector3d centre() const { return Eigen::Vector3d(pose.x, height, pose.z); }
};

bool buildModel(const PinholeCamera& camera, const State& state, const ScenePlane& plane,
                ModelHomography* model) {
  const PlanarPose& pose = state.pose;
  const Eigen::Matrix3d K = camera.K();
  const Eigen::Matrix3d K_inverse = camera.Kinverse();
  const Eigen::Matrix3d R21 = pose.rotation21();
  const Eigen::RowVector3d n_over_d = plane.normal.transpose() / plane.distance;
  const Eigen::Matrix3d plane_term = Eigen::Matrix3d::Identity() - state.centre() * n_over_d;
  // The current camera's tilt T = Rx(pitch) Rz(roll) rotates its rays after the planar motion.
  const CameraTilt tilt = cameraTilt(state.pitch, state.roll);
  const Eigen::Matrix3d KT = K * tilt.T;
  model->H = KT * R21 * plane_term * K_inverse;
  // det H ∝ det(I − C nᵀ/d) = 1 − nᵀC/d = (distance of camera 2 to the plane)/d.
  const double relative_distance = 1.0 - n_over_d.dot(state.centre());
  if (!(std::abs(relative_distance) > 1e-9)) return false;
  model->H_inverse = model->H.inverse();
  model->dH[0] = -KT * R21 * Eigen::Vector3d::UnitX() * n_over_d * K_inverse;
  model->dH[1] = -KT * R21 * Eigen::Vector3d::UnitZ() * n_over_d * K_inverse;
  // R21 = Ry(θ21), θ21 = −θ12: dR21/dθ12 = −Ry'(θ21).
  const double theta21 = -pose.theta;
  Eigen::Matrix3d d_rotation;
  d_rotation << -std::sin(theta21), 0.0, -std::cos(theta21), 0.0, 0.0, 0.0, std::cos(theta21), 0.0,
      -std::sin(theta21);
  model->dH[2] = -KT * d_rotation * plane_term * K_inverse;
  model->dH[3] = -KT * R21 * Eigen::Vector3d::UnitY() * n_over_d * K_inverse;
  model->dH[4] = K * tilt.dT_dpitch * R21 * plane_term * K_inverse;
  model->dH[5] = K * tilt.dT_droll * R21 * plane_term * K_inverse;
  return model->H.allFinite() && model->H_inverse.allFinite();
}

struct MatchLinearization {
  Eigen::Vector4d residual;
  Matrix46d jacobian;                  // ∂r/∂(Cx, Cz, θ12, Cy, pitch, roll)
  Eigen::Matrix4d measurement_jacobian;  // ∂r/∂(u, v, u', v')
};

// The algebraic DLT residual ε = A_i h of one match for a homography G (docs/math.md §3.1), linear in
// G; used with the model H and with its derivatives dH_k.
Eigen::Vector2d algebraicResidual(const Eigen::Matrix3d& G, const Eigen::Vector3d& p,
                                  const Eigen::Vector2d& current) {
  const double g3p = G.row(2).dot(p);
  return Eigen::Vector2d(-G.row(1).dot(p) + current.y() * g3p, G.row(0).dot(p) - current.x() * g3p);
}

// Sampson: r = W ε with W = (B Bᵀ)^(-1/2) (Cholesky), B = ∂ε/∂(u, v, u', v') (docs/math.md §3.4):
// the first-order geometric distance in the joint image space, the ML cost for iid pixel noise
// in both images. W is frozen within a Gauss-Newton step (its derivative is second order).
bool linearizeSampson(const ModelHomography& model, const PointMatch& match,
                      MatchLinearization* out) {
  const Eigen::Vector3d p = match.reference.homogeneous();
  const Eigen::Matrix3d& H = model.H;
  const double h3p = H.row(2).dot(p);
  Eigen::Matrix<double, 2, 4> b;
  b << -H(1, 0) + match.current.y() * H(2, 0), -H(1, 1) + match.current.y() * H(2, 1), 0.0, h3p,
      H(0, 0) - match.current.x() * H(2, 0), H(0, 1) - match.current.x() * H(2, 1), -h3p, 0.0;
  const Eigen::LLT<Eigen::Matrix2d> llt(b * b.transpose());
  if (llt.info() != Eigen::Success) return false;
  const Eigen::Matrix2d W = llt.matrixL().solve(Eigen::Matrix2d::Identity());
  out->residual.setZero();
  out->jacobian.setZero();
  out->measurement_jacobian.setZero();
  out->residual.head<2>() = W * algebraicResidual(H, p, match.current);
  // J = ∂r/∂p = W ∂ε/∂p; ε is linear in H, so ∂ε/∂p_k = ε(dH_k).
  for (int k = 0; k < kParameters; ++k) {
    out->jacobian.block<2, 1>(0, k) = W * algebraicResidual(model.dH[k], p, match.current);
  }
  out->measurement_jacobian.topRows<2>() = W * b;
  return out->residual.allFinite() && out->jacobian.allFinite();
}

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
  for (int k = 0; k < kParameters; ++k) {
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
  Matrix6d JtJ = Matrix6d::Zero();
  Vector6d Jtr = Vector6d::Zero();
  Matrix6d measurement_information = Matrix6d::Zero();  // Σ Jᵢᵀ Rᵢ Rᵢᵀ Jᵢ
  // The same over the reference image's coordinates (u, v) only: the part of the pixel noise that
  // every fix against this reference shares.
  Matrix6d reference_information = Matrix6d::Zero();
  double cost = 0.0;
};

// Which nuisance parameters are estimated, and the tilt's prior weight (σ_px / σ_tilt)².
struct Nuisance {
  bool height = false;
  bool tilt = false;
  double tilt_weight = 0.0;
};

bool accumulate(const PinholeCamera& camera, const State& state,
                const std::vector<PlaneMatches>& planes, RefinementCost cost,
                const Nuisance& nuisance, bool with_covariance, NormalEquations* eq) {
  *eq = NormalEquations();
  MatchLinearization lin;
  for (const auto& group : planes) {
    ModelHomography model;
    if (!buildModel(camera, state, group.plane, &model)) return false;
    for (const auto& match : group.matches) {
      const bool ok = cost == RefinementCost::kSampson ? linearizeSampson(model, match, &lin)
                                                       : linearize(model, match, &lin);
      if (!ok) return false;
      if (!nuisance.height) lin.jacobian.col(3).setZero();
      if (!nuisance.tilt) lin.jacobian.rightCols<2>().setZero();
      eq->JtJ.noalias() += lin.jacobian.transpose() * lin.jacobian;
      eq->Jtr.noalias() += lin.jacobian.transpose() * lin.residual;
      eq->cost += lin.residual.squaredNorm();
      if (with_covariance) {
        const Matrix46d weighted = lin.measurement_jacobian.transpose() * lin.jacobian;
        eq->measurement_information.noalias() += weighted.transpose() * weighted;
        // weighted's rows are the coordinates (u, v, u', v'): the first two the reference's.
        eq->reference_information.noalias() += weighted.topRows<2>().transpose() * weighted.topRows<2>();
      }
    }
  }
  // A fixed parameter: an identity row keeps the system regular and its step zero.
  if (!nuisance.height) eq->JtJ(3, 3) = 1.0;
  if (nuisance.tilt) {
    // The tilt's prior (zero mean, σ_tilt) as residuals √w·(pitch, roll) in the units of the
    // pixel residuals, so that σ_px² (JᵀJ)⁻¹ gives it σ_tilt alone.
    for (int k = 4; k < 6; ++k) {
      const double value = k == 4 ? state.pitch : state.roll;
      eq->JtJ(k, k) += nuisance.tilt_weight;
      eq->Jtr(k) += nuisance.tilt_weight * value;
      eq->cost += nuisance.tilt_weight * value * value;
      if (with_covariance) eq->measurement_information(k, k) += nuisance.tilt_weight;
    }
  } else {
    eq->JtJ(4, 4) = 1.0;
    eq->JtJ(5, 5) = 1.0;
  }
  return std::isfinite(eq->cost);
}

}  // namespace

std::pair<Eigen::Vector3d, Eigen::Vector3d> directionsAcrossNormal(const Eigen::Vector3d& normal) {
  const Eigen::Vector3d n = normal.normalized();
  const Eigen::Vector3d helper = std::abs(n.y()) < 0.9 ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d across1 = n.cross(helper).normalized();
  return {across1, n.cross(across1)};
}

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

  State state;
  state.pose = initial;
  Nuisance nuisance;
  nuisance.height = options.estimate_height_offset;
  nuisance.tilt = options.tilt_sigma_rad > 0.0;
  if (nuisance.tilt) {
    // With sigma_px = 0 (no covariance wanted) the prior still needs a pixel scale: 1 px.
    const double pixel = options.sigma_px > 0.0 ? options.sigma_px : 1.0;
    nuisance.tilt_weight = std::pow(pixel / options.tilt_sigma_rad, 2);
  }
  NormalEquations eq;
  if (!accumulate(camera, state, planes, options.cost, nuisance, false, &eq)) {
    return Status(StatusCode::kDegenerate, "initial pose puts the camera on a plane");
  }
  double lambda = 1e-6;
  int iteration = 0;
  for (; iteration < options.max_iterations; ++iteration) {
    if (!(eq.JtJ.diagonal().head<3>().maxCoeff() > 0.0)) {
      return Status(StatusCode::kDegenerate, "pose refinement: zero Jacobian");
    }
    bool improved = false;
    Vector6d step = Vector6d::Zero();
    for (int attempt = 0; attempt < 20 && !improved; ++attempt) {
      Matrix6d damped = eq.JtJ;
      damped.diagonal() += lambda * eq.JtJ.diagonal();
      const Eigen::LDLT<Matrix6d> ldlt(damped);
      if (ldlt.info() != Eigen::Success) {
        return Status(StatusCode::kDegenerate, "pose refinement: singular normal equations");
      }
      // The Gauss-Newton step solves JᵀJ δ = −Jᵀr with J = ∂r/∂p.
      step = -ldlt.solve(eq.Jtr);
      State candidate;
      candidate.pose = PlanarPose(state.pose.x + step(0), state.pose.z + step(1),
                                  wrapToPi(state.pose.theta + step(2)));
      candidate.height = state.height + step(3);
      candidate.pitch = state.pitch + step(4);
      candidate.roll = state.roll + step(5);
      NormalEquations candidate_eq;
      if (accumulate(camera, candidate, planes, options.cost, nuisance, false, &candidate_eq) &&
          candidate_eq.cost <= eq.cost) {
        state = candidate;
        eq = candidate_eq;
        lambda = std::max(lambda * 0.1, 1e-12);
        improved = true;
      } else {
        lambda *= 10.0;
      }
    }
    const bool converged = Eigen::Vector3d(step(0), step(1), step(3)).norm() <
                               options.convergence_step &&
                           std::abs(step(2)) < options.convergence_step &&
                           step.tail<2>().cwiseAbs().maxCoeff() < options.convergence_step;
    if (!improved || converged) {
      ++iteration;
      break;
    }
  }

  if (!accumulate(camera, state, planes, options.cost, nuisance, true, &eq)) {
    return Status(StatusCode::kDegenerate, "refined pose puts the camera on a plane");
  }
  const Eigen::FullPivLU<Matrix6d> lu(eq.JtJ);
  if (!lu.isInvertible() || lu.rcond() < 1e-14) {
    return Status(StatusCode::kDegenerate,
                  "pose refinement: the matches do not constrain all of (x, z, θ)");
  }
  const Matrix6d JtJ_inverse = lu.inverse();
  const Matrix6d covariance = options.sigma_px * options.sigma_px * JtJ_inverse *
                              eq.measurement_information * JtJ_inverse;
  RefinedPlanarPose result;
  result.pose = state.pose;
  // The marginal covariance of (Cx, Cz, θ12): height offset and tilt are nuisance parameters.
  result.covariance = covariance.topLeftCorner<3, 3>();
  result.covariance = 0.5 * (result.covariance + result.covariance.transpose());
  const Matrix6d reference_covariance =
      options.sigma_px * options.sigma_px * JtJ_inverse * eq.reference_information * JtJ_inverse;
  result.reference_noise_covariance = reference_covariance.topLeftCorner<3, 3>();
  result.reference_noise_covariance =
      0.5 * (result.reference_noise_covariance + result.reference_noise_covariance.transpose());
  result.height_offset = state.height;
  result.tilt = cameraTilt(state.pitch, state.roll).T;
  const double residuals_per_match = options.cost == RefinementCost::kSampson ? 1.0 : 2.0;
  result.rms_transfer_error_px =
      std::sqrt(eq.cost / (residuals_per_match * static_cast<double>(total)));
  result.iterations = iteration;
  if (options.plane_sensitivity && planes.size() == 1) {
    // The minimum moves with the plane as −(JᵀJ)⁻¹ ∂(Jᵀr)/∂plane (the gradient stays zero); the
    // closed form's derivative instead reads a few entries of H, and a leaning wall moved its
    // depth several times more than the fit over every match does (docs/math.md §3.6).
    // The normal turns about the matched points' centroid on the plane (where the matches hold
    // it), the distance moves the plane along its normal (docs/math.md §3.6).
    const ScenePlane& plane = planes.front().plane;
    const auto [across1, across2] = directionsAcrossNormal(plane.normal);
    constexpr double kStep = 1e-5;
    const Eigen::Vector3d pivot =
        centroidOnPlane(plane, camera, planes.front().matches).value_or(plane.distance * plane.normal);
    std::vector<PlaneMatches> perturbed = planes;
    const std::array<std::pair<Eigen::Vector3d, double>, 3> steps{
        {{kStep * across1, 0.0}, {kStep * across2, 0.0}, {Eigen::Vector3d::Zero(), kStep}}};
    for (int k = 0; k < 3; ++k) {
      Vector6d gradient[2];
      for (int side = 0; side < 2; ++side) {
        const double sign = side == 0 ? 1.0 : -1.0;
        perturbed.front().plane =
            k < 2 ? turnedAbout(plane, plane.normal.normalized() + sign * steps[k].first, pivot)
                  : ScenePlane{plane.normal, plane.distance * (1.0 + sign * steps[k].second)};
        NormalEquations at;
        if (!accumulate(camera, state, perturbed, options.cost, nuisance, false, &at)) {
          return Status(StatusCode::kDegenerate, "pose refinement: a perturbed plane puts the camera on it");
        }
        gradient[side] = at.Jtr;
      }
      result.plane_jacobian.col(k) = -(JtJ_inverse * (gradient[0] - gradient[1]) / (2.0 * kStep)).head<3>();
    }
  }
  if (!result.pose.isFinite() || !result.covariance.allFinite() ||
      !result.reference_noise_covariance.allFinite() || !result.plane_jacobian.allFinite()) {
    return Status(StatusCode::kNotFinite, "pose refinement produced a non-finite result");
  }
  return result;
}

}  // namespace homography_teach_repeat
