// bench_repeat_localizer: per-frame latency of the repeat phase (image in -> pose out, the core
// part of repeat_node: feature extraction, matching, robust homography, Fast-HD, covariance,
// refinement) at 640x480 for each feature type, on the synthetic taught route of the tests.
//   rosrun homography_teach_repeat bench_repeat_localizer [--benchmark_format=json]
// Counters: pos_err_mm / yaw_err_mdeg of the benchmarked frame against its ground truth.
// BM_RepeatLocalize detects features in every frame; BM_RepeatLocalizeTracked is a frame that
// follows a detected one by optical flow (RepeatOptions::max_tracked_frames).
#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <memory>

#include "support/synthetic_route.h"
#include <opencv2/features2d.hpp>

#include "homography_teach_repeat/features/feature_matcher.h"
#include "homography_teach_repeat/teach_repeat/repeat_localizer.h"

namespace htr = homography_teach_repeat;

namespace {

struct Fixture {
  htr::test_support::SyntheticWall wall;
  std::map<htr::FeatureType, std::string> routes;
  ~Fixture() {
    for (const auto& [type, dir] : routes) std::filesystem::remove_all(dir);
  }
  const std::string& route(htr::FeatureType type) {
    auto it = routes.find(type);
    if (it == routes.end()) {
      it = routes.emplace(type, htr::test_support::teachSyntheticRoute(wall, type)).first;
    }
    return it->second;
  }
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

void BM_RepeatLocalize(benchmark::State& state, htr::FeatureType type, htr::RepeatMode mode) {
  const auto route = htr::loadRoute(fixture().route(type));
  if (!route) {
    state.SkipWithError(route.status().toString().c_str());
    return;
  }
  htr::RepeatOptions options;
  options.mode = mode;
  options.max_tracked_frames = 0;  // every frame detected
  auto localizer = htr::RepeatLocalizer::create(*route, options);
  if (!localizer) {
    state.SkipWithError(localizer.status().toString().c_str());
    return;
  }
  // A frame 6 cm beside the taught path, turned 2°, between keyframes 2 and 3.
  const htr::PlanarPose camera_pose(0.08 * 0.65 + 0.06, 0.65, 0.04 * 0.65 + 0.035);
  const cv::Mat image = fixture().wall.imageAt(camera_pose);
  const htr::Pose2D truth = htr::cameraAxesToRep103(camera_pose);
  htr::RepeatEstimate last;
  for (auto _ : state) {
    localizer->setTrackedKeyframe(2);
    const auto estimate = localizer->localize(image);
    if (!estimate) {
      state.SkipWithError(estimate.status().toString().c_str());
      return;
    }
    last = *estimate;
  }
  if (last.has_pose) {
    state.counters["pos_err_mm"] =
        1000.0 * std::hypot(last.base_pose.x - truth.x, last.base_pose.y - truth.y);
    state.counters["yaw_err_mdeg"] =
        1000.0 * std::abs(htr::wrapToPi(last.base_pose.yaw - truth.yaw)) * 180.0 / M_PI;
  } else {
    state.counters["heading_err_mdeg"] =
        1000.0 * std::abs(htr::wrapToPi(last.heading_correction - (truth.yaw - route->keyframes[2].pose.yaw))) *
        180.0 / M_PI;
  }
  state.counters["inliers"] = last.inliers;
}

BENCHMARK_CAPTURE(BM_RepeatLocalize, FastHD_ORB, htr::FeatureType::kOrb, htr::RepeatMode::kFastHd)
    ->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);
BENCHMARK_CAPTURE(BM_RepeatLocalize, FastHD_AKAZE, htr::FeatureType::kAkaze, htr::RepeatMode::kFastHd)
    ->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);
BENCHMARK_CAPTURE(BM_RepeatLocalize, FastHD_SIFT, htr::FeatureType::kSift, htr::RepeatMode::kFastHd)
    ->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);
BENCHMARK_CAPTURE(BM_RepeatLocalize, Mu_lines, htr::FeatureType::kOrb, htr::RepeatMode::kMu)
    ->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);

