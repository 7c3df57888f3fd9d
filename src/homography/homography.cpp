#include "homography_teach_repeat/homography/homography.h"

#include <Eigen/Geometry>
#include <Eigen/QR>
#include <Eigen/SVD>

#include <opencv2/core.hpp>

#include <cmath>
#include <fstream>
#include <limits>
#include <string>

namespace homography_teach_repeat {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Ratio of the smallest to the largest principal spread of a point set (0: collinear).
double collinearityRatio(const std::vector<Eigen::Vector2d>& points) {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : points) mean += p;
  mean /= static_cast<double>(points.size());
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  for (const auto& p : points) scatter += (p - mean) * (p - mean).transpose();
  const Eigen::Vector2d eigenvalues = Eigen::JacobiSVD<Eigen::Matrix2d>(scatter).singularValues();
  if (!(eigenvalues(0) > 0.0)) return 0.0;
  return eigenvalues(1) / eigenvalues(0);
}

}  // namespace

Expected<HartleyNormalization> computeHartleyNormalization(const std::vector<Eigen::Vector2d>& points) {
  if (points.empty()) return Status(StatusCode::kTooFewPoints, "no points to normalise");
  HartleyNormalization n;
  for (const auto& p : points) n.centroid += p;
  n.centroid /= static_cast<double>(points.size());
  double mean_distance = 0.0;
  for (const auto& p : points) mean_distance += (p - n.centroid).norm();
  mean_distance /= static_cast<double>(points.size());
  if (!(mean_distance > 0.0) || !std::isfinite(mean_distance)) {
    return Status(StatusCode::kDegenerate, "all points coincide");
  }
  n.scale = std::sqrt(2.0) / mean_distance;
  n.transform << n.scale, 0.0, -n.scale * n.centroid.x(), 0.0, n.scale, -n.scale * n.centroid.y(),
      0.0, 0.0, 1.0;
  return n;
}

Expected<NormalizedDlt> solveNormalizedDlt(const PointMatches& matches) {
  const std::size_t n = matches.size();
  if (n < 4) {
    return Status(StatusCode::kTooFewPoints,
                  "a homography needs at least 4 matches, got " + std::to_string(n));
  }
  std::vector<Eigen::Vector2d> reference(n), current(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!matches[i].reference.allFinite() || !matches[i].current.allFinite()) {
      return Status(StatusCode::kInvalidInput, "match " + std::to_string(i) + " is not finite");
    }
    reference[i] = matches[i].reference;
    current[i] = matches[i].current;
  }
  constexpr double kCollinear = 1e-12;
  if (collinearityRatio(reference) < kCollinear || collinearityRatio(current) < kCollinear) {
    return Status(StatusCode::kDegenerate, "the points are collinear in one of the images");
  }
  const auto t1 = computeHartleyNormalization(reference);
  const auto t2 = computeHartleyNormalization(current);
  if (!t1) return t1.status();
  if (!t2) return t2.status();

  Eigen::MatrixXd a(2 * n, 9);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d p = t1->transform * reference[i].homogeneous();
    const Eigen::Vector3d q = t2->transform * current[i].homogeneous();
    const double u2 = q.x();
    const double v2 = q.y();
    const auto row = static_cast<Eigen::Index>(2 * i);
    a.row(row) << 0.0, 0.0, 0.0, -p.transpose(), v2 * p.transpose();
    a.row(row + 1) << p.transpose(), 0.0, 0.0, 0.0, -u2 * p.transpose();
  }
  // A = QR leaves the singular values and right singular vectors unchanged, and the 9x9 R is
  // cheap to decompose: O(n) instead of a Jacobi SVD of the tall 2n x 9 matrix. The QR runs in
  // place: copies of A made glibc trim and regrow the heap on every call (page faults dominated
  // the cost at 500 matches, bench_homography).
  Eigen::Matrix<double, 9, 9> square = Eigen::Matrix<double, 9, 9>::Zero();
  if (a.rows() > 9) {
    const Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr(a);
    square = a.topRows(9).triangularView<Eigen::Upper>();
  } else {
    // 4 matches: Â is 8x9; a zero ninth row changes neither V nor the singular values.
    square.topRows(a.rows()) = a;
  }
  const Eigen::JacobiSVD<Eigen::Matrix<double, 9, 9>> svd(square, Eigen::ComputeFullV);
  const Eigen::Matrix<double, 9, 1>& s = svd.singularValues();
  // A second null direction means the solution is not unique (e.g. three of four points
  // collinear).
  if (!(s(7) >= 1e-9 * s(0))) {
    return Status(StatusCode::kDegenerate,
                  "the DLT system has no unique solution (degenerate point configuration)");
  }
  NormalizedDlt result;
  result.right_singular_vectors = svd.matrixV();
  result.singular_values = s;
  result.match_count = n;
  const auto h = result.right_singular_vectors.col(8);
  result.H_normalized << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  result.reference_normalization = *t1;
  result.current_normalization = *t2;
  // H = T2⁻¹ Ĥ T1.
  result.H_unscaled = t2->transform.inverse() * result.H_normalized * t1->transform;
  if (!result.H_unscaled.allFinite() || !(result.H_unscaled.norm() > 0.0)) {
    return Status(StatusCode::kNotFinite, "the DLT produced a non-finite homography");
  }
  return result;
}

