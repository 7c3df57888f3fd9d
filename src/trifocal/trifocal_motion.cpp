#include "homography_teach_repeat/trifocal/trifocal_motion.h"

#include "homography_teach_repeat/geometry/planar_pose.h"

#include <Eigen/LU>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <complex>
#include <stdexcept>
#include <string>

namespace homography_teach_repeat {
namespace {

using Complex = std::complex<double>;
using ProjectionMatrix = Eigen::Matrix<double, 2, 3>;

// |v|, |t'| or |t''| below this fraction of |T|: no baseline between two views.
constexpr double kDegenerateFraction = 1e-9;
// Largest rotation change [rad] the refinement may make to a linear solution (see
// TrifocalMotionOptions::refine).
constexpr double kMaxRefinementStep = 0.02;

Eigen::Matrix2d rotation(double theta) {
  Eigen::Matrix2d R;
  R << std::cos(theta), std::sin(theta), -std::sin(theta), std::cos(theta);
  return R;
}

ProjectionMatrix projection(const TrifocalMotion& motion, int view) {
  ProjectionMatrix M = ProjectionMatrix::Zero();
  if (view == 1) {
    M.leftCols<2>().setIdentity();
  } else if (view == 2) {
    M << rotation(motion.theta_second), motion.t_second;
  } else {
    M << rotation(motion.theta_third), motion.t_third;
  }
  return M;
}

const Bearing& viewBearing(const BearingTriplet& t, int view) {
  return view == 1 ? t.first : (view == 2 ? t.second : t.third);
}

// Homogeneous landmark (docs/math.md §5.7) and the smallest two singular values over the largest.
Eigen::Vector3d triangulateHomogeneous(const TrifocalMotion& motion, const BearingTriplet& t, double* rank_gap) {
  Eigen::Matrix3d A;
  for (int view = 1; view <= 3; ++view) {
    const ProjectionMatrix M = projection(motion, view);
    const Bearing& u = viewBearing(t, view);
    A.row(view - 1) = u(1) * M.row(0) - u(0) * M.row(1);
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(A, Eigen::ComputeFullV);
  if (rank_gap != nullptr) {
    const auto& sv = svd.singularValues();
    *rank_gap = sv(0) > 0.0 ? sv(1) / sv(0) : 0.0;
  }
  return svd.matrixV().col(2);
}

// Triplets whose triangulated landmark (w > 0) is in front of all three views.
int countInFront(const TrifocalMotion& motion, const std::vector<BearingTriplet>& triplets) {
  int count = 0;
  for (const auto& t : triplets) {
    Eigen::Vector3d x = triangulateHomogeneous(motion, t, nullptr);
    if (x(2) < 0.0) x = -x;
    bool in_front = x(2) > 0.0;
    for (int view = 1; view <= 3 && in_front; ++view) {
      in_front = viewBearing(t, view).dot(projection(motion, view) * x) > 0.0;
    }
    count += in_front ? 1 : 0;
  }
  return count;
}

double directionAngle(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  if (!(a.norm() > 0.0) || !(b.norm() > 0.0)) return 0.0;
  return std::acos(std::clamp(a.dot(b) / (a.norm() * b.norm()), -1.0, 1.0));
}

}  // namespace

Eigen::Vector2d TrifocalMotion::centreSecond() const { return -rotation(theta_second).transpose() * t_second; }
Eigen::Vector2d TrifocalMotion::centreThird() const { return -rotation(theta_third).transpose() * t_third; }

TrifocalMotion TrifocalMotion::scaled(double factor) const {
  TrifocalMotion m = *this;
  m.t_second *= factor;
  m.t_third *= factor;
  return m;
}

TrifocalTensor1d tensorFromMotion(const TrifocalMotion& motion) {
  // T_ijk = det[s_i M(ī); s_j M'(j̄); s_k M''(k̄)], ī: 1 -> row 2, 2 -> row 1 with s = −1.
  const ProjectionMatrix M[3] = {projection(motion, 1), projection(motion, 2), projection(motion, 3)};
  auto picked = [&](int view, int index) -> Eigen::RowVector3d {
    return index == 1 ? Eigen::RowVector3d(M[view].row(1)) : Eigen::RowVector3d(-M[view].row(0));
  };
  TrifocalTensor1d T;
  for (int i = 1; i <= 2; ++i) {
    for (int j = 1; j <= 2; ++j) {
      for (int k = 1; k <= 2; ++k) {
        Eigen::Matrix3d rows;
        rows << picked(0, i), picked(1, j), picked(2, k);
        T(tensorIndex(i, j, k)) = rows.determinant();
      }
    }
  }
  return T;
}

Bearing projectBearing(const TrifocalMotion& motion, const Eigen::Vector2d& landmark, int view) {
  const Eigen::Vector2d q = projection(motion, view) * Eigen::Vector3d(landmark.x(), landmark.y(), 1.0);
  return q / q.norm();
}

Expected<std::vector<TrifocalMotionCandidate>> motionCandidates(const TrifocalTensor1d& T,
                                                                const std::vector<BearingTriplet>& triplets) {
  if (!T.allFinite() || !(T.norm() > 0.0)) return Status(StatusCode::kInvalidInput, "trifocal tensor is not finite or zero");
  for (const auto& t : triplets) {
    if (!t.first.allFinite() || !t.second.allFinite() || !t.third.allFinite()) {
      return Status(StatusCode::kInvalidInput, "a bearing triplet is not finite");
    }
  }
  // docs/math.md §5.6.
  const Complex I(0.0, 1.0);
  const Complex a(T(1), T(5)), b(T(3), T(7)), c(T(4), -T(0)), d(T(6), -T(2));
  const Complex P = a - c, Q = d - b;
  const Complex S = 0.5 * ((a + c) - I * (b + d));
  const Complex A = (Q + I * P) / 2.0;  // ω''(t'x + i t'z)
  const Complex B = I * S;              // ω'(t''x + i t''z)
  const Complex v = (Q - I * P) / 2.0;  // ω''² Ā − ω'² B̄
  const double scale = T.norm();
  if (std::abs(A) < kDegenerateFraction * scale || std::abs(B) < kDegenerateFraction * scale ||
      std::abs(v) < kDegenerateFraction * scale) {
    return Status(StatusCode::kDegenerate,
                  "trifocal motion: no baseline between two of the views (|t'|, |t''| or |v| vanishes)");
  }
  const double rA = std::abs(A), rB = std::abs(B), rv = std::abs(v);
  const double l = (rA * rA - rB * rB + rv * rv) / (2.0 * rv);
  const double h = std::sqrt(std::max(0.0, rA * rA - l * l));
  std::vector<TrifocalMotionCandidate> candidates;
  for (const double sign : {1.0, -1.0}) {
    const Complex p = Complex(l, sign * h) * v / rv;
    const Complex X = p / std::conj(A);
    const Complex Y = (p - v) / std::conj(B);
    const double theta_third = 0.5 * std::arg(X);
    const double theta_second = 0.5 * std::arg(Y);
    const Complex t_second = A / std::polar(1.0, theta_third);
    const Complex t_third = B / std::polar(1.0, theta_second);
    // Sign variants (θ' + e1 π, θ'' + e2 π, global sign g; t' ← g(−1)^e2 t', t'' ← g(−1)^e1 t''):
    // all give the same tensor; cheirality decides.
    TrifocalMotionCandidate best;
    best.in_front = -1;
    for (int e1 = 0; e1 <= 1; ++e1) {
      for (int e2 = 0; e2 <= 1; ++e2) {
        for (const double g : {1.0, -1.0}) {
          TrifocalMotion m;
          m.theta_second = wrapToPi(theta_second + e1 * M_PI);
          m.theta_third = wrapToPi(theta_third + e2 * M_PI);
          m.t_second = g * (e2 ? -1.0 : 1.0) * Eigen::Vector2d(t_second.real(), t_second.imag());
          m.t_third = g * (e1 ? -1.0 : 1.0) * Eigen::Vector2d(t_third.real(), t_third.imag());
          const double norm = std::hypot(m.t_second.norm(), m.t_third.norm());
          m = m.scaled(1.0 / norm);
          const int in_front = countInFront(m, triplets);
          if (in_front > best.in_front) best = TrifocalMotionCandidate{m, in_front};
        }
      }
    }
    candidates.push_back(best);
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const auto& x, const auto& y) { return x.in_front > y.in_front; });
  return candidates;
}

void TrifocalMotionOptions::validate() const {
  if (!(min_in_front_fraction >= 0.0 && min_in_front_fraction <= 1.0)) {
    throw std::invalid_argument("min_in_front_fraction must be in [0, 1]");
  }

}

Expected<TrifocalMotionEstimate> estimateTrifocalMotion(const TrifocalTensor1d& T,
                                                       const std::vector<BearingTriplet>& triplets,
                                                       const std::optional<TrifocalMotionPrior>& prior,
                                                       const TrifocalMotionOptions& options) {
  options.validate();
  const auto candidates = motionCandidates(T, triplets);
  if (!candidates) return candidates.status();
  const int needed = static_cast<int>(std::ceil(options.min_in_front_fraction * static_cast<double>(triplets.size())));
  std::vector<TrifocalMotionCandidate> passing;
  for (const auto& c : *candidates) {
    if (c.in_front >= needed) passing.push_back(c);
  }
  if (passing.empty()) {
    return Status(StatusCode::kNoConsensus, "trifocal motion: no candidate has " + std::to_string(needed) + " of " +
                                                std::to_string(triplets.size()) +
                                                " landmarks in front of the three views (best " +
                                                std::to_string((*candidates)[0].in_front) + ")");
  }
  // The candidate: the one passing cheirality, or of two the one the prior prefers (chosen on the
  // linear solutions: refining both first let the adjustment move the wrong one towards the prior).
  TrifocalMotionEstimate estimate;
  estimate.motion = passing[0].motion;
  estimate.in_front = passing[0].in_front;
  estimate.ambiguous = passing.size() > 1;
  if (prior) {
    const double prior_baseline = std::hypot(prior->centre_second.norm(), prior->centre_third.norm());
    if (!std::isfinite(prior_baseline) || !std::isfinite(prior->theta_second) || !std::isfinite(prior->theta_third)) {
      return Status(StatusCode::kInvalidInput, "trifocal motion: the odometry prior is not finite");
    }
    if (!(prior_baseline > 0.0)) {
      return Status(StatusCode::kDegenerate, "trifocal motion: the odometry prior has no baseline (no metric scale)");
    }
    double best_cost = INFINITY;
    for (const auto& c : passing) {
      const double cost = std::abs(wrapToPi(c.motion.theta_second - prior->theta_second)) +
                          std::abs(wrapToPi(c.motion.theta_third - prior->theta_third)) +
                          directionAngle(c.motion.centreSecond(), prior->centre_second) +
                          directionAngle(c.motion.centreThird(), prior->centre_third);
      if (cost < best_cost) {
        best_cost = cost;
        estimate.motion = c.motion;
        estimate.in_front = c.in_front;
      }
    }
    estimate.ambiguous = false;
  }
  if (options.refine) {
    const auto refined = refineTrifocalMotion(estimate.motion, triplets);
    // With little parallax (forward motion, far landmarks) the adjustment can trade translation
    // for landmark depth or slide into the other candidate's basin (MovB at 1 px: 0.01 -> 0.5 rad;
    // the simulated room: 0.4° -> 1.9°); such a step is not a refinement, the linear solution stays.
    if (refined && std::abs(wrapToPi(refined->theta_second - estimate.motion.theta_second)) < kMaxRefinementStep &&
        std::abs(wrapToPi(refined->theta_third - estimate.motion.theta_third)) < kMaxRefinementStep) {
      estimate.motion = *refined;
    }
  }
  if (prior) {
    // Least-squares scale of the centres onto the prior's.
    const Eigen::Vector2d c2 = estimate.motion.centreSecond(), c3 = estimate.motion.centreThird();
    const double factor = (c2.dot(prior->centre_second) + c3.dot(prior->centre_third)) /
                          (c2.squaredNorm() + c3.squaredNorm());
    estimate.motion = estimate.motion.scaled(factor);
    estimate.metric = true;
  }
  return estimate;
}

namespace {

using MotionParameters = Eigen::Matrix<double, 6, 1>;  // θ', θ'', t'x, t'z, t''x, t''z

TrifocalMotion fromParameters(const MotionParameters& p) {
  TrifocalMotion m;
  m.theta_second = p(0);
  m.theta_third = p(1);
  m.t_second = p.segment<2>(2);
  m.t_third = p.segment<2>(4);
  return m;
}

// Signed angles between the bearings of landmark x (frame 1) predicted in the three views and the
// measured ones.
Eigen::Vector3d bearingResiduals(const TrifocalMotion& motion, const Eigen::Vector2d& x, const BearingTriplet& t) {
  Eigen::Vector3d r;
  for (int view = 1; view <= 3; ++view) {
    const Eigen::Vector2d q = projection(motion, view) * Eigen::Vector3d(x.x(), x.y(), 1.0);
    r(view - 1) = std::remainder(std::atan2(q.x(), q.y()) - bearingAngle(viewBearing(t, view)), 2.0 * M_PI);
  }
  return r;
}

}  // namespace

Expected<TrifocalMotion> refineTrifocalMotion(const TrifocalMotion& initial, const std::vector<BearingTriplet>& triplets,
                                              int max_iterations) {
  if (triplets.size() < 5) {
    return Status(StatusCode::kTooFewPoints, "trifocal refinement needs 5 triplets, got " + std::to_string(triplets.size()));
  }
  MotionParameters p;
  p << initial.theta_second, initial.theta_third, initial.t_second, initial.t_third;
  if (!p.allFinite()) return Status(StatusCode::kInvalidInput, "trifocal refinement: the initial motion is not finite");
  for (const auto& t : triplets) {
    if (!t.first.allFinite() || !t.second.allFinite() || !t.third.allFinite()) {
      return Status(StatusCode::kInvalidInput, "trifocal refinement: a bearing triplet is not finite");
    }
  }
  const double norm = p.tail<4>().norm();
  if (!(norm > 0.0)) return Status(StatusCode::kDegenerate, "trifocal refinement: the motion has no translation");
  // Bundle adjustment (the maximum-likelihood estimate for Gaussian bearing noise): motion and
  // landmarks, angular residuals in the three views, Levenberg-Marquardt with the landmarks
  // eliminated by the Schur complement (2x2 blocks). Landmarks without parallax are left out.
  std::vector<Eigen::Vector2d> landmarks;
  std::vector<const BearingTriplet*> used;
  for (const auto& t : triplets) {
    const auto x = triangulateLandmark(initial, t);
    if (!x) continue;
    landmarks.push_back(*x);
    used.push_back(&t);
  }
  if (used.size() < 5) return Status(StatusCode::kDegenerate, "trifocal refinement: fewer than 5 landmarks with parallax");
  auto totalCost = [&](const MotionParameters& params, const std::vector<Eigen::Vector2d>& xs) {
    const TrifocalMotion m = fromParameters(params);
    double c = 0.0;
    for (std::size_t n = 0; n < used.size(); ++n) c += bearingResiduals(m, xs[n], *used[n]).squaredNorm();
    return c;
  };
  double cost = totalCost(p, landmarks);
  double lambda = 1e-3;
  const std::size_t count = used.size();
  std::vector<Eigen::Matrix<double, 3, 6>> Jm(count);
  std::vector<Eigen::Matrix<double, 3, 2>> Jx(count);
  std::vector<Eigen::Vector3d> r(count);
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    const TrifocalMotion m = fromParameters(p);
    for (std::size_t n = 0; n < count; ++n) {
      r[n] = bearingResiduals(m, landmarks[n], *used[n]);
      for (int k = 0; k < 6; ++k) {  // central differences
        const double h = 1e-7 * std::max(1.0, std::abs(p(k)));
        MotionParameters plus = p, minus = p;
        plus(k) += h;
        minus(k) -= h;
        Jm[n].col(k) = (bearingResiduals(fromParameters(plus), landmarks[n], *used[n]) -
                        bearingResiduals(fromParameters(minus), landmarks[n], *used[n])) / (2.0 * h);
      }
      for (int k = 0; k < 2; ++k) {
        const double h = 1e-7 * std::max(1.0, std::abs(landmarks[n](k)));
        Eigen::Vector2d plus = landmarks[n], minus = landmarks[n];
        plus(k) += h;
        minus(k) -= h;
        Jx[n].col(k) = (bearingResiduals(m, plus, *used[n]) - bearingResiduals(m, minus, *used[n])) / (2.0 * h);
      }
    }
    bool improved = false;
    for (int attempt = 0; attempt < 10 && !improved; ++attempt) {
      Eigen::Matrix<double, 6, 6> S = Eigen::Matrix<double, 6, 6>::Zero();
      MotionParameters rhs = MotionParameters::Zero();
      std::vector<Eigen::Matrix2d> V_inverse(count);
      for (std::size_t n = 0; n < count; ++n) {
        Eigen::Matrix<double, 6, 6> U = Jm[n].transpose() * Jm[n];
        Eigen::Matrix2d V = Jx[n].transpose() * Jx[n];
        const Eigen::Matrix<double, 6, 2> W = Jm[n].transpose() * Jx[n];
        U.diagonal() *= 1.0 + lambda;
        V.diagonal() *= 1.0 + lambda;
        V.diagonal().array() += 1e-12;
        V_inverse[n] = V.inverse();
        S += U - W * V_inverse[n] * W.transpose();
        rhs += -Jm[n].transpose() * r[n] + W * V_inverse[n] * (Jx[n].transpose() * r[n]);
      }
      S.diagonal().array() += 1e-12;
      const MotionParameters dp = S.ldlt().solve(rhs);
      MotionParameters candidate = p + dp;
      std::vector<Eigen::Vector2d> moved(count);
      for (std::size_t n = 0; n < count; ++n) {
        const Eigen::Matrix<double, 6, 2> W = Jm[n].transpose() * Jx[n];
        moved[n] = landmarks[n] + V_inverse[n] * (-Jx[n].transpose() * r[n] - W.transpose() * dp);
      }
      // Gauge: the translation norm stays; the landmarks scale with it.
      const double factor = norm / candidate.tail<4>().norm();
      candidate.tail<4>() *= factor;
      for (auto& x : moved) x *= factor;
      const double candidate_cost = candidate.allFinite() ? totalCost(candidate, moved) : INFINITY;
      if (candidate_cost < cost) {
        const double decrease = (cost - candidate_cost) / std::max(cost, 1e-300);
        p = candidate;
        landmarks = std::move(moved);
        cost = candidate_cost;
        lambda = std::max(1e-9, lambda / 10.0);
        improved = true;
        if (decrease < 1e-10) iteration = max_iterations;  // converged
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) break;
  }
  TrifocalMotion refined = fromParameters(p);
  refined.theta_second = wrapToPi(refined.theta_second);
  refined.theta_third = wrapToPi(refined.theta_third);
  return refined;
}

Expected<Eigen::Vector2d> triangulateLandmark(const TrifocalMotion& motion, const BearingTriplet& triplet) {
  if (!triplet.first.allFinite() || !triplet.second.allFinite() || !triplet.third.allFinite()) {
    return Status(StatusCode::kInvalidInput, "landmark bearings are not finite");
  }
  double rank_gap = 0.0;
  const Eigen::Vector3d x = triangulateHomogeneous(motion, triplet, &rank_gap);
  if (!(rank_gap > 1e-9) || !(std::abs(x(2)) > 1e-12)) {
    return Status(StatusCode::kDegenerate,
                  "landmark has no parallax (at infinity or on the line of the camera centres)");
  }
  return Eigen::Vector2d(x(0) / x(2), x(1) / x(2));
}

}  // namespace homography_teach_repeat
