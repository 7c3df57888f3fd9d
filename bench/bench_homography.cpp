// bench_homography: normalised DLT and robust estimation versus the number of matches.
//   rosrun homography_teach_repeat bench_homography [--benchmark_format=json]
#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>

#include <random>

#include "homography_teach_repeat/homography/homography.h"
#include "homography_teach_repeat/homography/robust_homography.h"

namespace htr = homography_teach_repeat;

namespace {

// Matches of a random plane homography on a 640x480 image, 0.5 px noise, `outlier_fraction`
// replaced by random points.
htr::PointMatches makeMatches(int n, double outlier_fraction) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(0.0, 640.0), v(0.0, 480.0);
  std::normal_distribution<double> noise(0.0, 0.5);
  Eigen::Matrix3d H;
  H << 0.9, -0.05, 30.0, 0.04, 1.02, -12.0, 1e-4, -5e-5, 1.0;
  htr::PointMatches matches;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d p(u(rng), v(rng));
    Eigen::Vector2d q = htr::applyHomography(H, p) + Eigen::Vector2d(noise(rng), noise(rng));
    if (i < static_cast<int>(outlier_fraction * n)) q = Eigen::Vector2d(u(rng), v(rng));
    matches.push_back({p, q});
  }
  return matches;
}

void BM_NormalizedDlt(benchmark::State& state) {
  const auto matches = makeMatches(static_cast<int>(state.range(0)), 0.0);
  for (auto _ : state) benchmark::DoNotOptimize(htr::estimateHomographyDlt(matches));
}
BENCHMARK(BM_NormalizedDlt)->Arg(10)->Arg(50)->Arg(100)->Arg(200)->Arg(500)->Unit(benchmark::kMicrosecond);

void BM_RobustDefault30PercentOutliers(benchmark::State& state) {
  const auto matches = makeMatches(static_cast<int>(state.range(0)), 0.3);
  htr::RobustHomographyOptions options;
  for (auto _ : state) {
    cv::setRNGSeed(1);
    benchmark::DoNotOptimize(htr::estimateHomographyRobust(matches, options));
  }
}
BENCHMARK(BM_RobustDefault30PercentOutliers)->Arg(100)->Arg(500)->Unit(benchmark::kMicrosecond);

// The same without the selector's second run at the measured scale (docs/design.md, "The robust
// homography"): what that run costs, as a ratio to the default in one run.
void BM_RobustSingleScale30PercentOutliers(benchmark::State& state) {
  const auto matches = makeMatches(static_cast<int>(state.range(0)), 0.3);
  htr::RobustHomographyOptions options;
  options.reselect_at_measured_scale = false;
  for (auto _ : state) {
    cv::setRNGSeed(1);
    benchmark::DoNotOptimize(htr::estimateHomographyRobust(matches, options));
  }
}
BENCHMARK(BM_RobustSingleScale30PercentOutliers)->Arg(100)->Arg(500)->Unit(benchmark::kMicrosecond);

}  // namespace

// main: bench_main.cpp
