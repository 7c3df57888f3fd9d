// bench_trifocal: the 1D trifocal tensor estimators (minimal TT7 / TT5 / TT4 solves), the
// closed-form motion, and RANSAC on 50 triplets with 40 % wrong matches (paper 003 §IV).
//   rosrun homography_teach_repeat bench_trifocal [--benchmark_format=json]
// Compare within one run (ratios): machines here are noisy.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <random>

#include "homography_teach_repeat/eval/synthetic_bearing_scene.h"
#include "homography_teach_repeat/trifocal/trifocal_motion.h"
#include "homography_teach_repeat/trifocal/trifocal_ransac.h"
#include "homography_teach_repeat/trifocal/trifocal_tensor_1d.h"

namespace htr = homography_teach_repeat;

namespace {

// MovB, 0.5 px noise: 20 triplets on a wall 20 units ahead, 30 elsewhere.
struct Scene {
  std::vector<htr::BearingTriplet> plane, off, all;
  Scene() {
    std::mt19937 rng(7);
    const htr::LineCamera1d camera;
    htr::BearingSceneOptions options;
    options.noise_px = 0.5;
    plane = htr::planeBearingScene(htr::movementB(), camera, 20, 20.0, options, rng).triplets;
    off = htr::randomBearingScene(htr::movementB(), camera, 30, options, rng).triplets;
    all = off;
  }
};

const Scene& scene() {
  static const Scene s;
  return s;
}

std::vector<htr::BearingTriplet> first(const std::vector<htr::BearingTriplet>& t, std::size_t n) {
  return std::vector<htr::BearingTriplet>(t.begin(), t.begin() + static_cast<std::ptrdiff_t>(n));
}

void BM_TT7Minimal(benchmark::State& state) {
  const auto triplets = first(scene().off, 7);
  for (auto _ : state) benchmark::DoNotOptimize(htr::estimateTT7(triplets));
}
BENCHMARK(BM_TT7Minimal);

void BM_TT5Minimal(benchmark::State& state) {
  const auto triplets = first(scene().off, 5);
  for (auto _ : state) benchmark::DoNotOptimize(htr::estimateTT5(triplets));
}
BENCHMARK(BM_TT5Minimal);

void BM_TT4Minimal(benchmark::State& state) {
  const auto plane = first(scene().plane, 3);
  const auto off = first(scene().off, 1);
  for (auto _ : state) benchmark::DoNotOptimize(htr::estimateTT4(plane, off));
}
BENCHMARK(BM_TT4Minimal);

void BM_MotionFromTensor(benchmark::State& state) {
  const auto T = htr::estimateTT5(scene().off);
  for (auto _ : state) benchmark::DoNotOptimize(htr::motionCandidates(*T, scene().off));
}
BENCHMARK(BM_MotionFromTensor);

// 50 triplets, 40 % wrong matches (the acceptance figure: TT5 median under 0.5 ms).
void BM_Ransac(benchmark::State& state) {
  const auto method = static_cast<htr::TrifocalMethod>(state.range(0));
  std::mt19937 rng(11);
  const htr::LineCamera1d camera;
  std::vector<htr::BearingTriplet> triplets;
  if (method == htr::TrifocalMethod::kTT4) {
    triplets = scene().plane;  // 20 on the wall, 10 off, 20 wrong
    triplets.insert(triplets.end(), scene().off.begin(), scene().off.begin() + 30);
    std::vector<htr::BearingTriplet> tail(triplets.begin() + 30, triplets.end());
    htr::corruptTriplets(tail, 1.0, camera, rng);
    std::copy(tail.begin(), tail.end(), triplets.begin() + 30);
  } else {
    triplets = scene().plane;
    triplets.insert(triplets.end(), scene().off.begin(), scene().off.end());
    htr::corruptTriplets(triplets, 0.4, camera, rng);
  }
  htr::TrifocalRansacOptions options;
  options.method = method;
  int iterations = 0, runs = 0;
  for (auto _ : state) {
    options.seed = static_cast<unsigned>(++runs);
    const auto result = htr::estimateTrifocalRansac(triplets, options);
    if (result) iterations += result->iterations;
    benchmark::DoNotOptimize(result);
  }
  state.counters["iterations"] = benchmark::Counter(iterations, benchmark::Counter::kAvgIterations);
  state.SetLabel(htr::toString(method));
}
BENCHMARK(BM_Ransac)
    ->Arg(static_cast<int>(htr::TrifocalMethod::kTT7))
    ->Arg(static_cast<int>(htr::TrifocalMethod::kTT5))
    ->Arg(static_cast<int>(htr::TrifocalMethod::kTT4))
    ->Unit(benchmark::kMicrosecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);

}  // namespace

// main: bench_main.cpp
