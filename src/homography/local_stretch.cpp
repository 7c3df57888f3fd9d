#include "homography_teach_repeat/homography/local_stretch.h"

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include <cmath>

namespace homography_teach_repeat {

std::optional<double> localStretch(const Eigen::Matrix3d& H, const Eigen::Vector2d& pixel) {
  const Eigen::Vector3d mapped = H * pixel.homogeneous();
  if (!(std::abs(mapped.z()) > 0.0)) return std::nullopt;
  // d(H x)ₕ/dx = (H₁₂ − (H x)ₕ h₃ᵀ) / w, H₁₂ the top-left 2x2 block, h₃ᵀ the first two of H's last row.
  const Eigen::Matrix2d local = (H.topLeftCorner<2, 2>() - mapped.hnormalized() * H.block<1, 2>(2, 0)) / mapped.z();
  const Eigen::Vector2d singular = Eigen::JacobiSVD<Eigen::Matrix2d>(local).singularValues();
  if (!(singular(1) > 0.0) || !std::isfinite(singular(0))) return std::nullopt;
  return singular(0) / singular(1);
}

namespace {

// The mean of `of`(a) over the pixels where H's local stretch a is defined; nullopt for none.
template <typename Function>
std::optional<double> meanOverStretch(const Eigen::Matrix3d& H, const std::vector<Eigen::Vector2d>& pixels,
                                      Function of) {
  double sum = 0.0;
  int counted = 0;
  for (const Eigen::Vector2d& pixel : pixels) {
    const auto stretch = localStretch(H, pixel);
    if (!stretch) continue;
    sum += of(*stretch);
    ++counted;
  }
  if (counted == 0) return std::nullopt;
  return sum / counted;
}

}  // namespace

double matchStretchNoiseScale(const Eigen::Matrix3d& H, const std::vector<Eigen::Vector2d>& pixels, double gain) {
  if (gain == 0.0) return 1.0;
  const auto mean_square = meanOverStretch(H, pixels, [gain](double a) {
    const double noise = 1.0 + gain * (a - 1.0);
    return noise * noise;
  });
  return mean_square ? std::sqrt(*mean_square) : 1.0;
}

double matchChanceScale(const Eigen::Matrix3d& H, const std::vector<Eigen::Vector2d>& pixels, double decay) {
  if (decay == 0.0) return 1.0;
  return meanOverStretch(H, pixels, [decay](double a) { return std::exp(-decay * (a - 1.0)); }).value_or(1.0);
}

}  // namespace homography_teach_repeat
