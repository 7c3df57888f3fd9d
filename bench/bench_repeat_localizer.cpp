// bench_repeat_localizer: per-frame latency of the repeat phase (image in -> pose out, the core
// part of repeat_node: feature extraction, matching, robust homography, Fast-HD, covariance,
// refinement) at 640x480 for each feature type, on the synthetic taught route of the tests.
//   rosrun homography_teach_repeat bench_repeat_localizer [--benchmark_format=json]
// Counters: pos_err_mm / yaw_err_mdeg of the benchmarked frame against its ground truth.
// BM_RepeatLocalize detects features in every frame; BM_RepeatLocalizeTracked is a frame that
// follows a detected one by optical flow (RepeatOptions::max_tracked_frames). BM_RepeatFrames is
// the whole frame of the default mode (RepeatPipeline, hybrid: Fast-HD with tracking, μ, the filter,
// the seasonal heading fix where nothing else fixes) over a drive of 40 frames 2.5 cm apart: counters
// median_ms, p95_ms and max_ms of the frames. Its _camera cases hand the frames over at 30 Hz, as a
// camera does to a node that takes the newest image (the time between frames is the worker's for
// RepeatOptions::background_detection; without pacing the worker has only the other frames' time);
// _no_background detects in the frame that needs the features. BM_RepeatStart is the pipeline's
// creation with the route's stored plane uncertainty and with it measured at load.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <thread>
#include <vector>

#include "support/synthetic_route.h"
#include <opencv2/features2d.hpp>

#include "homography_teach_repeat/features/feature_matcher.h"
#include "homography_teach_repeat/teach_repeat/repeat_localizer.h"
#include "homography_teach_repeat/teach_repeat/repeat_pipeline.h"

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
  state.counters["extraction_ms"] = localizer->lastTiming().extraction_ms;
  state.counters["references_ms"] = localizer->lastTiming().references_ms;
  state.counters["references_tried"] = localizer->lastTiming().references_tried;
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

