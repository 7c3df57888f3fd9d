// libFuzzer target: the vertical line extractor on arbitrary images (size, pixel type, contents),
// with or without a camera (right or wrong size, with distortion) and arbitrary valid options.
// Lines must come out finite and inside the image; bad images give a status.
#include <opencv2/core.hpp>

#include "fuzz_support.h"
#include "homography_teach_repeat/features/vertical_lines.h"

namespace htr = homography_teach_repeat;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  const int rows = in.ConsumeIntegralInRange<int>(0, 200), cols = in.ConsumeIntegralInRange<int>(0, 200);
  static const int kTypes[] = {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1, CV_32FC1, CV_8SC1};
  const int type = kTypes[in.ConsumeIntegralInRange<int>(0, 5)];
  htr::VerticalLineOptions options;
  if (in.ConsumeBool()) {
    options.max_angle_deg = htr_fuzz::anyDouble(in);
    options.min_length_px = htr_fuzz::anyInt(in);
    options.min_gradient = htr_fuzz::anyDouble(in);
    options.max_step_px = htr_fuzz::anyDouble(in);
    options.max_row_gap = htr_fuzz::anyInt(in);
    options.max_fit_rms_px = htr_fuzz::anyDouble(in);
    options.brightness_offset_px = htr_fuzz::anyInt(in);
    try {
      options.validate();
    } catch (const std::invalid_argument&) {
      return 0;
    }
  }
  std::optional<htr::PinholeCamera> camera;
  if (in.ConsumeBool()) {
    htr::CameraCalibration c;
    c.width = in.ConsumeBool() ? cols : in.ConsumeIntegralInRange<int>(1, 300);
    c.height = in.ConsumeBool() ? rows : in.ConsumeIntegralInRange<int>(1, 300);
    c.fx = in.ConsumeFloatingPointInRange<double>(1.0, 1000.0);
    c.fy = c.fx;
    c.cx = in.ConsumeFloatingPointInRange<double>(-50.0, 250.0);
    c.cy = in.ConsumeFloatingPointInRange<double>(-50.0, 250.0);
    if (in.ConsumeBool()) {
      c.distortion_model = "plumb_bob";
      for (int k = 0; k < 5; ++k) c.distortion.push_back(in.ConsumeFloatingPointInRange<double>(-1.0, 1.0));
    }
    try {
      camera.emplace(c);
    } catch (const std::invalid_argument&) {
      return 0;
    }
  }
  cv::Mat image(rows, cols, type, cv::Scalar::all(0));
  const std::vector<std::uint8_t> pixels = in.ConsumeRemainingBytes<std::uint8_t>();
  const std::size_t bytes = image.total() * image.elemSize();
  for (std::size_t k = 0; k < bytes && !pixels.empty(); ++k) image.data[k] = pixels[k % pixels.size()];
  if (type == CV_32FC1) cv::patchNaNs(image, 0.0);  // a float image is refused anyway
  htr::VerticalLineExtractor extractor(options);
  const auto lines = extractor.extract(image, camera ? &*camera : nullptr);
  if (!lines) return 0;
  for (const auto& line : *lines) {
    const bool inside = line.top.allFinite() && line.bottom.allFinite() && line.top.x() >= -1.0 &&
                        line.top.x() <= cols && line.bottom.y() <= rows && line.top.y() >= -1.0;
    if (!inside || !std::isfinite(line.length) || !std::isfinite(line.contrast)) __builtin_trap();
  }
  return 0;
}
