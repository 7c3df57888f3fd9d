#include "homography_teach_repeat/trifocal/trifocal_tensor_1d.h"

#include <Eigen/LU>
#include <Eigen/SVD>

#include <cmath>
#include <optional>
#include <string>

namespace homography_teach_repeat {
namespace {

// A null space of more than one dimension: the second smallest singular value is below this
// fraction of the largest (exact data of a degenerate configuration gives ~1e-16).
constexpr double kRankTolerance = 1e-9;
// Cofactors of a minimal sample above this fraction of the product of its row norms: the null
// vector is well determined and the SVD is not needed.
constexpr double kCofactorConfidence = 1e-11;

// Unit bearings of a triplet; false for a non-finite or zero bearing.
bool normalised(const BearingTriplet& in, BearingTriplet* out) {
  const Bearing* views[3] = {&in.first, &in.second, &in.third};
  Bearing* outs[3] = {&out->first, &out->second, &out->third};
  for (int v = 0; v < 3; ++v) {
    const double norm = views[v]->norm();
    if (!views[v]->allFinite() || !(norm > 0.0)) return false;
    *outs[v] = *views[v] / norm;
  }
  return true;
}

Expected<std::vector<BearingTriplet>> normalisedTriplets(const std::vector<BearingTriplet>& triplets) {
  std::vector<BearingTriplet> out(triplets.size());
  for (std::size_t n = 0; n < triplets.size(); ++n) {
    if (!normalised(triplets[n], &out[n])) {
      return Status(StatusCode::kInvalidInput, "bearing triplet " + std::to_string(n) + " is not finite or zero");
    }
  }
  return out;
}

// Eq. 3: the 8 coefficients u_i u'_j u''_k of one triplet, in T order.
Eigen::Matrix<double, 1, 8> trilinearRow(const BearingTriplet& t) {
  Eigen::Matrix<double, 1, 8> row;
  for (int i = 1; i <= 2; ++i) {
    for (int j = 1; j <= 2; ++j) {
      for (int k = 1; k <= 2; ++k) row(tensorIndex(i, j, k)) = t.first(i - 1) * t.second(j - 1) * t.third(k - 1);
    }
  }
  return row;
}

// Eq. 7 (docs/math.md §5.3): eq. 2 with T221 = T111 − T122 − T212 and T222 = T112 + T121 + T211
// substituted; unknowns (T111, T112, T121, T122, T211, T212).
Eigen::Matrix<double, 1, 6> tt5Row(const BearingTriplet& t) {
  const double u1 = t.first(0), u2 = t.first(1), a1 = t.second(0), a2 = t.second(1), b1 = t.third(0),
               b2 = t.third(1);
  Eigen::Matrix<double, 1, 6> row;
  row << u1 * a1 * b1 + u2 * a2 * b1, u1 * a1 * b2 + u2 * a2 * b2, u1 * a2 * b1 + u2 * a2 * b2,
      u1 * a2 * b2 - u2 * a2 * b1, u2 * a1 * b1 + u2 * a2 * b2, u2 * a1 * b2 - u2 * a2 * b1;
  return row;
}

// The null vector of a K x (K+1) matrix (a minimal sample) by cofactors: x_i = (−1)^i det(A
// without column i) — 10x faster than an SVD in RANSAC's inner loop. kDegenerate when every
// cofactor vanishes (rank < K).
template <int K>
Expected<Eigen::VectorXd> minimalNullVector(const Eigen::MatrixXd& A_dynamic, const char* what) {
  const Eigen::Matrix<double, K, K + 1> A = A_dynamic;
  Eigen::Matrix<double, K + 1, 1> x;
  double scale = 1.0;
  for (int r = 0; r < K; ++r) scale *= A.row(r).norm();
  for (int i = 0; i <= K; ++i) {
    Eigen::Matrix<double, K, K> minor;
    for (int c = 0, m = 0; c <= K; ++c) {
      if (c != i) minor.col(m++) = A.col(c);
    }
    x(i) = ((i % 2) ? -1.0 : 1.0) * minor.partialPivLu().determinant();
  }
  // Small cofactors do not tell an ill-conditioned sample from a rank-deficient one: those go to
  // the SVD (nullVector), which decides on the singular values.
  if (!x.allFinite() || !(x.norm() > kCofactorConfidence * scale)) return Status(StatusCode::kDegenerate, what);
  return Eigen::VectorXd(x / x.norm());
}

// The null vector of A (rows >= unknowns − 1); kDegenerate when the null space has more than one
// dimension.
Expected<Eigen::VectorXd> nullVector(const Eigen::MatrixXd& A, const char* what) {
  if (A.rows() + 1 == A.cols() && (A.cols() == 4 || A.cols() == 6 || A.cols() == 8)) {
    auto x = A.cols() == 4 ? minimalNullVector<3>(A, what)
                           : (A.cols() == 6 ? minimalNullVector<5>(A, what) : minimalNullVector<7>(A, what));
    if (x) return x;
  }
  const Eigen::Index unknowns = A.cols();
  Eigen::MatrixXd padded = A;
  if (A.rows() < unknowns) {  // JacobiSVD's V is complete only for at least as many rows as columns
    padded = Eigen::MatrixXd::Zero(unknowns, unknowns);
    padded.topRows(A.rows()) = A;
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(padded, Eigen::ComputeFullV);
  const Eigen::VectorXd& sv = svd.singularValues();
  if (!sv.allFinite()) return Status(StatusCode::kNotFinite, std::string(what) + ": SVD is not finite");
  if (!(sv(unknowns - 2) > kRankTolerance * sv(0))) {
    return Status(StatusCode::kDegenerate,
                  std::string(what) +
                      ": the system has more than one solution (identical views, coincident camera centres or "
                      "repeated bearings)");
  }
  return Eigen::VectorXd(svd.matrixV().col(unknowns - 1));
}

// Angle between two bearings modulo π, in [0, π/2].
double angleModPi(const Bearing& a, const Bearing& b) {
  const double d = std::atan2(a(0), a(1)) - std::atan2(b(0), b(1));
  return std::abs(std::remainder(d, M_PI));
}

}  // namespace

Bearing bearingFromAngle(double alpha) { return Bearing(std::sin(alpha), std::cos(alpha)); }

Bearing bearingFromPixel(double x, double f, double u0) {
  const Bearing u(x - u0, f);
  return u / u.norm();
}

double bearingAngle(const Bearing& u) { return std::atan2(u(0), u(1)); }

TrifocalTensor1d calibrateTensor(const TrifocalTensor1d& pixel_tensor, double f, double u0) {
  Eigen::Matrix2d K;
  K << f, u0, 0.0, 1.0;
  TrifocalTensor1d calibrated = TrifocalTensor1d::Zero();
  for (int l = 1; l <= 2; ++l) {
    for (int m = 1; m <= 2; ++m) {
      for (int n = 1; n <= 2; ++n) {
        double sum = 0.0;
        for (int i = 1; i <= 2; ++i) {
          for (int j = 1; j <= 2; ++j) {
            for (int k = 1; k <= 2; ++k) {
              sum += pixel_tensor(tensorIndex(i, j, k)) * K(i - 1, l - 1) * K(j - 1, m - 1) * K(k - 1, n - 1);
            }
          }
        }
        calibrated(tensorIndex(l, m, n)) = sum;
      }
    }
  }
  return calibrated;
}

Eigen::Vector2d calibrationResidual(const TrifocalTensor1d& T) {
  return Eigen::Vector2d(-T(0) + T(3) + T(5) + T(6), T(1) + T(2) + T(4) - T(7));
}

double trilinearResidual(const TrifocalTensor1d& T, const BearingTriplet& triplet) {
  BearingTriplet unit;
  if (!normalised(triplet, &unit) || !(T.norm() > 0.0)) return INFINITY;
  return trilinearRow(unit).dot(T) / T.norm();
}

Bearing transferBearing(const TrifocalTensor1d& T, const BearingTriplet& triplet, int view) {
  // docs/math.md §5.4 with T_i = [[T_i11, T_i12], [T_i21, T_i22]].
  const Bearing& u = triplet.first;
  const Bearing& a = triplet.second;
  const Bearing& b = triplet.third;
  auto t = [&](int i, int j, int k) { return T(tensorIndex(i, j, k)); };
  double numerator = 0.0, denominator = 0.0;
  for (int p = 1; p <= 2; ++p) {
    for (int q = 1; q <= 2; ++q) {
      if (view == 1) {
        numerator += t(2, p, q) * a(p - 1) * b(q - 1);
        denominator += t(1, p, q) * a(p - 1) * b(q - 1);
      } else if (view == 2) {
        numerator += t(p, 2, q) * u(p - 1) * b(q - 1);
        denominator += t(p, 1, q) * u(p - 1) * b(q - 1);
      } else {
        numerator += t(p, q, 2) * u(p - 1) * a(q - 1);
        denominator += t(p, q, 1) * u(p - 1) * a(q - 1);
      }
    }
  }
  return Bearing(-numerator, denominator);
}

double transferAngleError(const TrifocalTensor1d& T, const BearingTriplet& triplet, int view) {
  const Bearing predicted = transferBearing(T, triplet, view);
  const Bearing& measured = view == 1 ? triplet.first : (view == 2 ? triplet.second : triplet.third);
  if (!predicted.allFinite() || !(predicted.norm() > 0.0) || !measured.allFinite()) return INFINITY;
  return angleModPi(predicted, measured);
}

double transferError(const TrifocalTensor1d& T, const BearingTriplet& triplet) {
  double worst = 0.0;
  for (int view = 1; view <= 3; ++view) worst = std::max(worst, transferAngleError(T, triplet, view));
  return worst;
}

bool transferErrorBelow(const TrifocalTensor1d& T, const BearingTriplet& triplet, double threshold) {
  const double sine = std::sin(threshold);
  const double sine_squared = sine * sine;
  for (int view = 1; view <= 3; ++view) {
    const Bearing p = transferBearing(T, triplet, view);
    const Bearing& m = view == 1 ? triplet.first : (view == 2 ? triplet.second : triplet.third);
    const double cross = p(0) * m(1) - p(1) * m(0);
    // |sin Δ| < sin(threshold) ⇔ Δ within the threshold modulo π; false for non-finite values.
    if (!(cross * cross < sine_squared * p.squaredNorm() * m.squaredNorm())) return false;
  }
  return true;
}

Expected<TrifocalTensor1d> estimateTT7(const std::vector<BearingTriplet>& triplets) {
  if (triplets.size() < 7) {
    return Status(StatusCode::kTooFewPoints, "TT7 needs 7 bearing triplets, got " + std::to_string(triplets.size()));
  }
  const auto unit = normalisedTriplets(triplets);
  if (!unit) return unit.status();
  Eigen::MatrixXd A(static_cast<Eigen::Index>(unit->size()), 8);
  for (std::size_t n = 0; n < unit->size(); ++n) A.row(static_cast<Eigen::Index>(n)) = trilinearRow((*unit)[n]);
  const auto x = nullVector(A, "TT7");
  if (!x) return x.status();
  return TrifocalTensor1d(*x);
}

Expected<TrifocalTensor1d> estimateTT5(const std::vector<BearingTriplet>& triplets) {
  if (triplets.size() < 5) {
    return Status(StatusCode::kTooFewPoints, "TT5 needs 5 bearing triplets, got " + std::to_string(triplets.size()));
  }
  const auto unit = normalisedTriplets(triplets);
  if (!unit) return unit.status();
  Eigen::MatrixXd A(static_cast<Eigen::Index>(unit->size()), 6);
  for (std::size_t n = 0; n < unit->size(); ++n) A.row(static_cast<Eigen::Index>(n)) = tt5Row((*unit)[n]);
  const auto x = nullVector(A, "TT5");
  if (!x) return x.status();
  const Eigen::VectorXd& s = *x;
  TrifocalTensor1d T;
  T << s(0), s(1), s(2), s(3), s(4), s(5), s(0) - s(3) - s(5), s(1) + s(2) + s(4);
  return TrifocalTensor1d(T / T.norm());
}

namespace {

// Row of the 1D homography's DLT for u -> v (h = (h11, h12, h21, h22)): v × (H u) = 0. Bilinear in
// (u, v), so the same function gives its derivatives by either bearing.
Eigen::Matrix<double, 1, 4> bearingHomographyRow(const Bearing& u, const Bearing& v) {
  return Eigen::Matrix<double, 1, 4>(-v(1) * u(0), -v(1) * u(1), v(0) * u(0), v(0) * u(1));
}

}  // namespace

Expected<Eigen::Matrix2d> estimateBearingHomography(const std::vector<Bearing>& from, const std::vector<Bearing>& to) {
  if (from.size() != to.size()) {
    return Status(StatusCode::kInvalidInput, "1D homography: " + std::to_string(from.size()) + " bearings to " +
                                                 std::to_string(to.size()));
  }
  if (from.size() < 3) {
    return Status(StatusCode::kTooFewPoints, "1D homography needs 3 bearing pairs, got " + std::to_string(from.size()));
  }
  Eigen::MatrixXd A(static_cast<Eigen::Index>(from.size()), 4);
  for (std::size_t n = 0; n < from.size(); ++n) {
    if (!from[n].allFinite() || !to[n].allFinite() || !(from[n].norm() > 0.0) || !(to[n].norm() > 0.0)) {
      return Status(StatusCode::kInvalidInput, "1D homography: bearing " + std::to_string(n) + " is not finite or zero");
    }
    const Bearing u = from[n].normalized();
    const Bearing v = to[n].normalized();
    A.row(static_cast<Eigen::Index>(n)) = bearingHomographyRow(u, v);
  }
  const auto h = nullVector(A, "1D homography");
  if (!h) return h.status();
  Eigen::Matrix2d H;
  H << (*h)(0), (*h)(1), (*h)(2), (*h)(3);
  return H;
}

double bearingHomographyError(const Eigen::Matrix2d& H, const Bearing& from, const Bearing& to) {
  const Bearing mapped = H * from;
  if (!mapped.allFinite() || !(mapped.norm() > 0.0) || !to.allFinite()) return INFINITY;
  return angleModPi(mapped, to);
}

namespace {

// Eq. 12 (docs/math.md §5.5): B_i = H'ᵀ T_i H'', B_i(a, b) = Σ_jk H'(j, a) T_ijk H''(k, b); the plane
// gives B_1(1,1) = 0, B_1(1,2) + B_1(2,1) + B_2(1,1) = 0, B_1(2,2) + B_2(1,2) + B_2(2,1) = 0 and
// B_2(2,2) = 0 — four rows on T, each scaled to unit norm. kDegenerate when one vanishes.
Expected<Eigen::Matrix<double, 4, 8>> planeConstraintRows(const Eigen::Matrix2d& H_second,
                                                          const Eigen::Matrix2d& H_third) {
  auto b = [&](int i, int a, int c) {
    Eigen::Matrix<double, 1, 8> row = Eigen::Matrix<double, 1, 8>::Zero();
    for (int j = 1; j <= 2; ++j) {
      for (int k = 1; k <= 2; ++k) row(tensorIndex(i, j, k)) = H_second(j - 1, a - 1) * H_third(k - 1, c - 1);
    }
    return row;
  };
  Eigen::Matrix<double, 4, 8> rows;
  rows.row(0) = b(2, 1, 1) + b(1, 2, 1) + b(1, 1, 2);
  rows.row(1) = b(1, 1, 1);
  rows.row(2) = b(1, 2, 2) + b(2, 2, 1) + b(2, 1, 2);
  rows.row(3) = b(2, 2, 2);
  for (int r = 0; r < 4; ++r) {
    const double norm = rows.row(r).norm();
    if (!(norm > 0.0)) return Status(StatusCode::kDegenerate, "TT4: a plane constraint vanishes (singular homography)");
    rows.row(r) /= norm;
  }
  return rows;
}

// TT4's system: the plane rows times `plane_weights`, eq. 6 (two rows of weight 1/2) and the
// trilinear rows of the (unit) triplets; one triplet makes it the minimal 7x8 system. (Imposing
// eq. 6 exactly, as TT5 does, was tried: the same in the simulations, and fountain-P11's median
// TT4 rotation error went from 1.36° to 1.94°.)
Expected<TrifocalTensor1d> solveTT4(const Eigen::Matrix<double, 4, 8>& plane_rows, const Eigen::Vector4d& plane_weights,
                                   const std::vector<BearingTriplet>& unit_triplets) {
  Eigen::MatrixXd A(6 + static_cast<Eigen::Index>(unit_triplets.size()), 8);
  A.topRows<4>() = plane_weights.asDiagonal() * plane_rows;
  A.row(4) << -1, 0, 0, 1, 0, 1, 1, 0;  // eq. 6
  A.row(5) << 0, 1, 1, 0, 1, 0, 0, -1;
  A.middleRows<2>(4) /= 2.0;
  for (std::size_t n = 0; n < unit_triplets.size(); ++n) {
    A.row(6 + static_cast<Eigen::Index>(n)) = trilinearRow(unit_triplets[n]);  // unit norm for unit bearings
  }
  const auto x = nullVector(A, "TT4");
  if (!x) return x.status();
  return TrifocalTensor1d(*x);
}

// Derivative of a unit bearing (sin α, cos α) by its angle α.
Bearing bearingDerivative(const Bearing& u) { return Bearing(u(1), -u(0)); }

// First-order derivatives of the unit null vector h (row-major H) of estimateBearingHomography's
// system A h = 0 by each bearing angle: δh = −A⁺ e_n (∂a_n/∂α · h) for a change of row n
// (A⁺ the pseudo-inverse without the null direction). Columns n: by the angle of from[n] / to[n].
// False when A has a second (near-)null direction.
bool bearingHomographyJacobian(const Eigen::Matrix2d& H, const std::vector<Bearing>& from,
                               const std::vector<Bearing>& to, Eigen::Matrix<double, 4, Eigen::Dynamic>* by_from,
                               Eigen::Matrix<double, 4, Eigen::Dynamic>* by_to) {
  const auto n = static_cast<Eigen::Index>(from.size());
  Eigen::MatrixXd A(n, 4);
  for (Eigen::Index k = 0; k < n; ++k) {
    A.row(k) = bearingHomographyRow(from[static_cast<std::size_t>(k)], to[static_cast<std::size_t>(k)]);
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeThinU | Eigen::ComputeFullV);
  const Eigen::VectorXd& sv = svd.singularValues();
  if (sv.size() < 3 || !(sv(2) > kRankTolerance * sv(0))) return false;
  const Eigen::Vector4d h(H(0, 0), H(0, 1), H(1, 0), H(1, 1));
  // −A⁺ restricted to the three non-null directions: column k is −Σ_i v_i U(k, i) / s_i.
  const Eigen::Matrix<double, 4, 3> V = svd.matrixV().leftCols<3>();
  const Eigen::MatrixXd minus_pinv = -V * sv.head<3>().cwiseInverse().asDiagonal() * svd.matrixU().leftCols<3>().transpose();
  by_from->resize(4, n);
  by_to->resize(4, n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const Bearing& u = from[static_cast<std::size_t>(k)];
    const Bearing& v = to[static_cast<std::size_t>(k)];
    by_from->col(k) = minus_pinv.col(k) * bearingHomographyRow(bearingDerivative(u), v).dot(h);
    by_to->col(k) = minus_pinv.col(k) * bearingHomographyRow(u, bearingDerivative(v)).dot(h);
  }
  return true;
}

// Weights of the four plane rows in TT4's least squares: the bearing noise (the same σ on every
// angle) propagated to each plane row's residual at the tensor T through the homographies, against
// the mean variance of the trilinear rows' residuals — so that a plane row counts like a match of
// the same reliability. Without them, the plane rows (unit weight) outvoted the matches where
// the plane fixes the tensor badly: eval_trifocal's MovB (forward motion) gave TT4 1.31° vs TT5
// 1.09° RMS rotation at 1 px; weighted 0.97° vs 1.09° (1000 runs). The correlation between a
// plane row and the trilinear rows of the plane's own triplets is ignored (a diagonal weighting).
// Empty when the homographies' Jacobian is not defined.
std::optional<Eigen::Vector4d> planeRowWeights(const Eigen::Matrix2d& H_second, const Eigen::Matrix2d& H_third,
                                               const std::vector<Bearing>& first, const std::vector<Bearing>& second,
                                               const std::vector<Bearing>& third,
                                               const std::vector<BearingTriplet>& unit_all, const TrifocalTensor1d& T) {
  Eigen::Matrix<double, 4, Eigen::Dynamic> second_by_first, second_by_second, third_by_first, third_by_third;
  if (!bearingHomographyJacobian(H_second, first, second, &second_by_first, &second_by_second) ||
      !bearingHomographyJacobian(H_third, first, third, &third_by_first, &third_by_third)) {
    return std::nullopt;
  }
  // d(residuals)/d(h', h'') by central differences (the rows are normalised: a ratio of quadratics).
  Eigen::Matrix<double, 4, 8> G;
  const double step = 1e-6;
  for (int e = 0; e < 8; ++e) {
    Eigen::Matrix2d plus[2] = {H_second, H_third}, minus[2] = {H_second, H_third};
    plus[e / 4](e % 4 / 2, e % 2) += step;
    minus[e / 4](e % 4 / 2, e % 2) -= step;
    const auto rows_plus = planeConstraintRows(plus[0], plus[1]);
    const auto rows_minus = planeConstraintRows(minus[0], minus[1]);
    if (!rows_plus || !rows_minus) return std::nullopt;
    G.col(e) = (*rows_plus - *rows_minus) * T / (2.0 * step);
  }
  const Eigen::Matrix4d G_second = G.leftCols<4>(), G_third = G.rightCols<4>();
  const Eigen::MatrixXd by_first = G_second * second_by_first + G_third * third_by_first;  // view 1 moves both
  const Eigen::Vector4d plane_variance = by_first.rowwise().squaredNorm() +
                                         (G_second * second_by_second).rowwise().squaredNorm() +
                                         (G_third * third_by_third).rowwise().squaredNorm();
  double trilinear_variance = 0.0;
  for (const auto& t : unit_all) {
    const double d1 = trilinearRow({bearingDerivative(t.first), t.second, t.third}).dot(T);
    const double d2 = trilinearRow({t.first, bearingDerivative(t.second), t.third}).dot(T);
    const double d3 = trilinearRow({t.first, t.second, bearingDerivative(t.third)}).dot(T);
    trilinear_variance += (d1 * d1 + d2 * d2 + d3 * d3) / static_cast<double>(unit_all.size());
  }
  const Eigen::Vector4d weights = (trilinear_variance / plane_variance.array()).sqrt().matrix();
  if (!weights.allFinite() || !(weights.minCoeff() > 0.0)) return std::nullopt;
  return weights;
}

}  // namespace

Expected<TrifocalTensor1d> estimateTT4(const Eigen::Matrix2d& H_second, const Eigen::Matrix2d& H_third,
                                       const std::vector<BearingTriplet>& off_plane) {
  if (off_plane.empty()) {
    return Status(StatusCode::kTooFewPoints, "TT4 needs a bearing triplet off the plane");
  }
  if (!H_second.allFinite() || !H_third.allFinite()) {
    return Status(StatusCode::kInvalidInput, "TT4: the plane's 1D homographies are not finite");
  }
  const auto unit = normalisedTriplets(off_plane);
  if (!unit) return unit.status();
  const auto rows = planeConstraintRows(H_second, H_third);
  if (!rows) return rows.status();
  return solveTT4(*rows, Eigen::Vector4d::Ones(), *unit);
}

Expected<TrifocalTensor1d> estimateTT4(const std::vector<BearingTriplet>& on_plane,
                                       const std::vector<BearingTriplet>& off_plane) {
  const auto unit_on = normalisedTriplets(on_plane);
  if (!unit_on) return unit_on.status();
  std::vector<Bearing> first, second, third;
  for (const auto& t : *unit_on) {
    first.push_back(t.first);
    second.push_back(t.second);
    third.push_back(t.third);
  }
  const auto H_second = estimateBearingHomography(first, second);
  if (!H_second) return Status(H_second.status().code(), "TT4, plane view 1 -> 2: " + H_second.status().message());
  const auto H_third = estimateBearingHomography(first, third);
  if (!H_third) return Status(H_third.status().code(), "TT4, plane view 1 -> 3: " + H_third.status().message());
  if (off_plane.empty()) return Status(StatusCode::kTooFewPoints, "TT4 needs a bearing triplet off the plane");
  const auto unit_off = normalisedTriplets(off_plane);
  if (!unit_off) return unit_off.status();
  const auto rows = planeConstraintRows(*H_second, *H_third);
  if (!rows) return rows.status();
  // The plane's triplets satisfy the trilinear constraint too: with their rows the system uses
  // every match (the homographies alone would leave their noise unaveraged).
  std::vector<BearingTriplet> all = *unit_off;
  all.insert(all.end(), unit_on->begin(), unit_on->end());
  auto initial = solveTT4(*rows, Eigen::Vector4d::Ones(), all);
  if (!initial) return initial;
  const auto weights = planeRowWeights(*H_second, *H_third, first, second, third, all, *initial);
  if (!weights) return initial;
  return solveTT4(*rows, *weights, all);
}

}  // namespace homography_teach_repeat
