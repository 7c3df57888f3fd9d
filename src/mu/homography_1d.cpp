#include "homography_teach_repeat/mu/homography_1d.h"

#include <Eigen/LU>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <set>
#include <stdexcept>
#include <string>

namespace homography_teach_repeat {
namespace {

// Similarity x̂ = s (x − c) for conditioning.
struct Normalization1d {
  double centre = 0.0;
  double scale = 1.0;
  Eigen::Matrix2d matrix() const {
    Eigen::Matrix2d T;
    T << scale, -scale * centre, 0.0, 1.0;
    return T;
  }
};

Normalization1d normalization(const std::vector<double>& xs) {
  Normalization1d n;
  for (double x : xs) n.centre += x;
  n.centre /= static_cast<double>(xs.size());
  double spread = 0.0;
  for (double x : xs) spread += std::abs(x - n.centre);
  spread /= static_cast<double>(xs.size());
  n.scale = spread > 0.0 ? 1.0 / spread : 1.0;
  return n;
}

int distinctCount(std::vector<double> xs) {
  std::sort(xs.begin(), xs.end());
  int count = 0;
  for (std::size_t i = 0; i < xs.size(); ++i) {
    if (i == 0 || xs[i] - xs[i - 1] > 1e-9 * (1.0 + std::abs(xs[i]))) ++count;
  }
  return count;
}

}  // namespace

Expected<Eigen::Matrix2d> estimateHomography1dDlt(const std::vector<LineCorrespondence>& lines) {
  const std::size_t n = lines.size();
  if (n < 3) {
    return Status(StatusCode::kTooFewPoints,
                  "a 1D homography needs at least 3 line matches, got " + std::to_string(n));
  }
  std::vector<double> x1(n), x2(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(lines[i].reference_x) || !std::isfinite(lines[i].current_x)) {
      return Status(StatusCode::kInvalidInput, "line match " + std::to_string(i) + " is not finite");
    }
    x1[i] = lines[i].reference_x;
    x2[i] = lines[i].current_x;
  }
  if (distinctCount(x1) < 3 || distinctCount(x2) < 3) {
    return Status(StatusCode::kDegenerate, "fewer than 3 distinct line positions");
  }
  const Normalization1d t1 = normalization(x1), t2 = normalization(x2);
  Eigen::MatrixXd M(n, 4);
  for (std::size_t i = 0; i < n; ++i) {
    const double a = t1.scale * (x1[i] - t1.centre);
    const double b = t2.scale * (x2[i] - t2.centre);
    M.row(static_cast<Eigen::Index>(i)) << a, 1.0, -a * b, -b;  // docs/math.md §4.2
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(M, Eigen::ComputeFullV);
  const Eigen::VectorXd& s = svd.singularValues();
  if (s.size() < 3 || !(s(2) > 1e-10 * s(0))) {
    return Status(StatusCode::kDegenerate, "the 1D DLT has no unique solution");
  }
  const Eigen::Vector4d h = svd.matrixV().col(3);
  Eigen::Matrix2d H_normalized;
  H_normalized << h(0), h(1), h(2), h(3);
  Eigen::Matrix2d H = t2.matrix().inverse() * H_normalized * t1.matrix();
  if (H(1, 1) < 0.0) H = -H;
  const double norm = H.norm();
  if (!(norm > 0.0) || !H.allFinite()) {
    return Status(StatusCode::kNotFinite, "the 1D DLT produced a non-finite homography");
  }
  return Eigen::Matrix2d(H / norm);
}

double transferResidual1d(const Eigen::Matrix2d& H, const LineCorrespondence& line) {
  const double denominator = H(1, 0) * line.reference_x + H(1, 1);
  if (denominator == 0.0) return std::numeric_limits<double>::infinity();
  return line.current_x - (H(0, 0) * line.reference_x + H(0, 1)) / denominator;
}

namespace {

// LMedS draws at most this many subsets: a smaller inlier_probability is refused by validate()
// (it would also overflow the count: Pns³ underflows to 0 for Pns < 1e-103 and m = −inf).
constexpr double kMaxSubsets = 1e6;

// m = ⌈log Pf / log(1 − Pns³)⌉ in double (NaN or ±inf for degenerate probabilities).
double subsetCountReal(double failure_probability, double inlier_probability) {
  const double p3 = inlier_probability * inlier_probability * inlier_probability;
  return std::ceil(std::log(failure_probability) / std::log1p(-p3));
}

}  // namespace

void Homography1dOptions::validate() const {
  if (!(failure_probability > 0.0 && failure_probability < 1.0)) {
    throw std::invalid_argument("1D homography: failure_probability must be in (0, 1)");
  }
  if (!(inlier_probability > 0.0 && inlier_probability < 1.0)) {
    throw std::invalid_argument("1D homography: inlier_probability must be in (0, 1)");
  }
  const double subsets = subsetCountReal(failure_probability, inlier_probability);
  if (!(subsets >= 1.0 && subsets <= kMaxSubsets)) {
    throw std::invalid_argument("1D homography: inlier_probability " + std::to_string(inlier_probability) +
                                " with failure_probability " + std::to_string(failure_probability) +
                                " needs more than 1e6 LMedS subsets");
  }
}

int Homography1dOptions::subsetCount() const {
  const double subsets = subsetCountReal(failure_probability, inlier_probability);
  return subsets >= 1.0 ? static_cast<int>(std::min(subsets, kMaxSubsets)) : 1;
}

Expected<Homography1dResult> estimateHomography1dLmeds(const std::vector<LineCorrespondence>& lines,
                                                       const Homography1dOptions& options) {
  options.validate();
  const std::size_t n = lines.size();
  if (n < 3) {
    return Status(StatusCode::kTooFewPoints,
                  "a 1D homography needs at least 3 line matches, got " + std::to_string(n));
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(lines[i].reference_x) || !std::isfinite(lines[i].current_x)) {
      return Status(StatusCode::kInvalidInput, "line match " + std::to_string(i) + " is not finite");
    }
  }
  Homography1dResult result;
  result.subsets = options.subsetCount();
  std::mt19937 rng(options.seed);
  std::uniform_int_distribution<std::size_t> pick(0, n - 1);
  std::vector<double> squared(n);
  double best_median = std::numeric_limits<double>::infinity();
  Eigen::Matrix2d best_H;
  std::vector<LineCorrespondence> subset(3);
  // With n = 3 there is one subset; with few matches all subsets may repeat: harmless.
  for (int k = 0; k < result.subsets; ++k) {
    std::set<std::size_t> chosen;
    while (chosen.size() < 3) chosen.insert(pick(rng));
    int j = 0;
    for (const std::size_t i : chosen) subset[j++] = lines[i];
    const auto H = estimateHomography1dDlt(subset);
    if (!H) continue;
    for (std::size_t i = 0; i < n; ++i) {
      const double r = transferResidual1d(*H, lines[i]);
      squared[i] = r * r;
    }
    std::nth_element(squared.begin(), squared.begin() + static_cast<std::ptrdiff_t>(n / 2), squared.end());
    const double median = squared[n / 2];
    if (median < best_median) {
      best_median = median;
      best_H = *H;
    }
  }
  if (!std::isfinite(best_median)) {
    return Status(StatusCode::kDegenerate, "no subset of 3 line matches gives a 1D homography");
  }
  result.median_squared_residual = best_median;
  const double redundancy = n > 3 ? 1.0 + 5.0 / static_cast<double>(n - 3) : 6.0;
  result.sigma_px = 1.4826 * redundancy * std::sqrt(best_median);
  const double threshold = 3.84 * result.sigma_px * result.sigma_px;
  std::vector<LineCorrespondence> inliers;
  for (std::size_t i = 0; i < n; ++i) {
    const double r = transferResidual1d(best_H, lines[i]);
    // An exact fit (σ̂ = 0) keeps the matches it explains to rounding.
    if (r * r < threshold || r * r <= 1e-18 * (1.0 + lines[i].current_x * lines[i].current_x)) {
      result.inliers.push_back(static_cast<int>(i));
      inliers.push_back(lines[i]);
    }
  }
  if (inliers.size() < 3) {
    return Status(StatusCode::kNoConsensus,
                  "only " + std::to_string(inliers.size()) + " line matches agree on a 1D homography");
  }
  const auto refit = estimateHomography1dDlt(inliers);
  if (!refit) return refit.status();
  result.H = *refit;
  double sum = 0.0;
  for (const auto& line : inliers) sum += std::pow(transferResidual1d(result.H, line), 2);
  result.rms_residual_px = std::sqrt(sum / static_cast<double>(inliers.size()));
  return result;
}

}  // namespace homography_teach_repeat