// The default mode's whole frame (RepeatPipeline, hybrid, the node's defaults where they differ
// from the options' own: max_tracked_frames 2, SIFT routes) over 40 frames 2.5 cm apart at 30 Hz
// (0.75 m/s), 4 cm beside the taught path with exact odometry; each benchmark iteration is one
// frame, timed on its own. `seasonal`: the taught views match nothing any more (Fast-HD's and μ's
// consensus thresholds out of reach), so the frame runs Fast-HD detection and μ without a fix, and
// the seasonal heading fix once per shift_heading_period.
void BM_RepeatFrames(benchmark::State& state, bool seasonal, bool camera_rate, bool background) {
  const auto route = htr::loadRoute(fixture().route(htr::FeatureType::kSift));
  if (!route) {
    state.SkipWithError(route.status().toString().c_str());
    return;
  }
  htr::RepeatPipelineOptions options;
  options.localization.mode = htr::RepeatMode::kHybrid;
  options.localization.background_detection = background;
  if (seasonal) {
    options.localization.min_inliers = 100000;
    options.localization.heading.min_inliers = 100000;
  }
  auto pipeline = htr::RepeatPipeline::create(*route, options);
  if (!pipeline) {
    state.SkipWithError(pipeline.status().toString().c_str());
    return;
  }
  pipeline->warmUp();  // as repeat_node at start-up
  constexpr int kFrames = 40;
  std::vector<cv::Mat> images;
  std::vector<htr::Pose2D> odometry;
  for (int i = 0; i < kFrames; ++i) {
    const double s = 0.1 + 0.025 * i;
    const htr::PlanarPose camera_pose(0.08 * s + 0.04, s, 0.04 * s);
    images.push_back(fixture().wall.imageAt(camera_pose));
    odometry.push_back(htr::cameraAxesToRep103(camera_pose));
  }
  const htr::PinholeCamera camera(htr::test_support::syntheticCalibration());
  std::vector<double> frame_ms;
  int frame = 0, poses = 0, shift_fixes = 0, background_frames = 0;
  // A camera at 30 Hz and a node that always takes the newest image: a frame starts 1/30 s after
  // the previous one started, or as soon as that one is done when it took longer (the images in
  // between would have been dropped).
  auto next_frame = std::chrono::steady_clock::now();
  for (auto _ : state) {
    const double stamp = 100.0 + frame / 30.0;
    if (camera_rate) {
      std::this_thread::sleep_until(next_frame);
      next_frame = std::chrono::steady_clock::now() + std::chrono::microseconds(33333);
    }
    if (!pipeline->addOdometry(stamp, odometry[static_cast<std::size_t>(frame)]).isOk()) {
      state.SkipWithError("odometry refused");
      return;
    }
    const auto start = std::chrono::steady_clock::now();
    const htr::RepeatFrameResult result = pipeline->processFrame(stamp, images[static_cast<std::size_t>(frame)], camera);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    state.SetIterationTime(seconds);
    frame_ms.push_back(1000.0 * seconds);
    poses += result.pose ? 1 : 0;
    shift_fixes += result.fixes == "shift" ? 1 : 0;
    background_frames += result.timing && result.timing->background ? 1 : 0;
    ++frame;
  }
  std::sort(frame_ms.begin(), frame_ms.end());
  const auto at = [&](double q) { return frame_ms[static_cast<std::size_t>(std::lround(q * (frame_ms.size() - 1)))]; };
  state.counters["median_ms"] = at(0.5);
  state.counters["p95_ms"] = at(0.95);
  state.counters["max_ms"] = frame_ms.back();
  state.counters["frames_with_pose"] = poses;
  state.counters["shift_fixes"] = shift_fixes;
  state.counters["background_frames"] = background_frames;
}
BENCHMARK_CAPTURE(BM_RepeatFrames, Hybrid_SIFT_camera, false, true, true)
    ->UseManualTime()->Iterations(40)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_RepeatFrames, Hybrid_SIFT_camera_no_background, false, true, false)
    ->UseManualTime()->Iterations(40)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_RepeatFrames, Hybrid_SIFT, false, false, true)
    ->UseManualTime()->Iterations(40)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_RepeatFrames, Hybrid_SIFT_seasonal_camera, true, true, true)
    ->UseManualTime()->Iterations(40)->Unit(benchmark::kMillisecond);

// The repeat's start: RepeatPipeline::create at the defaults (hybrid) on the synthetic SIFT route
// (16 keyframes), reading each plane's uncertainty as the teach run stored it (format 5), or
// measuring it at load as for a route of format 4 (the neighbours' planes compared and their images
// relocalized against each keyframe; docs/route_format.md, "Measured noise").
void BM_RepeatStart(benchmark::State& state, bool stored) {
  auto route = htr::loadRoute(fixture().route(htr::FeatureType::kSift));
  if (!route || !htr::planeUncertaintyStored(*route)) {
    state.SkipWithError(route ? "the synthetic route stores no plane uncertainty" : route.status().toString().c_str());
    return;
  }
  if (!stored) {
    for (htr::RouteKeyframe& keyframe : route->keyframes) keyframe.plane_uncertainty.reset();
  }
  for (auto _ : state) {
    auto pipeline = htr::RepeatPipeline::create(*route, htr::RepeatPipelineOptions());
    if (!pipeline) {
      state.SkipWithError(pipeline.status().toString().c_str());
      return;
    }
    benchmark::DoNotOptimize(pipeline);
  }
}
BENCHMARK_CAPTURE(BM_RepeatStart, stored, true)->Unit(benchmark::kMillisecond)->Repetitions(3)->ReportAggregatesOnly(true);
BENCHMARK_CAPTURE(BM_RepeatStart, measured_at_load, false)
    ->Unit(benchmark::kMillisecond)->Repetitions(3)->ReportAggregatesOnly(true);

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

// main: bench_main.cpp
