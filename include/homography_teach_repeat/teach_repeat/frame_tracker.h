// Frames between feature detections (RepeatOptions::max_tracked_frames): the inlier matches of the
// last estimate are followed into the next image by pyramidal Lucas-Kanade optical flow, checked
// forward and backward. The keyframe pixels stay, the current pixels move with the image. Feature
// extraction is most of a frame's cost (SIFT at 640x480: ~45 of ~50 ms on 2 cores), tracking ~5 ms.
#pragma once

#include <opencv2/core.hpp>

#include <optional>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/geometry/point_match.h"

namespace homography_teach_repeat {

class FrameTracker {
 public:
  // `max_tracked_frames` 0: never tracks. `tolerance_px`: forward-backward check. `min_points`:
  // fewer points followed is a failure.
  FrameTracker(int max_tracked_frames, double tolerance_px, int min_points);

  // Whether the next frame may be tracked against `keyframe` (the matches are of that keyframe and
  // fewer than max_tracked_frames frames were tracked since the last detection).
  bool canTrack(int keyframe) const;
  // The remembered matches followed into `gray` (reference pixels as they were, current pixels as
  // measured). kNoConsensus when fewer than `min_points` are followed.
  Expected<PointMatches> track(const cv::Mat& gray) const;
  int keyframe() const { return memory_ ? memory_->keyframe : -1; }
  int framesTracked() const { return memory_ ? memory_->frames_tracked : 0; }

  // Keeps `inliers` (against `keyframe`, measured in `gray`) for the next frames.
  void remember(const PointMatches& inliers, int keyframe, const cv::Mat& gray, int frames_tracked);
  void forget() { memory_.reset(); }

 private:
  struct Memory {
    cv::Mat image;                                  // grey frame the current points belong to
    std::vector<cv::Point2f> reference, current;   // keyframe and frame pixels (as measured)
    int keyframe = -1;
    int frames_tracked = 0;                          // frames since the last feature detection
  };
  int max_tracked_frames_;
  double tolerance_px_;
  int min_points_;
  std::optional<Memory> memory_;
};

}  // namespace homography_teach_repeat
