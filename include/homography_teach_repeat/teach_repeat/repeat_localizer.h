// The vision part of the repeat phase: localizes the current image against the keyframes of a
// taught route and gives the pose of base_link in the route frame (the odometry frame of the teach
// run, in which the keyframe poses are stored) with its covariance, or (mu) the heading fix.
// It composes the keyframe store, the reference selection, the frame tracker and the mode's
// estimator (keyframe_estimators.h):
//  - reference keyframe: the tracked one, then its neighbours (k+1, k−1, k+2, ...) when it fails
//    or the caller's check (the odometry gate) would refuse its pose: a wrong pose from one
//    keyframe (its plane a poor model of this view) must not hide a right one from the next;
//    tracking moves on when the robot is closer to the next keyframe than to the current one;
//  - each candidate keyframe: its taught view, then, when that fails or its pose is refused, its
//    experiences (views learned by earlier repeat runs, newest first; experience_learning.h);
//  - lost tracking (every candidate fails): the last good current image becomes a temporary
//    reference (paper 000's outdoor experiment) and estimates are flagged `degraded`; after
//    `max_degraded_frames` such frames, or when that fails too, localization reports failure;
//  - point modes: frames between detections follow the last inliers by optical flow.
// A failed estimate never gives a pose. The odometry, the μ filter and the odometry gate are the
// RepeatPipeline's (repeat_pipeline.h).
#pragma once

#include <opencv2/core.hpp>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/teach_repeat/frame_tracker.h"
#include "homography_teach_repeat/teach_repeat/keyframe_estimators.h"
#include "homography_teach_repeat/teach_repeat/keyframe_store.h"
#include "homography_teach_repeat/teach_repeat/reference_selection.h"
#include "homography_teach_repeat/teach_repeat/repeat_estimate.h"
#include "homography_teach_repeat/teach_repeat/route.h"

namespace homography_teach_repeat {

class RepeatLocalizer {
 public:
  // Accepts (ok) or refuses (the reason) a pose estimate before it is used or remembered.
  using PoseCheck = std::function<Status(const RepeatEstimate&)>;

  // Loads every keyframe's features or lines, and localizes with withMeasuredNoise(options, route)
  // (the covariance's pixel σ from the route's measured noise). kInvalidInput naming the file for a
  // corrupt keyframe; kInvalidInput when fast_hd/classic mode meets a route without planes.
  static Expected<RepeatLocalizer> create(const Route& route, const RepeatOptions& options);

  // Status: kInvalidInput (empty/odd image, size differs from the route's camera), or the failure
  // of the last reference tried (never a pose). mu mode: `predicted_pose` (route frame, the μ
  // filter's) restricts the references to those facing the same way and guides the line
  // matching. Ignored in the other modes and when not finite. `check` (when given, without side
  // effects) vets every estimate with a pose: one it refuses makes the next reference try (a
  // tracked frame is then detected afresh); when no reference gives an accepted pose, the first
  // refused one is returned, for the caller to decide about as without a check.
  Expected<RepeatEstimate> localize(const cv::Mat& image, std::optional<Pose2D> predicted_pose = std::nullopt,
                                    const PoseCheck& check = {});

  // With background detection (RepeatOptions::background_detection): one detection of a noise
  // image of the camera's size on the worker, waited for. The worker's first detection takes
  // several times as long as the next (its memory is fresh); repeat_node does this at start-up
  // instead of in its first frames. No effect otherwise.
  void warmUpBackgroundDetection();

  // Of the last localize() call (initializeGlobally: of its last localize()), failed ones too.
  const LocalizeTiming& lastTiming() const { return timing_; }

  // Start anywhere: tries every keyframe alone and tracks the one with most inliers.
  Expected<RepeatEstimate> initializeGlobally(const cv::Mat& image);

  void setTrackedKeyframe(int keyframe);
  // Tracking from a position known otherwise (mu mode: the μ filter's, which vision does not give).
  void advanceTrackingTo(const Pose2D& robot) { selector_.advanceTo(robot); }
  int trackedKeyframe() const { return selector_.tracked(); }
  bool closedRoute() const { return selector_.closedRoute(); }
  int keyframeCount() const { return keyframes_.size(); }
  int experienceCount() const { return keyframes_.experienceCount(); }
  // mu mode: whether keyframe k was reached turning (gives no heading fix, see
  // RepeatOptions::mu_skip_turn_keyframes). The first keyframe never is: the run starts there.
  bool isTurnKeyframe(int keyframe) const;
  // What keyframe k is localized against (its lines, landmarks, plane); k in [0, keyframeCount()).
  const KeyframeReference& reference(int keyframe) const { return keyframes_.at(keyframe); }
  const Route& route() const { return route_; }
  const PinholeCamera& camera() const { return estimator_->context().camera; }
  const RepeatOptions& options() const { return estimator_->context().options; }

 private:
  RepeatLocalizer(const Route& route, KeyframeStore keyframes, std::unique_ptr<KeyframeEstimator> estimator);
  // Against the candidates near the tracked keyframe, then the temporary reference.
  Expected<RepeatEstimate> localizeAgainstCandidates(const FrameObservations& frame, const cv::Mat& gray,
                                                     const std::optional<Pose2D>& predicted_pose, int neighbour_search,
                                                     int max_degraded_frames, const PoseCheck& check);
  Expected<RepeatEstimate> localizeByTracking(const cv::Mat& gray, const PoseCheck& check);
  // The features the worker detected in an earlier frame: matched against the candidates there,
  // their inliers followed into `gray` by one optical-flow step.
  Expected<RepeatEstimate> localizeFromBackground(const cv::Mat& gray, const PoseCheck& check);
  // Detects the features of `gray` on the worker (RepeatOptions::background_detection).
  void startBackgroundDetection(const cv::Mat& gray, const std::optional<Pose2D>& predicted_pose);
  bool backgroundDetectionOn() const;
  // The frame that just localized against `source` becomes the temporary reference (a pose
  // estimate needs source's plane seen from the frame; its uncertainty goes with it).
  void keepAsTemporaryReference(FrameObservations frame, const RepeatEstimate& estimate,
                                const KeyframeReference& source);
  // Keeps the estimate's inliers for the optical flow of the next frames (or forgets them).
  void rememberForTracking(const RepeatEstimate& estimate, const cv::Mat& gray, int frames_tracked);
  void advanceTracking(const RepeatEstimate& estimate);

  Route route_;
  KeyframeStore keyframes_;
  std::unique_ptr<KeyframeEstimator> estimator_;
  ReferenceSelector selector_;
  FrameTracker tracker_;
  std::optional<KeyframeReference> temporary_;
  int temporary_keyframe_ = -1;
  int degraded_frames_ = 0;
  LocalizeTiming timing_;
  // Last: its worker uses *estimator_ and must stop before the estimator goes.
  BackgroundDetection background_;
};

}  // namespace homography_teach_repeat
