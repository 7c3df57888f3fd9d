// A repeat frame's whole path without ROS: the image and the odometry in, the pose with its
// covariance (or the reason there is none) out. repeat_node only converts messages and publishes
// what this returns (one call per callback).
//
//  - Vision: RepeatLocalizer against the route's keyframes (global initialization on the first
//    frame when start_keyframe is -1).
//  - fast_hd / classic: the visual pose, refused when it disagrees with the odometry motion since
//    the last accepted pose (OdometryGate; docs/reliability.md).
//  - mu: the heading-aided odometry (an EKF on the odometry, docs/math.md §4.4-4.5) corrected by
//    the frame's μ through the keyframe wall's model; the pose is the filter's. Frames without a
//    fix carry the pose on odometry alone for at most mu_max_unaided_distance metres.
// The map -> odom alignment is returned for a node that publishes it as tf.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <deque>
#include <optional>
#include <string>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/mu/heading_aided_odometry.h"
#include "homography_teach_repeat/teach_repeat/odometry_buffer.h"
#include "homography_teach_repeat/teach_repeat/odometry_gate.h"
#include "homography_teach_repeat/teach_repeat/repeat_localizer.h"
#include "homography_teach_repeat/teach_repeat/route.h"

namespace homography_teach_repeat {

struct RepeatPipelineOptions {
  RepeatOptions localization;
  HeadingAidedOdometryOptions mu_filter;
  std::optional<OdometryGateOptions> odometry_gate = OdometryGateOptions();  // nullopt: no gate
  // The keyframe the robot starts at; -1: found by trying every keyframe on the first image.
  int start_keyframe = 0;
  // mu mode: how far [m] the filter carries the pose on odometry alone after its last fix; 0:
  // never (no pose without a fix).
  double mu_max_unaided_distance = 3.0;

  void validate() const;  // throws std::invalid_argument naming the bad field
};

// What one frame gave.
struct RepeatFrameResult {
  Status status = Status::ok();              // why this frame has no estimate
  std::optional<RepeatEstimate> estimate;     // vision's, when status is OK
  std::optional<Pose2D> pose;                 // base_link in the route frame, to publish
  std::optional<Eigen::Matrix3d> covariance;  // of `pose` (x, y, yaw); absent: unknown (classic)
  std::optional<Pose2D> map_to_odom;          // route frame -> odometry frame at this frame
  std::string warning;                        // something a user should read (logged throttled)
  std::optional<LocalizeTiming> timing;       // of the localizer, when the frame reached it
};

// Counters and the last outcome, for diagnostics.
struct RepeatStatistics {
  unsigned frames = 0, failures = 0, degraded = 0, gated = 0;
  int last_inliers = 0;
  int last_keyframe = -1;
  bool last_degraded = false;
  Status last_status{StatusCode::kInvalidInput, "no image received yet"};
};

class RepeatPipeline {
 public:
  // kInvalidInput naming the option, the route file or the start keyframe.
  static Expected<RepeatPipeline> create(const Route& route, const RepeatPipelineOptions& options);

  // An odometry sample (odometry frame); kInvalidInput for a non-finite pose.
  Status addOdometry(double stamp, const Pose2D& odom);
  // One image with the camera it was taken with (either may be the conversion's failure).
  RepeatFrameResult processFrame(double stamp, const Expected<cv::Mat>& image, const Expected<PinholeCamera>& camera);
  // New localization options (e.g. dynamic_reconfigure), tracking the same keyframe; the old ones
  // stay when the route cannot support them (the status says why).
  Status reconfigure(const RepeatOptions& options);

  const RepeatLocalizer& localizer() const { return localizer_; }
  const RepeatPipelineOptions& options() const { return options_; }
  const RepeatStatistics& statistics() const { return statistics_; }
  const HeadingAidedOdometry& muFilter() const { return mu_filter_; }

 private:
  RepeatPipeline(RepeatLocalizer localizer, const RepeatPipelineOptions& options);
  RepeatFrameResult fail(RepeatFrameResult result, const Status& status);
  // fast_hd/classic: the visual pose checked against the odometry.
  // `odom`: the odometry at the image stamp (or why there is none).
  Status gate(const Expected<Pose2D>& odom, const RepeatEstimate& estimate, std::string* warning);
  // mu: the filter at `stamp` corrected by the estimate's μ.
  // (`fix`: its keyframe and inliers become those of the line landmark fix taken.)
  Status correctMuFilter(double stamp, RepeatEstimate* fix);
  // mu, a keyframe with line landmarks: the filter's fix from the current lines.
  Status correctWithLineLandmarks(const Pose2D& odom, RepeatEstimate* fix);
  // mu, a frame without a fix: the filter alone, within mu_max_unaided_distance.
  void addUnaidedMuPose(double stamp, RepeatFrameResult* result);
  Expected<Pose2D> unaidedMuPose(const Pose2D& odom);
  std::optional<Pose2D> predictedMuPose(double stamp) const;
  void setMuPose(const Pose2D& pose, RepeatFrameResult* result);

  RepeatLocalizer localizer_;
  RepeatPipelineOptions options_;
  bool initialized_ = false;
  OdometryBuffer odometry_;
  HeadingAidedOdometry mu_filter_;
  std::optional<OdometryGate> odometry_gate_;
  RepeatStatistics statistics_;
};

}  // namespace homography_teach_repeat
