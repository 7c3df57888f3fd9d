#include "homography_teach_repeat/mu/heading_1d.h"

#include <Eigen/LU>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <string>

namespace homography_teach_repeat {
namespace {

Eigen::Matrix2d perpendicular() {
  Eigen::Matrix2d J;
  J << 0.0, -1.0, 1.0, 0.0;
  return J;
}

}  // namespace

Status LineCamera::validate() const {
  if (!std::isfinite(f) || !(f > 0.0) || !std::isfinite(x0)) {
    return Status(StatusCode::kInvalidInput, "line camera needs finite f > 0 and finite x0");
  }
  return Status::ok();
}

Expected<Eigen::Matrix2d> centredHomography1d(const Eigen::Matrix2d& H, double x0) {
  if (!H.allFinite() || !std::isfinite(x0)) {
    return Status(StatusCode::kNotFinite, "1D homography or x0 is not finite");
  }
  Eigen::Matrix2d T, T_inverse;
  T << 1.0, -x0, 0.0, 1.0;
  T_inverse << 1.0, x0, 0.0, 1.0;
  Eigen::Matrix2d Hc = T * H * T_inverse;
  if (!(std::abs(Hc(1, 1)) > 1e-12 * Hc.norm())) {
    return Status(StatusCode::kDegenerate, "h22 of the centred 1D homography is zero");
  }
  if (Hc(1, 1) < 0.0) Hc = -Hc;
  return Hc;
}

Expected<double> muOf(const Eigen::Matrix2d& H, double x0) {
  const auto Hc = centredHomography1d(H, x0);
  if (!Hc) return Hc.status();
  return (*Hc)(0, 1) / (*Hc)(1, 1);
}

Expected<double> headingFromMu(const Eigen::Matrix2d& H, const LineCamera& camera) {
  const Status valid = camera.validate();
  if (!valid.isOk()) return valid;
  const auto mu = muOf(H, camera.x0);
  if (!mu) return mu.status();
  return std::atan(*mu / camera.f);
}

Expected<Eigen::Matrix2d> planeHomography1d(const PlanarPose& current, const Eigen::Vector2d& normal_xz,
                                            double distance, double f) {
  if (!normal_xz.allFinite() || std::abs(normal_xz.norm() - 1.0) > 1e-6 || !(distance > 0.0) ||
      !std::isfinite(distance) || !(f > 0.0) || !std::isfinite(f) || !current.isFinite()) {
    return Status(StatusCode::kInvalidInput,
                  "plane homography: needs a finite unit normal, a distance > 0, f > 0 and a finite pose");
  }
  const double c = std::cos(current.theta), s = std::sin(current.theta);
  Eigen::Matrix2d R;
  R << c, s, -s, c;  // X2 = R X1 + t (docs/math.md §4.1)
  const Eigen::Vector2d t = -R * Eigen::Vector2d(current.x, current.z);
  const Eigen::Matrix2d M = R + t * normal_xz.transpose() / distance;
  Eigen::Matrix2d H;
  H << M(0, 0), f * M(0, 1), M(1, 0) / f, M(1, 1);
  if (!(H(1, 1) > 0.0)) {
    return Status(StatusCode::kDegenerate, "plane homography: the wall is not in front of both cameras");
  }
  return H;
}

Expected<double> predictedMu(const PlanarPose& current, const Eigen::Vector2d& normal_xz, double distance,
                             double f) {
  const auto H = planeHomography1d(current, normal_xz, distance, f);
  if (!H) return H.status();
  return (*H)(0, 1) / (*H)(1, 1);
}

Expected<double> headingFromT(const Eigen::Matrix2d& H, const LineCamera& camera) {
  const Status valid = camera.validate();
  if (!valid.isOk()) return valid;
  const auto Hc = centredHomography1d(H, camera.x0);
  if (!Hc) return Hc.status();
  return std::atan(-camera.f * (*Hc)(1, 0) / (*Hc)(1, 1));
}

Expected<double> headingMagnitudeFromEigenvalues(const Eigen::Matrix2d& H) {
  if (!H.allFinite()) return Status(StatusCode::kNotFinite, "1D homography is not finite");
  Eigen::Matrix2d Hs = H(1, 1) < 0.0 ? Eigen::Matrix2d(-H) : H;
  const double det = Hs.determinant();
  if (!(det > 0.0)) {
    return Status(StatusCode::kDegenerate, "det H <= 0: not a rotation-like 1D homography");
  }
  // Similarity invariant: independent of f and x0 (docs/math.md §4.6).
  const double c = Hs.trace() / (2.0 * std::sqrt(det));
  return std::acos(std::clamp(c, -1.0, 1.0));
}

Expected<std::vector<CompleteMotion1d>> completeMotion1d(const Eigen::Matrix2d& H,
                                                         const LineCamera& camera,
                                                         const std::vector<double>& reference_xs,
                                                         std::optional<double> depth_ratio) {
  const Status valid = camera.validate();
  if (!valid.isOk()) return valid;
  if (!H.allFinite()) return Status(StatusCode::kNotFinite, "1D homography is not finite");
  if (reference_xs.empty()) {
    return Status(StatusCode::kInvalidInput, "complete motion needs the reference line positions");
  }
  if (depth_ratio && !(*depth_ratio > 0.0 && std::isfinite(*depth_ratio))) {
    return Status(StatusCode::kInvalidInput, "depth ratio d2/d1 must be finite and > 0");
  }
  Eigen::Matrix2d K, K_inverse;
  K << camera.f, camera.x0, 0.0, 1.0;
  K_inverse = K.inverse();
  // 1. Calibrated H, sign so that (Hc m1)_2 = Z2/Z1 > 0 for the lines.
  Eigen::Matrix2d Hc = K_inverse * H * K;
  double votes = 0.0;
  for (const double x : reference_xs) {
    votes += (Hc * (K_inverse * Eigen::Vector2d(x, 1.0))).y() > 0.0 ? 1.0 : -1.0;
  }
  if (votes < 0.0) Hc = -Hc;
  const double det = Hc.determinant();
  if (!(det > 0.0)) return Status(StatusCode::kDegenerate, "det of the calibrated 1D H <= 0");
  // True scale: det Hc = d2/d1 (docs/math.md §4.7); det = 1 when the ratio is unknown.
  Hc *= std::sqrt(depth_ratio.value_or(1.0) / det);
  // 2. SVD, λi = σi².
  const Eigen::JacobiSVD<Eigen::Matrix2d> svd(Hc, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const double lambda1 = svd.singularValues()(0) * svd.singularValues()(0);
  const double lambda2 = svd.singularValues()(1) * svd.singularValues()(1);
  const Eigen::Matrix2d& V = svd.matrixV();
  const Eigen::Matrix2d J = perpendicular();
  Eigen::Vector2d mean_ray = Eigen::Vector2d::Zero();
  for (const double x : reference_xs) mean_ray += (K_inverse * Eigen::Vector2d(x, 1.0)).normalized();

  std::vector<CompleteMotion1d> solutions;
  auto addSolution = [&](const Eigen::Vector2d& w) {
    const Eigen::Vector2d hw = Hc * w;
    Eigen::Matrix2d A, B;
    A << hw, J * hw;
    B << w, J * w;
    const Eigen::Matrix2d R = A * B.transpose();
    Eigen::Vector2d n = J * w;
    if (n.dot(mean_ray) < 0.0) n = -n;
    CompleteMotion1d m;
    m.theta = std::atan2(R(0, 1), R(0, 0));
    m.normal = n;
    m.translation_over_distance = (Hc - R) * n;
    if (std::isfinite(m.theta) && m.translation_over_distance.allFinite()) solutions.push_back(m);
  };
  const double spread = lambda1 - lambda2;
  if (spread < 1e-12) {
    // 8. λ1 = λ2 (= 1 at the true scale): t = 0, R = Hc.
    CompleteMotion1d m;
    m.theta = std::atan2(Hc(0, 1), Hc(0, 0));
    m.normal = mean_ray.normalized();
    solutions.push_back(m);
    return solutions;
  }
  // 3-4. w = α v1 ± β v2 with |Hc w| = |w| = 1 (clamped: noise can push λ's past 1).
  const double alpha = std::sqrt(std::clamp((1.0 - lambda2) / spread, 0.0, 1.0));
  const double beta = std::sqrt(std::clamp((lambda1 - 1.0) / spread, 0.0, 1.0));
  addSolution(alpha * V.col(0) + beta * V.col(1));
  if (beta > 1e-12 && alpha > 1e-12) addSolution(alpha * V.col(0) - beta * V.col(1));
  if (solutions.empty()) return Status(StatusCode::kNotFinite, "complete motion is not finite");
  return solutions;
}

Expected<FocalFit> fitFocalFromMu(const std::vector<std::pair<double, double>>& samples) {
  double numerator = 0.0, denominator = 0.0;
  FocalFit fit;
  for (const auto& [theta, mu] : samples) {
    if (!std::isfinite(theta) || !std::isfinite(mu)) {
      return Status(StatusCode::kInvalidInput, "a calibration sample is not finite");
    }
    const double t = std::tan(theta);
    numerator += mu * t;
    denominator += t * t;
    if (theta != 0.0) ++fit.samples;
  }
  if (fit.samples == 0 || !(denominator > 0.0)) {
    return Status(StatusCode::kTooFewPoints, "focal calibration needs rotations other than 0");
  }
  fit.f = numerator / denominator;
  if (!(fit.f > 0.0)) {
    return Status(StatusCode::kDegenerate,
                  "μ does not grow with the rotation (f <= 0): check the sign of the angles");
  }
  double sum = 0.0;
  for (const auto& [theta, mu] : samples) sum += std::pow(mu - fit.f * std::tan(theta), 2);
  fit.rms_residual_px = std::sqrt(sum / static_cast<double>(samples.size()));
  return fit;
}

}  // namespace homography_teach_repeat
