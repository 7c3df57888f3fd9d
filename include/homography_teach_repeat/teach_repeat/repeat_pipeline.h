// A repeat frame's whole path without ROS: the image and the odometry in, the pose with its
// covariance (or the reason there is none) out. repeat_node only converts messages and publishes
// what this returns (one call per callback).
//
//  - Vision: RepeatLocalizer against the route's keyframes (global initialization on the first
//    frame when start_keyframe is -1).
//  - fast_hd / classic: the visual pose, refused when it disagrees with the odometry motion since
//    the last accepted pose (OdometryGate; docs/reliability.md).
//  - mu: the localization filter (localization/localization_filter.h: an EKF on the odometry,
//    docs/math.md §4.4-4.5) corrected by the frame's μ through the keyframe wall's model; the pose
//    is the filter's. Frames without a fix carry the pose on odometry alone for at most max_unaided_distance metres.
//    Where the lines give no fix, the seasonal heading fix (as in hybrid, below).
//  - hybrid (docs/math.md §7): the same filter takes, frame by frame, what the place offers: the
//    Fast-HD pose with its covariance where the keyframe has a plane and the pose passes its
//    checks and the odometry gate (§7.1), the μ fix (or line landmark fix) where it has vertical
//    lines, both where both exist, the odometry alone in between (within max_unaided_distance).
//    Where none of these is available, the seasonal heading fix (ShiftHeading against the nearest
//    keyframe's images, shift_heading). The published pose and covariance are the filter's. A
//    route without planes runs on μ, one without lines on Fast-HD (hybridNotes() says what is
//    missing).
//  - every mode: frames without a fix let the search follow the odometry along the route and,
//    after search_all_after of them, try every keyframe; the integrity monitor
//    (integrity_monitor.h) judges every frame's pose.
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
#include "homography_teach_repeat/localization/localization_filter.h"
#include "homography_teach_repeat/localization/integrity_monitor.h"
#include "homography_teach_repeat/geometry/odometry_buffer.h"
#include "homography_teach_repeat/localization/odometry_gate.h"
#include "homography_teach_repeat/teach_repeat/keyframe_shift_heading.h"
#include "homography_teach_repeat/teach_repeat/repeat_localizer.h"
#include "homography_teach_repeat/teach_repeat/route.h"

