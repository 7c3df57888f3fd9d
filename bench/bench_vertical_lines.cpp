// bench_vertical_lines: the per-frame chain of the mu heading correction (paper 002 Table 2:
// 111 ms extraction + 32 ms matching + 18 ms homography on an 850 MHz PIII) on a real photograph
// (Debian's opencv-doc building.jpg, cropped to the aspect ratio) at 640x480 and 768x288, and OpenCV's LineSegmentDetector on
// the same image for comparison.
//   rosrun homography_teach_repeat bench_vertical_lines [--benchmark_format=json]
// The current image is the reference seen after a 3° yaw (warped by K R K⁻¹).
#include <benchmark/benchmark.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <iostream>

#include "homography_teach_repeat/mu/heading_1d.h"
#include "homography_teach_repeat/mu/heading_correction.h"
#include "homography_teach_repeat/mu/homography_1d.h"
#include "homography_teach_repeat/features/vertical_line_matcher.h"
#include "homography_teach_repeat/features/vertical_lines.h"

namespace htr = homography_teach_repeat;

namespace {

struct Frames {
  cv::Mat reference, current;
  htr::LineCamera camera;
};

Frames makeFrames(int width, int height) {
  const std::string path = std::string(HTR_OPENCV_DATA_DIR) + "/building.jpg";
  cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (image.empty()) {
    std::cerr << "bench_vertical_lines: cannot read " << path << " (install opencv-doc)\n";
    std::exit(2);
  }
  Frames frames;
  // Crop to the target aspect ratio (keeping the lower part, as a level robot camera would see
  // the building) so that vertical lines keep their length.
  const double aspect = static_cast<double>(width) / height;
  cv::Rect crop(0, 0, image.cols, image.rows);
  if (image.cols / static_cast<double>(image.rows) < aspect) {
    crop.height = static_cast<int>(image.cols / aspect);
    crop.y = image.rows - crop.height;
  } else {
    crop.width = static_cast<int>(image.rows * aspect);
  }
  cv::resize(image(crop), frames.reference, cv::Size(width, height), 0, 0, cv::INTER_AREA);
  frames.camera = htr::LineCamera{0.8 * width, 0.5 * (width - 1)};
  const double yaw = 3.0 * M_PI / 180.0;
  const cv::Matx33d K(frames.camera.f, 0, frames.camera.x0, 0, frames.camera.f, 0.5 * (height - 1),
                      0, 0, 1);
  const cv::Matx33d R(std::cos(yaw), 0, std::sin(yaw), 0, 1, 0, -std::sin(yaw), 0, std::cos(yaw));
  cv::warpPerspective(frames.reference, frames.current, K * R * K.inv(), frames.reference.size(),
                      cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return frames;
}

void setSizeArgs(benchmark::internal::Benchmark* b) {
  b->Args({640, 480})->Args({768, 288})->Unit(benchmark::kMicrosecond);
}

void BM_VerticalLines_Extract(benchmark::State& state) {
  const Frames f = makeFrames(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  htr::VerticalLineExtractor extractor;
  std::size_t count = 0;
  for (auto _ : state) count = extractor.extract(f.current)->size();
  state.counters["lines"] = static_cast<double>(count);
}
BENCHMARK(BM_VerticalLines_Extract)->Apply(setSizeArgs);

void BM_OpenCV_LineSegmentDetector(benchmark::State& state) {
  const Frames f = makeFrames(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  cv::Ptr<cv::LineSegmentDetector> lsd = cv::createLineSegmentDetector();
  std::vector<cv::Vec4f> segments;
  for (auto _ : state) lsd->detect(f.current, segments);
  state.counters["segments"] = static_cast<double>(segments.size());
}
BENCHMARK(BM_OpenCV_LineSegmentDetector)->Apply(setSizeArgs);

void BM_VerticalLines_Match(benchmark::State& state) {
  const Frames f = makeFrames(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  htr::VerticalLineExtractor extractor;
  const auto reference = *extractor.extract(f.reference);
  const auto current = *extractor.extract(f.current);
  std::size_t count = 0;
  for (auto _ : state) count = htr::matchVerticalLines(reference, current)->size();
  state.counters["matches"] = static_cast<double>(count);
}
BENCHMARK(BM_VerticalLines_Match)->Apply(setSizeArgs);

std::vector<htr::LineCorrespondence> correspondences(const std::vector<htr::VerticalLine>& a,
                                                     const std::vector<htr::VerticalLine>& b,
                                                     const std::vector<htr::LineMatch>& matches) {
  std::vector<htr::LineCorrespondence> out;
  for (const auto& m : matches) out.push_back({a[m.reference].x, b[m.current].x});
  return out;
}

void BM_VerticalLines_RobustHomography1d(benchmark::State& state) {
  const Frames f = makeFrames(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  htr::VerticalLineExtractor extractor;
  const auto reference = *extractor.extract(f.reference);
  const auto current = *extractor.extract(f.current);
  const auto lines = correspondences(reference, current, *htr::matchVerticalLines(reference, current));
  for (auto _ : state) benchmark::DoNotOptimize(htr::estimateHomography1dLmeds(lines));
  state.counters["line_matches"] = static_cast<double>(lines.size());
}
BENCHMARK(BM_VerticalLines_RobustHomography1d)->Apply(setSizeArgs);

// What the repeat node does per frame in mu mode (reference lines precomputed at teach time).
void BM_VerticalLines_WholeChain(benchmark::State& state) {
  const Frames f = makeFrames(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  htr::VerticalLineExtractor extractor;
  const auto reference = *extractor.extract(f.reference);
  const htr::HeadingCorrector corrector(htr::HeadingCorrectionOptions(), f.camera);
  double theta = std::nan("");
  for (auto _ : state) {
    const auto current = extractor.extract(f.current);
    const auto correction = corrector.estimate(reference, *current);
    if (correction) theta = correction->theta;
  }
  state.counters["theta_deg"] = theta * 180.0 / M_PI;  // true yaw: 3°
}
// Repetitions give the median the speed target refers to.
BENCHMARK(BM_VerticalLines_WholeChain)->Apply(setSizeArgs)->Repetitions(5)->ReportAggregatesOnly(true);

}  // namespace

// main: bench_main.cpp
