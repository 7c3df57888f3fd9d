#include "homography_teach_repeat/fast_hd_covariance.h"

#include <Eigen/LU>

#include <cmath>
#include <string>

namespace homography_teach_repeat {
namespace {

using Matrix24d = Eigen::Matrix<double, 2, 4>;
using Matrix92d = Eigen::Matrix<double, 9, 2>;
using Matrix34d = Eigen::Matrix<double, 3, 4>;

// The two DLT rows of one match (MATH.md §3.1), transposed: columns are the rows of Â_i.
Matrix92d dltRowsTransposed(const Eigen::Vector3d& p, const Eigen::Vector3d& q) {
  Matrix92d rows;
  rows.col(0) << 0.0, 0.0, 0.0, -p, q.y() * p;
  rows.col(1) << p, 0.0, 0.0, 0.0, -q.x() * p;
  return rows;
}

// B_i = ∂(Â_i ĥ)/∂(û, v̂, û', v̂') for one match (MATH.md §3.4 step 1), Ĥ 0-based.
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
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) kron.block<3, 3>(3 * i, 3 * j) = t2_inverse(i, j) * t1_transpose;
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

Expected<Matrix39d> fastHdJacobian(const Eigen::Matrix3d& H, const PinholeCamera& camera,
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

  // ∂b/∂hn = d1 Jb (MATH.md §3.3 corrected eq. 17 plus the H(3,2) column).
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
  const Eigen::Matrix4d pi_inverse = pi.inverse();

  // atan2(S, C) and the pose map (MATH.md §3.3: corrected eq. 16 and the C-version of eq. 14).
  const double S = solution->sin_theta21;
  const double C = solution->cos_theta21;
  const double r2 = S * S + C * C;
  Eigen::Matrix<double, 3, 4> j_theta = Eigen::Matrix<double, 3, 4>::Zero();
  j_theta(0, 0) = 1.0;
  j_theta(1, 1) = 1.0;
  j_theta(2, 2) = C / r2;
  j_theta(2, 3) = -S / r2;
  const double theta21 = -solution->pose.theta;
  const double c = std::cos(theta21);
  const double s = std::sin(theta21);
  Eigen::Matrix3d j_pose;
  j_pose << c, s, solution->pose.z, -s, c, -solution->pose.x, 0.0, 0.0, -1.0;

  return Matrix39d(j_pose * j_theta * pi_inverse * (d1 * jb) * d_hn);
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
                                           double sigma_px) {
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
  const auto j_g = fastHdJacobian(dlt.H_unscaled, camera, plane);
  if (!j_g) return j_g.status();
  // P = J_g (T2⁻¹ ⊗ T1ᵀ)(−V S⁺² Vᵀ): 3x9, then J_g J_h restricted to match i is
  // P Â_iᵀ B̂_i diag(s1, s1, s2, s2) (3x4).
  const Matrix39d P = *j_g * denormalizationJacobian(dlt) * negativePseudoInverseFactor(dlt);
  const double s1 = dlt.reference_normalization.scale;
  const double s2 = dlt.current_normalization.scale;
  const Eigen::Vector4d scales(s1, s1, s2, s2);
  Eigen::Matrix3d information_sum = Eigen::Matrix3d::Zero();
  for (const auto& m : matches) {
    const Eigen::Vector3d p = dlt.reference_normalization.transform * m.reference.homogeneous();
    const Eigen::Vector3d q = dlt.current_normalization.transform * m.current.homogeneous();
    const Matrix34d g = (P * dltRowsTransposed(p, q)) *
                        (dltResidualJacobian(dlt.H_normalized, p, q) * scales.asDiagonal());
    information_sum.noalias() += g * g.transpose();
  }
  Eigen::Matrix3d covariance = sigma_px * sigma_px * information_sum;
  covariance = 0.5 * (covariance + covariance.transpose());
  if (!covariance.allFinite()) {
    return Status(StatusCode::kNotFinite, "Fast-HD covariance is not finite");
  }
  return covariance;
}

}  // namespace homography_teach_repeat