namespace homography_teach_repeat {

struct RepeatPipelineOptions {
  RepeatOptions localization;
  LocalizationFilterOptions mu_filter;
  std::optional<OdometryGateOptions> odometry_gate = OdometryGateOptions();  // nullopt: no gate
  // The keyframe the robot starts at; -1: found by trying every keyframe on the first image.
  int start_keyframe = 0;
  // mu and hybrid: how far [m] the filter carries the pose on odometry alone after its last fix;
  // 0: never (no pose without a fix).
  double max_unaided_distance = 3.0;
  // hybrid: also take the μ fix in a frame whose Fast-HD pose was accepted (false: μ only where
  // there is no pose). Both are measured through the keyframe's plane, so their errors are not
  // independent as the filter takes them: beside a pose of an uncertain plane the μ fix moved
  // KITTI 07's estimate 1.4 m (docs/math.md §7.1).
  bool hybrid_fuse_both = false;
  // hybrid: no Fast-HD pose from the keyframes where the teach run turned
  // (RepeatOptions::skip_turn_keyframes_for_poses); the filter turns on odometry and μ there.
  // Off: in the simulator's gallery it made things worse (2 laps: 13 poses more than 0.3 m or 5°
  // off, none with the corners' fixes).
  bool hybrid_skip_turn_keyframes = false;
  IntegrityOptions integrity;
  // fast_hd/classic (docs/reliability.md, "Lost and found"):
  //  - before every search, and in frames without a pose, the odometry since the last accepted
  //    pose moves the tracked keyframe on, so the search starts at the keyframe nearest the robot
  //    (the route says where the next keyframes are) for up to `follow_odometry_distance`
  //    [m, >= 0; 0: never] of travel (hybrid starts at the filter's prediction);
  //  - after `search_all_after` [>= 0; 0: never] failed frames in a row, and again every that many,
  //    every keyframe is tried (a wrong tracked keyframe, a start elsewhere); the pose found still
  //    passes the odometry gate, and a failed search leaves the tracked keyframe as it was.
  double follow_odometry_distance = 5.0;
  int search_all_after = 10;
  // mu and hybrid: the seasonal heading fix (teach_repeat/keyframe_shift_heading.h, docs/math.md
  // §4.10) in a frame without a Fast-HD pose, μ or line fix: the current image against the stored images
  // of the keyframe the filter's prediction is at and of its experiences (the best view's fix;
  // KeyframeShiftHeading::measureViews), when that keyframe faces within
  // localization.mu_max_reference_angle of the predicted heading. Its μ goes through the
  // keyframe's wall model (a heading-only fix without one, or from an experience); an ambiguous
  // vote only where the filter's prediction is at most half as far from the winning shift as from
  // the runner-up. At most one attempt every `shift_heading_period` seconds [>= 0]: one costs
  // about 100-150 ms at 640x480 on 2 cores (bench_shift_heading), and the odometry carries the
  // heading in between.
  bool shift_heading = true;
  double shift_heading_period = 1.0;
  KeyframeShiftHeadingOptions shift_heading_options;
  // hybrid with planes: after a frame whose Fast-HD search found no pose (it detected features and
  // tried the keyframes near the robot, or every keyframe, without an estimate; a pose the odometry
  // gate or the filter refused does not count), the next search waits this long [s, >= 0; 0: every
  // frame]; a whole-route search that is due (search_all_after) does not wait. The filter
  // carries the pose on odometry, μ and the seasonal fix in between. A search costs a feature
  // detection and several keyframes' matching (50-90 ms at 640x480 on 2 cores), which a place that
  // matches nothing any more would otherwise spend on every frame (docs/nodes/repeat_node.md,
  // "Frame time").
  double fast_hd_retry_period = 0.25;

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
  // The filter modes (mu, hybrid): what corrected it in this frame ("fast_hd", "mu", "lines",
  // "fast_hd+mu", "shift", ...; empty: odometry alone).
  std::string fixes;
  IntegrityReport integrity;                  // the verdict on `pose`
};

// Counters and the last outcome, for diagnostics.
struct RepeatStatistics {
  unsigned frames = 0, failures = 0, degraded = 0, gated = 0;
  unsigned failures_in_a_row = 0;
  unsigned searches_all = 0, found_by_search_all = 0;  // whole-route searches, and those that gave a pose
  unsigned shift_heading_fixes = 0;  // mu and hybrid: seasonal heading fixes taken
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
  // Before the first frame: RepeatLocalizer::warmUpBackgroundDetection (repeat_node does it at start-up).
  void warmUp() { localizer_.warmUpBackgroundDetection(); }
  // New localization options (e.g. dynamic_reconfigure), tracking the same keyframe; the old ones
  // stay when the route cannot support them (the status says why).
  Status reconfigure(const RepeatOptions& options);

  // The localizer of the mode (hybrid: the Fast-HD one, or the μ one on a route without planes).
  const RepeatLocalizer& localizer() const { return localizer_; }
  // hybrid: the μ localizer beside the Fast-HD one (nullptr otherwise).
  const RepeatLocalizer* lineLocalizer() const { return line_localizer_ ? &*line_localizer_ : nullptr; }
  // hybrid: what the route lacks ("no planes: ...", "no vertical lines: ..."), empty when it has both.
  const std::string& hybridNotes() const { return hybrid_notes_; }
  RepeatMode mode() const { return options_.localization.mode; }
  const RepeatPipelineOptions& options() const { return options_; }
  const RepeatStatistics& statistics() const { return statistics_; }
  const LocalizationFilter& filter() const { return filter_; }

 private:
  // The odometry of an image's instant may arrive after the image (a simulator publishes both at
  // once); for the odometry gate and the filter (its prediction, fixes and pose) the newest sample
  // is close enough within this lag [s]. (With poseAt, a frame processed before its odometry had
  // arrived got no pose at all in the simulator's hybrid runs: every other covered frame was LOST.)
  static constexpr double kOdometryLag = 0.1;

