// bench_fast_hd: Fast-HD against the decompositions it replaces (paper 000 Fig. 3), and the whole
// per-frame estimate versus the number of matches.
//   rosrun homography_teach_repeat bench_fast_hd [--benchmark_format=json]
// Compare within one run (ratios): machines here are noisy.
#include <benchmark/benchmark.h>
#include <opencv2/calib3d.hpp>

#include <random>

#include "homography_teach_repeat/fast_hd/fast_hd.h"
#include "homography_teach_repeat/fast_hd/fast_hd_covariance.h"
#include "homography_teach_repeat/homography/homography.h"
#include "homography_teach_repeat/homography/homography_decomposition.h"
#include "homography_teach_repeat/fast_hd/planar_pose_estimator.h"
#include "homography_teach_repeat/eval/synthetic_plane_scene.h"

namespace htr = homography_teach_repeat;

namespace {

htr::PinholeCamera camera() {
  htr::CameraCalibration c;
  c.width = 640;
  c.height = 480;
  c.fx = c.fy = 520.0;
  c.cx = 318.0;
  c.cy = 243.0;
  return htr::PinholeCamera(c);
}

// Scene A of docs/math.md §3.5 with 0.5 px noise.
struct Scene {
  htr::ScenePlane plane;
  htr::PlanarPose pose{0.6, -1.4, -0.25};
  htr::PointMatches matches;
  Eigen::Matrix3d H;
  std::vector<Eigen::Vector2d> reference_pixels;

  explicit Scene(int n) {
    plane.normal = Eigen::Vector3d(std::sin(0.35), std::cos(0.35) * std::sin(0.2),
                                   std::cos(0.35) * std::cos(0.2));
    plane.distance = 5.0;
    std::mt19937_64 rng(7);
    matches = htr::sampleVisiblePlaneMatches(camera(), plane, pose, n, &rng);
    std::normal_distribution<double> noise(0.0, 0.5);
    for (auto& m : matches) {
      m.reference += Eigen::Vector2d(noise(rng), noise(rng));
      m.current += Eigen::Vector2d(noise(rng), noise(rng));
      reference_pixels.push_back(m.reference);
    }
    H = *htr::estimateHomographyDlt(matches);
  }
};

void BM_FastHD_Solve(benchmark::State& state) {
  const Scene scene(100);
  const htr::PinholeCamera cam = camera();
  for (auto _ : state) benchmark::DoNotOptimize(htr::solveFastHd(scene.H, cam, scene.plane));
}
BENCHMARK(BM_FastHD_Solve);

void BM_OpenCV_DecomposeHomographyMat(benchmark::State& state) {
  const Scene scene(100);
  cv::Matx33d H, K;
  const Eigen::Matrix3d k = camera().K();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      H(r, c) = scene.H(r, c);
      K(r, c) = k(r, c);
    }
  }
  std::vector<cv::Mat> rotations, translations, normals;
  for (auto _ : state) {
    benchmark::DoNotOptimize(cv::decomposeHomographyMat(H, K, rotations, translations, normals));
  }
}
BENCHMARK(BM_OpenCV_DecomposeHomographyMat);

// Classic-HD as a pose estimator: decomposition plus the positive-depth filter on the matches.
void BM_ClassicHD_DecomposeAndVisibilityFilter(benchmark::State& state) {
  const Scene scene(static_cast<int>(state.range(0)));
  const htr::PinholeCamera cam = camera();
  for (auto _ : state) {
    const auto all = htr::decomposeHomographyClassic(scene.H, cam);
    benchmark::DoNotOptimize(htr::filterByPositiveDepth(*all, cam, scene.reference_pixels));
  }
}
BENCHMARK(BM_ClassicHD_DecomposeAndVisibilityFilter)->Arg(100);

void BM_PlanarHD(benchmark::State& state) {
  const Scene scene(100);
  const htr::PinholeCamera cam = camera();
  for (auto _ : state) {
    benchmark::DoNotOptimize(htr::decomposeHomographyPlanar(scene.H, cam, scene.reference_pixels));
  }
}
BENCHMARK(BM_PlanarHD);

// Fast-HD solve + covariance (docs/math.md §3.4) given the DLT of the matches.
void BM_FastHD_SolveAndCovariance(benchmark::State& state) {
  const Scene scene(static_cast<int>(state.range(0)));
  const htr::PinholeCamera cam = camera();
  const auto dlt = htr::solveNormalizedDlt(scene.matches);
  for (auto _ : state) {
    benchmark::DoNotOptimize(htr::solveFastHd(dlt->H_unscaled, cam, scene.plane));
    benchmark::DoNotOptimize(htr::fastHdCovariance(*dlt, scene.matches, cam, scene.plane, 0.5));
  }
}
BENCHMARK(BM_FastHD_SolveAndCovariance)->Arg(10)->Arg(50)->Arg(100)->Arg(200)->Arg(500)
    ->Unit(benchmark::kMicrosecond);

// The whole estimate from matches: normalised DLT + Fast-HD (paper 000 Fig. 3).
void BM_FastHD_DltAndSolve(benchmark::State& state) {
  const Scene scene(static_cast<int>(state.range(0)));
  const htr::PinholeCamera cam = camera();
  for (auto _ : state) {
    const auto dlt = htr::solveNormalizedDlt(scene.matches);
    benchmark::DoNotOptimize(htr::solveFastHd(dlt->H_unscaled, cam, scene.plane));
  }
}
BENCHMARK(BM_FastHD_DltAndSolve)->Arg(10)->Arg(50)->Arg(100)->Arg(200)->Arg(500)
    ->Unit(benchmark::kMicrosecond);

// DLT + Fast-HD + covariance: what the repeat node needs per frame on the inliers.
void BM_FastHD_DltSolveAndCovariance(benchmark::State& state) {
  const Scene scene(static_cast<int>(state.range(0)));
  const htr::PinholeCamera cam = camera();
  for (auto _ : state) {
    const auto dlt = htr::solveNormalizedDlt(scene.matches);
    benchmark::DoNotOptimize(htr::solveFastHd(dlt->H_unscaled, cam, scene.plane));
    benchmark::DoNotOptimize(htr::fastHdCovariance(*dlt, scene.matches, cam, scene.plane, 0.5));
  }
}
BENCHMARK(BM_FastHD_DltSolveAndCovariance)->Arg(10)->Arg(50)->Arg(100)->Arg(200)->Arg(500)
    ->Unit(benchmark::kMicrosecond);

// The full inlier pipeline with the 3-DoF refinement (estimatePlanarPoseFromInliers).
void BM_FastHD_FullWithRefinement(benchmark::State& state) {
  const Scene scene(static_cast<int>(state.range(0)));
  const htr::PinholeCamera cam = camera();
  htr::PlanarPoseEstimatorOptions options;
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        htr::estimatePlanarPoseFromInliers(scene.matches, cam, scene.plane, options));
  }
}
BENCHMARK(BM_FastHD_FullWithRefinement)->Arg(10)->Arg(100)->Arg(500)->Unit(benchmark::kMicrosecond);

}  // namespace

// main: bench_main.cpp