Expected<Eigen::Matrix3d> estimateHomographyDlt(const PointMatches& matches) {
  const auto dlt = solveNormalizedDlt(matches);
  if (!dlt) return dlt.status();
  return Eigen::Matrix3d(dlt->H_unscaled / dlt->H_unscaled.norm());
}

Eigen::Vector2d applyHomography(const Eigen::Matrix3d& H, const Eigen::Vector2d& point) {
  const Eigen::Vector3d q = H * point.homogeneous();
  if (q.z() == 0.0) return Eigen::Vector2d(kNaN, kNaN);
  return q.hnormalized();
}

double transferError(const Eigen::Matrix3d& H, const PointMatch& match) {
  return (match.current - applyHomography(H, match.reference)).norm();
}

double rmsTransferError(const Eigen::Matrix3d& H, const PointMatches& matches) {
  if (matches.empty()) return 0.0;
  double sum = 0.0;
  for (const PointMatch& match : matches) sum += std::pow(transferError(H, match), 2);
  return std::sqrt(sum / static_cast<double>(matches.size()));
}

double symmetricTransferErrorSquared(const Eigen::Matrix3d& H, const Eigen::Matrix3d& H_inverse,
                                     const PointMatch& match) {
  return (match.current - applyHomography(H, match.reference)).squaredNorm() +
         (match.reference - applyHomography(H_inverse, match.current)).squaredNorm();
}

Expected<double> meanGridTransferDifference(const Eigen::Matrix3d& H_a, const Eigen::Matrix3d& H_b,
                                            int width, int height, int width_b, int height_b,
                                            int step) {
  if (step <= 0 || width <= 0 || height <= 0) {
    return Status(StatusCode::kInvalidInput, "grid size and step must be positive");
  }
  double sum = 0.0;
  int count = 0;
  for (int v = 0; v < height; v += step) {
    for (int u = 0; u < width; u += step) {
      const Eigen::Vector2d p(u, v);
      const Eigen::Vector2d qb = applyHomography(H_b, p);
      if (!qb.allFinite() || qb.x() < 0 || qb.y() < 0 || qb.x() > width_b - 1 ||
          qb.y() > height_b - 1) {
        continue;
      }
      sum += (applyHomography(H_a, p) - qb).norm();
      ++count;
    }
  }
  if (count == 0) {
    return Status(StatusCode::kInvalidInput, "no grid point maps inside the second image");
  }
  return sum / count;
}

namespace {
bool endsWith(const std::string& text, const std::string& suffix) {
  return text.size() >= suffix.size() &&
         text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}
}  // namespace

Expected<Eigen::Matrix3d> readHomographyFile(const std::string& path) {
  Eigen::Matrix3d H;
  if (endsWith(path, ".xml") || endsWith(path, ".yml") || endsWith(path, ".yaml")) {
    cv::Mat m;
    try {
      cv::FileStorage storage(path, cv::FileStorage::READ);
      if (!storage.isOpened() || storage.root().empty()) {
        return Status(StatusCode::kInvalidInput, "cannot open homography file '" + path + "'");
      }
      (*storage.root().begin()) >> m;
    } catch (const cv::Exception& e) {
      return Status(StatusCode::kInvalidInput,
                    "cannot parse homography file '" + path + "': " + e.what());
    }
    if (m.rows != 3 || m.cols != 3) {
      return Status(StatusCode::kInvalidInput, "homography file '" + path + "' is not 3x3");
    }
    m.convertTo(m, CV_64F);
    for (int k = 0; k < 9; ++k) H(k / 3, k % 3) = m.at<double>(k / 3, k % 3);
  } else {
    std::ifstream in(path);
    if (!in) return Status(StatusCode::kInvalidInput, "cannot open homography file '" + path + "'");
    for (int k = 0; k < 9; ++k) {
      if (!(in >> H(k / 3, k % 3))) {
        return Status(StatusCode::kInvalidInput,
                      "homography file '" + path + "' needs 9 numbers, found " + std::to_string(k));
      }
    }
  }
  if (!H.allFinite()) {
    return Status(StatusCode::kInvalidInput, "homography file '" + path + "' is not finite");
  }
  return H;
}

}  // namespace homography_teach_repeat
