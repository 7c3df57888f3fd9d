// bench_shift_heading: the seasonal heading fix (mu/shift_heading.h) per frame on a real photograph
// (Debian's opencv-doc building.jpg) at 640x480: describing the current view (upright AKAZE and
// BRIEF, each alone and both) and measuring it against a reference described beforehand (what the
// repeat does per frame: the keyframe's features are stored). The current view is the reference
// after a 3° yaw (warped by K R K⁻¹, f = 0.8 width); the counter `mu_px` is the measured shift
// (true: f tan 3° = 26.8 px at the principal point).
//   rosrun homography_teach_repeat bench_shift_heading [--benchmark_format=json]
#include <benchmark/benchmark.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <iostream>

#include "homography_teach_repeat/mu/shift_heading.h"

namespace htr = homography_teach_repeat;

namespace {

struct Frames {
  cv::Mat reference, current;
  double cx = 0.0, f = 0.0;
};

Frames makeFrames() {
  const std::string path = std::string(HTR_OPENCV_DATA_DIR) + "/building.jpg";
  cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (image.empty()) {
    std::cerr << "bench_shift_heading: cannot read " << path << " (install opencv-doc)\n";
    std::exit(2);
  }
  Frames frames;
  const int width = 640, height = 480;
  cv::Rect crop(0, 0, image.cols, image.rows);  // the lower part at 4:3
  if (image.cols * 3 < image.rows * 4) {
    crop.height = image.cols * 3 / 4;
    crop.y = image.rows - crop.height;
  } else {
    crop.width = image.rows * 4 / 3;
  }
  cv::resize(image(crop), frames.reference, cv::Size(width, height), 0, 0, cv::INTER_AREA);
  const double f = 0.8 * width;
  frames.f = f;
  frames.cx = 0.5 * (width - 1);
  const double yaw = 3.0 * M_PI / 180.0;
  const cv::Matx33d K(f, 0, frames.cx, 0, f, 0.5 * (height - 1), 0, 0, 1);
  const cv::Matx33d R(std::cos(yaw), 0, std::sin(yaw), 0, 1, 0, -std::sin(yaw), 0, std::cos(yaw));
  cv::warpPerspective(frames.reference, frames.current, K * R * K.inv(), frames.reference.size(), cv::INTER_LINEAR,
                      cv::BORDER_REPLICATE);
  return frames;
}

htr::ShiftHeadingOptions optionsOf(int which) {
  htr::ShiftHeadingOptions options;  // 0: both (the default)
  if (which == 1) options.features = {options.features[0]};  // upright AKAZE
  if (which == 2) options.features = {options.features[1]};  // BRIEF
  return options;
}

// Describing one view: 0 both, 1 upright AKAZE, 2 BRIEF.
void BM_ShiftHeading_Describe(benchmark::State& state) {
  const Frames f = makeFrames();
  htr::ShiftHeading heading(optionsOf(static_cast<int>(state.range(0))));
  std::size_t features = 0;
  for (auto _ : state) {
    const auto described = heading.describe(f.current);
    features = 0;
    for (const auto& set : described->sets) features += set.keypoints.size();
  }
  state.counters["features"] = static_cast<double>(features);
}
BENCHMARK(BM_ShiftHeading_Describe)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

// Per frame in the repeat: describe the current view, match, vote (the reference described once).
void BM_ShiftHeading_PerFrame(benchmark::State& state) {
  const Frames f = makeFrames();
  htr::ShiftHeading heading(optionsOf(static_cast<int>(state.range(0))));
  const auto reference = heading.describe(f.reference);
  double mu = std::nan("");
  for (auto _ : state) {
    const auto fix = heading.measure(*reference, *heading.describe(f.current), f.cx, f.f);
    if (fix) mu = fix->mu;
  }
  state.counters["mu_px"] = mu;
}
BENCHMARK(BM_ShiftHeading_PerFrame)
    ->Arg(0)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);

}  // namespace

// main: bench_main.cpp