  struct Localizers {
    RepeatLocalizer primary;
    std::optional<RepeatLocalizer> lines;  // hybrid with both planes and lines
    std::string notes;
  };
  static Expected<Localizers> createLocalizers(const Route& route, const RepeatOptions& options,
                                               bool skip_turn_keyframes);
  RepeatPipeline(Localizers localizers, const RepeatPipelineOptions& options);
  bool usesFilter() const;  // mu, hybrid
  bool primaryIsMu() const { return localizer_.options().mode == RepeatMode::kMu; }
  // hybrid: the whole frame (vision done, the filter corrected and read).
  RepeatFrameResult processHybridFrame(double stamp, const cv::Mat& image);
  // The seasonal fix's KeyframeShiftHeading, once the mode uses the filter (mu, hybrid) with shift_heading.
  void makeShiftHeadingIfUsed();
  // A frame with a filter fix in result->estimate: the statistics, the filter's pose, integrity.
  void finishFilterFix(double stamp, RepeatFrameResult* result);
  // The Fast-HD pose of a hybrid frame into the filter; the reason when none was taken.
  Status fuseHybridPose(double stamp, const Expected<Pose2D>& odom_near_image, const Expected<RepeatEstimate>& estimate,
                        RepeatFrameResult* result);
  void recordFix(double stamp, bool accepted, int inliers);
  void assessIntegrity(double stamp, RepeatFrameResult* result);
  // fast_hd/classic: the visual pose checked against the odometry.
  // `odom`: the odometry at the image stamp (or why there is none).
  Status gate(const Expected<Pose2D>& odom, const RepeatEstimate& estimate, std::string* warning);
  // mu: the filter at `stamp` corrected by the estimate's μ.
  // (`fix`: its keyframe and inliers become those of the line landmark fix taken.)
  // `beside_pose`: a Fast-HD pose was taken in this frame; a μ fix is then taken only through the
  // keyframe's wall, never as a heading alone (docs/math.md §7.1).
  Status correctMuFilter(double stamp, RepeatEstimate* fix, bool beside_pose = false);
  // hybrid, a frame without another fix: the seasonal heading fix into the filter (the reason
  // when none was taken).
  Status correctWithShiftHeading(double stamp, const cv::Mat& image, RepeatFrameResult* result);
  // mu, a keyframe with line landmarks: the filter's fix from the current lines.
  Status correctWithLineLandmarks(const Pose2D& odom, RepeatEstimate* fix);
  // mu/hybrid, a frame without a fix: the filter alone, within max_unaided_distance.
  void addUnaidedFilterPose(double stamp, RepeatFrameResult* result);
  Expected<Pose2D> unaidedFilterPose(const Pose2D& odom);
  std::optional<Pose2D> predictedFilterPose(double stamp) const;
  void setFilterPose(const Pose2D& pose, RepeatFrameResult* result);
  // fast_hd/classic, before a search and in a frame without a pose: the tracked keyframe follows
  // the odometry since the last accepted pose.
  void followOdometry(const Expected<Pose2D>& odom);
  bool searchAllNow() const;
  // hybrid: whether this frame searches for a Fast-HD pose (fast_hd_retry_period).
  bool fastHdSearchDue(double stamp) const;
  // The primary localizer on the image, each reference's pose vetted by the odometry gate; the
  // whole route when searchAllNow() (then `search_all` is set).
  Expected<RepeatEstimate> localizeWithGate(const cv::Mat& image, const Expected<Pose2D>& odom_near_image,
                                            const std::optional<Pose2D>& predicted, bool* search_all);

  RepeatLocalizer localizer_;
  std::optional<RepeatLocalizer> line_localizer_;  // hybrid
  std::string hybrid_notes_;
  RepeatPipelineOptions options_;
  IntegrityMonitor integrity_;
  bool initialized_ = false;
  OdometryBuffer odometry_;
  LocalizationFilter filter_;
  std::optional<OdometryGate> odometry_gate_;
  // fast_hd/classic: the last accepted pose's map -> odom, and the odometry then.
  std::optional<Pose2D> last_alignment_;
  std::optional<Pose2D> last_fix_odometry_;
  std::optional<KeyframeShiftHeading> shift_heading_;  // mu or hybrid, with shift_heading
  std::optional<double> last_shift_heading_stamp_;    // the last attempt's
  std::optional<double> last_failed_search_stamp_;    // hybrid: the last Fast-HD search without a pose
  RepeatStatistics statistics_;
};

}  // namespace homography_teach_repeat
