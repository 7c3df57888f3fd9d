// What a person looks at while the robot repeats (repeat_node's ~debug_image and
// ~route_markers), drawn without ROS.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cstddef>
#include <deque>
#include <functional>
#include <optional>
#include <string>

#include "homography_teach_repeat/teach_repeat/repeat_estimate.h"
#include "homography_teach_repeat/teach_repeat/route.h"

namespace homography_teach_repeat {

// The reference keyframe (BGR, may be empty) beside the current image with the inlier matches and
// a line of text: "keyframe k  mode  inliers n" or "no estimate: <failure>". Without a reference
// of the current image's size, the current image alone.
cv::Mat drawRepeatMatches(const cv::Mat& reference_bgr, const cv::Mat& current, const RepeatEstimate* estimate,
                          const std::string& failure);

// A keyframe's scene plane as a vertical wall segment `width` [m] wide (route frame, seen from
// above) centred on the foot of the perpendicular from the keyframe camera; nullopt without a plane.
struct WallSegment {
  Eigen::Vector2d a, b;
};
std::optional<WallSegment> keyframeWallSegment(const Route& route, std::size_t keyframe, double width = 2.0);

// The timing of the last frames, for diagnostics: median / max of a figure over the window.
struct FrameTiming {
  double processing_ms = 0.0;              // image in to results published
  double age_ms = 0.0;                     // image age when processing started (transport + waiting)
  std::optional<LocalizeTiming> localize;  // absent when the frame failed before localization
};
class FrameTimingWindow {
 public:
  explicit FrameTimingWindow(std::size_t frames = 300) : capacity_(frames) {}
  void add(const FrameTiming& timing);
  // "median / max" of `figure` over the frames that have it, "-" when none has.
  std::string medianAndMax(const std::function<std::optional<double>(const FrameTiming&)>& figure) const;
  std::size_t size() const { return frames_.size(); }
  std::size_t trackedFrames() const;

 private:
  std::size_t capacity_;
  std::deque<FrameTiming> frames_;
};

}  // namespace homography_teach_repeat