// A tracked frame (RepeatOptions::max_tracked_frames): the frame after a detected one, 1 cm on,
// takes the detected frame's inliers on by optical flow instead of detecting features.
void BM_RepeatLocalizeTracked(benchmark::State& state, htr::FeatureType type) {
  const auto route = htr::loadRoute(fixture().route(type));
  if (!route) {
    state.SkipWithError(route.status().toString().c_str());
    return;
  }
  auto localizer = htr::RepeatLocalizer::create(*route, htr::RepeatOptions());
  if (!localizer) {
    state.SkipWithError(localizer.status().toString().c_str());
    return;
  }
  const htr::PlanarPose detected_pose(0.08 * 0.64 + 0.06, 0.64, 0.04 * 0.64 + 0.035);
  const htr::PlanarPose camera_pose(0.08 * 0.65 + 0.06, 0.65, 0.04 * 0.65 + 0.035);
  const cv::Mat detected = fixture().wall.imageAt(detected_pose);
  const cv::Mat image = fixture().wall.imageAt(camera_pose);
  const htr::Pose2D truth = htr::cameraAxesToRep103(camera_pose);
  htr::RepeatEstimate last;
  for (auto _ : state) {
    state.PauseTiming();
    localizer->setTrackedKeyframe(2);
    const auto first = localizer->localize(detected);
    state.ResumeTiming();
    const auto estimate = localizer->localize(image);
    if (!first || !estimate || !estimate->tracked) {
      state.SkipWithError(!estimate ? estimate.status().toString().c_str() : "the frame was not tracked");
      return;
    }
    last = *estimate;
  }
  state.counters["pos_err_mm"] = 1000.0 * std::hypot(last.base_pose.x - truth.x, last.base_pose.y - truth.y);
  state.counters["yaw_err_mdeg"] = 1000.0 * std::abs(htr::wrapToPi(last.base_pose.yaw - truth.yaw)) * 180.0 / M_PI;
  state.counters["inliers"] = last.inliers;
}
BENCHMARK_CAPTURE(BM_RepeatLocalizeTracked, FastHD_SIFT, htr::FeatureType::kSift)
    ->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);
BENCHMARK_CAPTURE(BM_RepeatLocalizeTracked, FastHD_ORB, htr::FeatureType::kOrb)
    ->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);

// The matching step alone, up to 1500 x 1500 features on two frames of the synthetic wall: ours
// (one distance matrix: popcount for ORB, cv::batchDistance rows for SIFT; ratio test + mutual
// check) against OpenCV's brute force doing the same (knnMatch k=2 forward + match backward).
struct FeaturePair {
  htr::ImageFeatures reference, current;
  explicit FeaturePair(htr::FeatureType type) {
    htr::FeatureOptions options;
    options.type = type;
    options.max_features = 1500;
    htr::FeatureExtractor extractor(options);
    reference = *extractor.extract(fixture().wall.imageAt(htr::PlanarPose(0.0, 0.5, 0.02)));
    current = *extractor.extract(fixture().wall.imageAt(htr::PlanarPose(0.1, 0.65, 0.06)));
  }
};

const FeaturePair& featurePair(htr::FeatureType type) {
  static const FeaturePair orb(htr::FeatureType::kOrb), sift(htr::FeatureType::kSift);
  return type == htr::FeatureType::kOrb ? orb : sift;
}

void BM_Match1500_Ours(benchmark::State& state, htr::FeatureType type) {
  const FeaturePair& pair = featurePair(type);
  for (auto _ : state) {
    benchmark::DoNotOptimize(htr::matchFeatures(pair.reference, pair.current, htr::MatchOptions()));
  }
  state.counters["features"] = static_cast<double>(pair.reference.keypoints.size());
}
BENCHMARK_CAPTURE(BM_Match1500_Ours, Orb, htr::FeatureType::kOrb)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Match1500_Ours, Sift, htr::FeatureType::kSift)->Unit(benchmark::kMillisecond);

void BM_Match1500_OpenCvBruteForce(benchmark::State& state, htr::FeatureType type) {
  const FeaturePair& pair = featurePair(type);
  cv::BFMatcher matcher(type == htr::FeatureType::kOrb ? cv::NORM_HAMMING : cv::NORM_L2);
  for (auto _ : state) {
    std::vector<std::vector<cv::DMatch>> forward;
    std::vector<cv::DMatch> backward;
    matcher.knnMatch(pair.reference.descriptors, pair.current.descriptors, forward, 2);
    matcher.match(pair.current.descriptors, pair.reference.descriptors, backward);
    benchmark::DoNotOptimize(forward.data());
    benchmark::DoNotOptimize(backward.data());
  }
}
BENCHMARK_CAPTURE(BM_Match1500_OpenCvBruteForce, Orb, htr::FeatureType::kOrb)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Match1500_OpenCvBruteForce, Sift, htr::FeatureType::kSift)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
