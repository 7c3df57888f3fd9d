#include "homography_teach_repeat/homography/homography_decomposition.h"

#include <Eigen/SVD>
#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <cmath>

namespace homography_teach_repeat {
namespace {

Eigen::Matrix3d yawRotation(double theta21) {
  const double c = std::cos(theta21);
  const double s = std::sin(theta21);
  Eigen::Matrix3d r;
  r << c, 0.0, -s, 0.0, 1.0, 0.0, s, 0.0, c;
  return r;
}

}  // namespace

bool HomographyDecomposition::isPlanarMotion(double eps) const {
  return std::abs(rotation21(1, 1) - 1.0) < eps && std::abs(translation_over_distance.y()) < eps;
}

PlanarPose HomographyDecomposition::planarPose(double plane_distance) const {
  const Eigen::Vector3d t21 = -translation_over_distance * plane_distance;
  const Eigen::Vector3d centre = rotation21.transpose() * t21;
  // Ry(θ) = [[c, 0, −s], [0, 1, 0], [s, 0, c]].
  const double theta21 = std::atan2(rotation21(2, 0) - rotation21(0, 2),
                                    rotation21(0, 0) + rotation21(2, 2));
  return PlanarPose(centre.x(), centre.z(), -theta21);
}

Expected<std::vector<HomographyDecomposition>> decomposeHomographyClassic(
    const Eigen::Matrix3d& H, const PinholeCamera& camera) {
  if (!H.allFinite()) return Status(StatusCode::kNotFinite, "homography has NaN/Inf entries");
  cv::Matx33d h_cv, k_cv;
  const Eigen::Matrix3d K = camera.K();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      h_cv(r, c) = H(r, c);
      k_cv(r, c) = K(r, c);
    }
  }
  std::vector<cv::Mat> rotations, translations, normals;
  int count = 0;
  try {
    count = cv::decomposeHomographyMat(h_cv, k_cv, rotations, translations, normals);
  } catch (const cv::Exception& e) {
    return Status(StatusCode::kDegenerate, std::string("decomposeHomographyMat: ") + e.what());
  }
  std::vector<HomographyDecomposition> solutions;
  for (int i = 0; i < count; ++i) {
    HomographyDecomposition d;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) d.rotation21(r, c) = rotations[i].at<double>(r, c);
      d.translation_over_distance(r) = translations[i].at<double>(r);
      d.normal(r) = normals[i].at<double>(r);
    }
    if (d.rotation21.allFinite() && d.translation_over_distance.allFinite() &&
        d.normal.allFinite()) {
      solutions.push_back(d);
    }
  }
  if (solutions.empty()) {
    return Status(StatusCode::kDegenerate, "the classic decomposition found no solution");
  }
  return solutions;
}

std::vector<HomographyDecomposition> filterByPositiveDepth(
    const std::vector<HomographyDecomposition>& solutions, const PinholeCamera& camera,
    const std::vector<Eigen::Vector2d>& reference_pixels, double min_fraction) {
  const Eigen::Matrix3d K_inverse = camera.Kinverse();
  std::vector<HomographyDecomposition> kept;
  const auto required = static_cast<std::ptrdiff_t>(
      std::ceil(std::clamp(min_fraction, 0.0, 1.0) * static_cast<double>(reference_pixels.size())));
  for (const auto& s : solutions) {
    const auto in_front =
        std::count_if(reference_pixels.begin(), reference_pixels.end(), [&](const auto& p) {
          return s.normal.dot(K_inverse * p.homogeneous()) > 0.0;
        });
    if (in_front >= required) kept.push_back(s);
  }
  return kept;
}

Expected<std::vector<HomographyDecomposition>> decomposeHomographyPlanar(
    const Eigen::Matrix3d& H, const PinholeCamera& camera,
    const std::vector<Eigen::Vector2d>& reference_pixels) {
  if (!H.allFinite()) return Status(StatusCode::kNotFinite, "homography has NaN/Inf entries");
  Eigen::Matrix3d m = camera.Kinverse() * H * camera.K();
  // At the true scale row 2 of K⁻¹HK is (0, 1, 0) (docs/math.md §1.3): κ = m(1,1).
  if (!(std::abs(m(1, 1)) > 1e-12 * m.norm())) {
    return Status(StatusCode::kDegenerate, "κ is zero: not a homography of planar motion");
  }
  m /= m(1, 1);
  const double a = -(m(0, 0) + m(2, 2));
  const double b = m(0, 2) - m(2, 0);
  const double r = -(1.0 + m(0, 0) * m(2, 2) - m(0, 2) * m(2, 0));
  const double rho = std::hypot(a, b);
  if (!(rho > 0.0)) return Status(StatusCode::kDegenerate, "Planar-HD: no rotation constraint");
  const double phi = std::atan2(b, a);
  // Noise can push |r/ρ| above 1: the roots then merge at the tangent point.
  const double offset = std::acos(std::clamp(r / rho, -1.0, 1.0));
  std::vector<double> angles{phi + offset};
  if (offset > 1e-12) angles.push_back(phi - offset);

  const Eigen::Matrix3d K_inverse = camera.Kinverse();
  Eigen::Vector3d mean_ray = Eigen::Vector3d::UnitZ();
  if (!reference_pixels.empty()) {
    mean_ray.setZero();
    for (const auto& p : reference_pixels) mean_ray += (K_inverse * p.homogeneous()).normalized();
  }
  std::vector<HomographyDecomposition> solutions;
  for (const double theta21 : angles) {
    HomographyDecomposition d;
    d.rotation21 = yawRotation(theta21);
    const Eigen::Matrix3d residual = m - d.rotation21;
    Eigen::Matrix<double, 2, 3> rows;
    rows << residual.row(0), residual.row(2);
    const Eigen::JacobiSVD<Eigen::Matrix<double, 2, 3>> svd(rows, Eigen::ComputeFullV);
    if (svd.singularValues()(0) < 1e-12) {
      // No translation: any normal explains the homography; keep the viewing direction.
      d.normal = mean_ray.normalized();
      d.translation_over_distance.setZero();
    } else {
      d.normal = svd.matrixV().col(0);
      if (d.normal.dot(mean_ray) < 0.0) d.normal = -d.normal;
      // residual rows = T_{x,z} Nᵀ (H ∝ K (R + T Nᵀ) K⁻¹).
      d.translation_over_distance = Eigen::Vector3d(residual.row(0).dot(d.normal), 0.0,
                                                    residual.row(2).dot(d.normal));
    }
    solutions.push_back(d);
  }
  return solutions;
}

}  // namespace homography_teach_repeat
