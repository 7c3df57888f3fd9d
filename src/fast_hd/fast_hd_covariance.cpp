#include "homography_teach_repeat/fast_hd/fast_hd.h"
#include "homography_teach_repeat/fast_hd/fast_hd_covariance.h"
#include "homography_teach_repeat/homography/homography.h"

#include <Eigen/LU>

#include <array>
#include <cmath>
#include <string>

namespace homography_teach_repeat {
namespace {

using Matrix24d = Eigen::Matrix<double, 2, 4>;
using Matrix92d = Eigen::Matrix<double, 9, 2>;

// The two DLT rows of one match (docs/math.md §3.1), transposed: columns are the rows of Â_i.
Matrix92d dltRowsTransposed(const Eigen::Vector3d& p, const Eigen::Vector3d& q) {
  Matrix92d rows;
  rows.col(0) << 0.0, 0.0, 0.0, -p, q.y() * p;
  rows.col(1) << p, 0.0, 0.0, 0.0, -q.x() * p;
  return rows;
}

// B_i = ∂(Â_i ĥ)/∂(û, v̂, û', v̂') for one match (docs/math.md §3.4 step 1), Ĥ 0-based.
Matrix24d dltResidualJacobian(const Eigen::Matrix3d& H, const Eigen::Vector3d& p,
                              const Eigen::Vector3d& q) {
  const double h3p = H.row(2).dot(p);
  Matrix24d b;
  b << -H(1, 0) + q.y() * H(2, 0), -H(1, 1) + q.y() * H(2, 1), 0.0, h3p,
      H(0, 0) - q.x() * H(2, 0), H(0, 1) - q.x() * H(2, 1), -h3p, 0.0;
  return b;
}

// (T2⁻¹ ⊗ T1ᵀ): vec(T2⁻¹ Ĥ T1) = (T2⁻¹ ⊗ T1ᵀ) vec(Ĥ), row-major vec.
Eigen::Matrix<double, 9, 9> denormalizationJacobian(const NormalizedDlt& dlt) {
  const Eigen::Matrix3d t2_inverse = dlt.current_normalization.transform.inverse();
  const Eigen::Matrix3d t1_transpose = dlt.reference_normalization.transform.transpose();
  Eigen::Matrix<double, 9, 9> kron;
  for (Eigen::Index i = 0; i < 3; ++i) {
    for (Eigen::Index j = 0; j < 3; ++j) kron.block<3, 3>(3 * i, 3 * j) = t2_inverse(i, j) * t1_transpose;
  }
  return kron;
}

// −Â⁺ = −V S⁺² Vᵀ Âᵀ (the null direction excluded); returns the 9x9 factor −V S⁺² Vᵀ.
Eigen::Matrix<double, 9, 9> negativePseudoInverseFactor(const NormalizedDlt& dlt) {
  Eigen::Matrix<double, 9, 1> inverse_squares = Eigen::Matrix<double, 9, 1>::Zero();
  for (int k = 0; k < 8; ++k) {
    const double s = dlt.singular_values(k);
    inverse_squares(k) = 1.0 / (s * s);
  }
  const auto& V = dlt.right_singular_vectors;
  return -(V * inverse_squares.asDiagonal() * V.transpose());
}

}  // namespace

Eigen::Matrix<double, 3, 4> fastHdPoseMapJacobian(const FastHdSolution& solution) {
  // docs/math.md §3.3: corrected eq. 16 (atan2) and the C-version of eq. 14 (pose map).
  const double S = solution.sin_theta21;
  const double C = solution.cos_theta21;
  const double r2 = S * S + C * C;
  Eigen::Matrix<double, 3, 4> j_theta = Eigen::Matrix<double, 3, 4>::Zero();
  j_theta(0, 0) = 1.0;
  j_theta(1, 1) = 1.0;
  j_theta(2, 2) = C / r2;
  j_theta(2, 3) = -S / r2;
  const double theta21 = -solution.pose.theta;
  const double c = std::cos(theta21);
  const double s = std::sin(theta21);
  Eigen::Matrix3d j_pose;
  j_pose << c, s, solution.pose.z, -s, c, -solution.pose.x, 0.0, 0.0, -1.0;
  return j_pose * j_theta;
}

std::array<Eigen::Matrix4d, 3> fastHdPoseMapHessians(const FastHdSolution& solution) {
  // With θ = atan2(S, C), θ_S = C/r², θ_C = −S/r², θ_SS = −2SC/r⁴, θ_CC = 2SC/r⁴,
  // θ_SC = (S² − C²)/r⁴; Cx = cosθ x + sinθ z (∂θ Cx = Cz, ∂θθ Cx = −Cx),
  // Cz = −sinθ x + cosθ z (∂θ Cz = −Cx, ∂θθ Cz = −Cz), θ12 = −θ.
  const double S = solution.sin_theta21;
  const double C = solution.cos_theta21;
  const double r2 = S * S + C * C;
  const double theta21 = -solution.pose.theta;
  const double c = std::cos(theta21);
  const double s = std::sin(theta21);
  const double cx = solution.pose.x;
  const double cz = solution.pose.z;
  const Eigen::Vector2d theta_q(C / r2, -S / r2);
  Eigen::Matrix2d theta_qq;
  theta_qq << -2.0 * S * C, S * S - C * C, S * S - C * C, 2.0 * S * C;
  theta_qq /= r2 * r2;
  std::array<Eigen::Matrix4d, 3> hessians;
  for (auto& hessian : hessians) hessian.setZero();
  // Cx: mixed terms ∂x∂q = −sinθ θ_q, ∂z∂q = cosθ θ_q.
  hessians[0].block<1, 2>(0, 2) = -s * theta_q.transpose();
  hessians[0].block<1, 2>(1, 2) = c * theta_q.transpose();
  hessians[0].block<2, 2>(2, 2) = -cx * theta_q * theta_q.transpose() + cz * theta_qq;
  // Cz: ∂x∂q = −cosθ θ_q, ∂z∂q = −sinθ θ_q.
  hessians[1].block<1, 2>(0, 2) = -c * theta_q.transpose();
  hessians[1].block<1, 2>(1, 2) = -s * theta_q.transpose();
  hessians[1].block<2, 2>(2, 2) = -cz * theta_q * theta_q.transpose() - cx * theta_qq;
  hessians[2].block<2, 2>(2, 2) = -theta_qq;
  for (int i = 0; i < 2; ++i) hessians[i].block<2, 2>(2, 0) = hessians[i].block<2, 2>(0, 2).transpose();
  return hessians;
}

namespace {

// The two factors of J_g (docs/math.md §3.4 step 2): s* = (x21, z21, S, C) from h, and the pose map
// g(s*) = (Cx, Cz, θ12) with θ21 = atan2(S, C).
struct FastHdJacobianFactors {
  Eigen::Matrix<double, 4, 9> solution_jacobian;  // ∂s*/∂h = Π⁻¹ (d1 Jb) (I9 − hn e_κᵀ)/κ
  Eigen::Matrix<double, 3, 4> pose_jacobian;      // ∂g/∂s* = J14 · Jθ
  std::array<Eigen::Matrix4d, 3> pose_hessians;   // ∂²g_i/∂s*²
};

Expected<FastHdJacobianFactors> fastHdJacobianFactors(const Eigen::Matrix3d& H,
                                                      const PinholeCamera& camera,
                                                      const ScenePlane& plane) {
  const auto solution = solveFastHd(H, camera, plane);
  if (!solution) return solution.status();
  const double fu = camera.fx();
  const double u0 = camera.cx();
  const double v0 = camera.cy();
  const double d1 = plane.distance;
  const double nx = plane.normal.x();
  const double nz = plane.normal.z();
  const double kappa = solution->kappa;

  // (I9 − hn e_κᵀ)/κ: derivative of hn = h/κ, κ = h[4] − v0 h[7].
  Eigen::Matrix<double, 9, 1> h;
  for (int k = 0; k < 9; ++k) h(k) = H(k / 3, k % 3);
  Eigen::Matrix<double, 1, 9> e_kappa = Eigen::Matrix<double, 1, 9>::Zero();
  e_kappa(4) = 1.0;
  e_kappa(7) = -v0;
  const Eigen::Matrix<double, 9, 9> d_hn =
      (Eigen::Matrix<double, 9, 9>::Identity() - (h / kappa) * e_kappa) / kappa;

  // ∂b/∂hn = d1 Jb (docs/math.md §3.3 corrected eq. 17 plus the H(3,2) column).
  Eigen::Matrix<double, 4, 9> jb = Eigen::Matrix<double, 4, 9>::Zero();
  jb(0, 0) = 1.0;
  jb(0, 6) = -u0;
  jb(1, 0) = u0 / fu;
  jb(1, 1) = v0 / fu;
  jb(1, 2) = 1.0 / fu;
  jb(1, 6) = -u0 * u0 / fu;
  jb(1, 7) = -u0 * v0 / fu;
  jb(1, 8) = -u0 / fu;
  jb(2, 6) = fu;
  jb(3, 6) = u0;
  jb(3, 7) = v0;
  jb(3, 8) = 1.0;

  Eigen::Matrix4d pi;
  pi << -nx, 0, 0, d1, -nz, 0, -d1, 0, 0, -nx, d1, 0, 0, -nz, 0, d1;
  FastHdJacobianFactors factors;
  factors.solution_jacobian = pi.inverse() * (d1 * jb) * d_hn;

  factors.pose_jacobian = fastHdPoseMapJacobian(*solution);
  factors.pose_hessians = fastHdPoseMapHessians(*solution);
  return factors;
}

}  // namespace

Expected<Matrix39d> fastHdJacobian(const Eigen::Matrix3d& H, const PinholeCamera& camera,
                                   const ScenePlane& plane) {
  const auto factors = fastHdJacobianFactors(H, camera, plane);
  if (!factors) return factors.status();
  return Matrix39d(factors->pose_jacobian * factors->solution_jacobian);
}

Eigen::MatrixXd normalizedDltJacobian(const NormalizedDlt& dlt, const PointMatches& matches) {
  const Eigen::Index n = static_cast<Eigen::Index>(matches.size());
  const Eigen::Matrix<double, 9, 9> factor =
      denormalizationJacobian(dlt) * negativePseudoInverseFactor(dlt);
  const double s1 = dlt.reference_normalization.scale;
  const double s2 = dlt.current_normalization.scale;
  const Eigen::Vector4d scales(s1, s1, s2, s2);
  Eigen::MatrixXd jacobian(9, 4 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& m = matches[static_cast<std::size_t>(i)];
    const Eigen::Vector3d p = dlt.reference_normalization.transform * m.reference.homogeneous();
    const Eigen::Vector3d q = dlt.current_normalization.transform * m.current.homogeneous();
    jacobian.middleCols<4>(4 * i) = factor * dltRowsTransposed(p, q) *
                                    dltResidualJacobian(dlt.H_normalized, p, q) *
                                    scales.asDiagonal();
  }
  return jacobian;
}

Expected<Eigen::Matrix3d> fastHdCovariance(const NormalizedDlt& dlt, const PointMatches& matches,
                                           const PinholeCamera& camera, const ScenePlane& plane,
                                           double sigma_px, bool second_order,
                                           Eigen::Matrix3d* reference_noise_covariance) {
  if (!std::isfinite(sigma_px) || sigma_px < 0.0) {
    return Status(StatusCode::kInvalidInput,
                  "pixel noise sigma must be finite and >= 0, got " + std::to_string(sigma_px));
  }
  if (matches.size() != dlt.match_count) {
    return Status(StatusCode::kInvalidInput,
                  "covariance needs the matches the DLT was solved from: got " +
                      std::to_string(matches.size()) + ", DLT used " +
                      std::to_string(dlt.match_count));
  }
  const auto factors = fastHdJacobianFactors(dlt.H_unscaled, camera, plane);
  if (!factors) return factors.status();
  // P = ∂s*/∂h (T2⁻¹ ⊗ T1ᵀ)(−V S⁺² Vᵀ): 4x9; ∂s*/∂x restricted to match i is
  // P Â_iᵀ B̂_i diag(s1, s1, s2, s2) (4x4).
  const Eigen::Matrix<double, 4, 9> P = factors->solution_jacobian *
                                        denormalizationJacobian(dlt) *
                                        negativePseudoInverseFactor(dlt);
  const double s1 = dlt.reference_normalization.scale;
  const double s2 = dlt.current_normalization.scale;
  const Eigen::Vector4d scales(s1, s1, s2, s2);
  Eigen::Matrix4d solution_covariance = Eigen::Matrix4d::Zero();
  Eigen::Matrix4d reference_solution_covariance = Eigen::Matrix4d::Zero();  // g's columns u, v
  for (const auto& m : matches) {
    const Eigen::Vector3d p = dlt.reference_normalization.transform * m.reference.homogeneous();
    const Eigen::Vector3d q = dlt.current_normalization.transform * m.current.homogeneous();
    const Eigen::Matrix4d g = (P * dltRowsTransposed(p, q)) *
                              (dltResidualJacobian(dlt.H_normalized, p, q) * scales.asDiagonal());
    solution_covariance.noalias() += g * g.transpose();
    reference_solution_covariance.noalias() += g.leftCols<2>() * g.leftCols<2>().transpose();
  }
  solution_covariance *= sigma_px * sigma_px;
  const Eigen::Matrix<double, 3, 4>& J = factors->pose_jacobian;
  if (reference_noise_covariance != nullptr) {
    const Eigen::Matrix3d shared = sigma_px * sigma_px * J * reference_solution_covariance * J.transpose();
    *reference_noise_covariance = 0.5 * (shared + shared.transpose());
  }
  Eigen::Matrix3d covariance = J * solution_covariance * J.transpose();
  if (second_order) {
    // Second-order (Gaussian) propagation through the pose map g: the solution s* is linear in
    // the data to first order, the map (x21, z21, S, C) -> (Cx, Cz, θ12) is not, and its
    // curvature adds ½ tr(G_i Σ G_j Σ) to the covariance (eval_fast_hd scene B at 1 px: NEES
    // 3.57 first-order, see README).
    for (int i = 0; i < 3; ++i) {
      const Eigen::Matrix4d a = factors->pose_hessians[i] * solution_covariance;
      for (int j = i; j < 3; ++j) {
        const double term =
            0.5 * (a * factors->pose_hessians[j] * solution_covariance).trace();
        covariance(i, j) += term;
        if (j != i) covariance(j, i) += term;
      }
    }
  }
  covariance = 0.5 * (covariance + covariance.transpose());
  if (!covariance.allFinite()) {
    return Status(StatusCode::kNotFinite, "Fast-HD covariance is not finite");
  }
  return covariance;
}

}  // namespace homography_teach_repeat
