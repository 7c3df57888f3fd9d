// Frames between feature detections (RepeatOptions::max_tracked_frames): the inlier matches of the
// last estimate are followed into the next image by pyramidal Lucas-Kanade optical flow, checked
// forward and backward. The keyframe pixels stay, the current pixels move with the image. Feature
// extraction is most of a frame's cost (SIFT at 640x480: ~45 of ~50 ms on 2 cores), tracking ~5 ms.
// BackgroundDetection detects a frame's features on a worker thread meanwhile
// (RepeatOptions::background_detection, docs/design.md "Background detection").
#pragma once

#include <opencv2/core.hpp>

#include <functional>
#include <future>
#include <optional>
#include <utility>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/geometry/point_match.h"
#include "homography_teach_repeat/teach_repeat/keyframe_estimators.h"

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
  int rememberedMatches() const { return memory_ ? static_cast<int>(memory_->reference.size()) : 0; }

  // Keeps `inliers` (against `keyframe`, measured in `gray`) for the next frames.
  void remember(const PointMatches& inliers, int keyframe, const cv::Mat& gray, int frames_tracked);
  void forget() { memory_.reset(); }
  // Counts the remembered matches as `frames_tracked` frames old (e.g. -1: the next step does not count).
  void setFramesTracked(int frames_tracked) {
    if (memory_) memory_->frames_tracked = frames_tracked;
  }

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

// One frame's feature detection on a worker thread (std::async) while the caller goes on; at
// most one at a time. The detector runs alone on what it is given: the caller must not use it
// (e.g. KeyframeEstimator::observe) until take() or discard() returned. Not thread-safe itself:
// one caller thread.
class BackgroundDetection {
 public:
  using Detect = std::function<Expected<FrameObservations>(const cv::Mat& gray)>;
  struct Result {
    Expected<FrameObservations> observations;  // the detector's, or kInvalidInput for an exception
    cv::Mat gray;                               // the image detected (owned)
    std::optional<Pose2D> predicted_pose;       // as given to start()
    int frames_since = 0;                       // frameSeen() calls since start()
    double waited_ms = 0.0;                     // the time take() waited for the worker
  };

  BackgroundDetection() = default;
  BackgroundDetection(BackgroundDetection&& other) noexcept : job_(std::move(other.job_)) { other.job_.reset(); }
  BackgroundDetection& operator=(BackgroundDetection&& other) noexcept;
  BackgroundDetection(const BackgroundDetection&) = delete;
  BackgroundDetection& operator=(const BackgroundDetection&) = delete;
  ~BackgroundDetection() { discard(); }

  // Starts `detect` on a copy of `gray` (a detection still running is waited for and dropped).
  void start(Detect detect, const cv::Mat& gray, std::optional<Pose2D> predicted_pose);
  bool pending() const { return job_.has_value(); }
  // One more frame has come since start() (no effect when nothing is pending).
  void frameSeen() {
    if (job_) ++job_->frames_since;
  }
  int framesSince() const { return job_ ? job_->frames_since : 0; }
  // Waits for the detection and hands it over; pending() afterwards is false. Only when pending().
  Result take();
  // Waits for a running detection (its detector is the caller's again) and drops it.
  void discard();

 private:
  struct Job {
    std::future<Expected<FrameObservations>> observations;
    cv::Mat gray;
    std::optional<Pose2D> predicted_pose;
    int frames_since = 0;
  };
  std::optional<Job> job_;
};

}  // namespace homography_teach_repeat
