#include "homography_teach_repeat/ros/repeat_visualization.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdio>
#include <vector>

#include "homography_teach_repeat/geometry/planar_pose.h"

namespace homography_teach_repeat {

cv::Mat drawRepeatMatches(const cv::Mat& reference_bgr, const cv::Mat& current, const RepeatEstimate* estimate,
                          const std::string& failure) {
  cv::Mat right;
  if (current.channels() == 1) {
    cv::cvtColor(current, right, cv::COLOR_GRAY2BGR);
  } else {
    right = current.clone();
  }
  cv::Mat canvas;
  if (!reference_bgr.empty() && estimate != nullptr && reference_bgr.size() == right.size()) {
    cv::hconcat(reference_bgr, right, canvas);
    const double offset = reference_bgr.cols;
    for (const auto& m : estimate->inlier_matches) {
      cv::line(canvas, cv::Point2d(m.reference.x(), m.reference.y()), cv::Point2d(m.current.x() + offset, m.current.y()),
               cv::Scalar(0, 200, 0), 1, cv::LINE_AA);
    }
  } else {
    canvas = right;
  }
  const std::string text = estimate != nullptr ? "keyframe " + std::to_string(estimate->keyframe) + "  " +
                                                     toString(estimate->mode) + "  inliers " +
                                                     std::to_string(estimate->inliers) +
                                                     (estimate->degraded ? "  DEGRADED" : "")
                                               : "no estimate: " + failure;
  cv::putText(canvas, text, cv::Point(10, 25), cv::FONT_HERSHEY_SIMPLEX, 0.6,
              estimate != nullptr ? cv::Scalar(0, 255, 0) : cv::Scalar(0, 0, 255), 2, cv::LINE_AA);
  return canvas;
}

std::optional<WallSegment> keyframeWallSegment(const Route& route, std::size_t keyframe, double width) {
  if (keyframe >= route.keyframes.size() || !route.keyframes[keyframe].plane) return std::nullopt;
  const ScenePlane& plane = *route.keyframes[keyframe].plane;
  const Pose2D camera = route.keyframes[keyframe].pose.compose(route.info.camera_mount);
  // Foot of the perpendicular from the camera (camera axes: x right, z forward) in base axes.
  const Eigen::Vector2d foot_camera(plane.normal.x() * plane.distance, plane.normal.z() * plane.distance);
  const Eigen::Vector2d foot = camera.transformPoint(Eigen::Vector2d(foot_camera.y(), -foot_camera.x()));
  const Eigen::Vector2d along = 0.5 * width *
                                (camera.transformPoint(Eigen::Vector2d(-plane.normal.x(), -plane.normal.z())) -
                                 camera.transformPoint(Eigen::Vector2d::Zero()));
  return WallSegment{foot - along, foot + along};
}

void FrameTimingWindow::add(const FrameTiming& timing) {
  frames_.push_back(timing);
  while (frames_.size() > capacity_) frames_.pop_front();
}

std::string FrameTimingWindow::medianAndMax(const std::function<std::optional<double>(const FrameTiming&)>& figure) const {
  std::vector<double> values;
  for (const FrameTiming& timing : frames_) {
    if (const std::optional<double> v = figure(timing)) values.push_back(*v);
  }
  if (values.empty()) return "-";
  std::sort(values.begin(), values.end());
  char text[64];
  std::snprintf(text, sizeof text, "%.1f / %.1f", values[values.size() / 2], values.back());
  return text;
}

std::size_t FrameTimingWindow::trackedFrames() const {
  return static_cast<std::size_t>(
      std::count_if(frames_.begin(), frames_.end(), [](const FrameTiming& t) { return t.localize && t.localize->tracked; }));
}

}  // namespace homography_teach_repeat
