// Teach and repeat offline over recorded data (evaluate_sequence; docs/evaluation.md, "Recorded
// sequences"): the teach frames go through TeachSession exactly as teach_node feeds it, the repeat
// frames through RepeatPipeline exactly as repeat_node feeds it (odometry samples up to each
// image's stamp, then the image), and every frame's outcome is scored against the ground truth.
//
// Scoring. The route frame is the teach run's odometry frame, which drifts from the ground truth's;
// what a teach-and-repeat needs is the pose relative to the taught keyframes. So the ground truth of
// a repeat frame is mapped into the route frame through its reference keyframe k (the one the
// estimate used, else the nearest by ground truth):
//   truth_in_route = keyframe_pose_k ∘ (truth_k⁻¹ ∘ truth)
// and the error is estimate − truth_in_route (with teach odometry = ground truth the two frames
// coincide). NEES: eᵀ P⁻¹ e with the published 3x3 covariance P of (x, y, yaw).
//
// Images: rotated to the level camera (docs/math.md §1.1) before anything sees them, with each
// frame's tilt from gravity (LevelSource::kGravity, an IMU's role), with the constant mount tilt
// (kMount, a robot without an IMU) or not at all (kNone); distortion is removed in the same remap
// when levelling. The same preparation is applied to the teach and the repeat images.
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/eval/recorded_sequence.h"
#include "homography_teach_repeat/sim/differential_drive.h"
#include "homography_teach_repeat/teach_repeat/repeat_pipeline.h"
#include "homography_teach_repeat/teach_repeat/teach_session.h"

namespace homography_teach_repeat {
namespace eval {

enum class LevelSource { kGravity, kMount, kNone };
// "gravity", "mount", "none"; throws std::invalid_argument naming the accepted values.
LevelSource levelSourceFromString(const std::string& name);
std::string toString(LevelSource source);

// Rotates an image to the level camera and scales it (the teach and repeat images alike).
struct PreparedImage {
  cv::Mat image;  // 8-bit grey
  CameraCalibration camera;
};
// `camera_to_level`: identity or absent for no rotation. `scale` in (0, 1]. kInvalidInput for a
// camera the pinhole model refuses or an empty image.
Expected<PreparedImage> prepareImage(const SequenceImage& frame, const std::optional<Eigen::Matrix3d>& camera_to_level,
                                     double scale);

struct SequenceEvaluationOptions {
  TeachOptions teach;  // route_directory, features, planes; keyframes: the policy (see below)
  RepeatPipelineOptions repeat;
  LevelSource level = LevelSource::kGravity;
  double image_scale = 1.0;
  // true: the teach frames take every offered frame as a keyframe (stride / index lists chosen by
  // the caller); false: the teach node's policy (teach.keyframes) decides among them.
  bool teach_every_offered_frame = false;
  // The teach run's odometry is the ground truth (as the simulator's teach run: the route is then
  // drift-free, and plane distances are metric); false: the recorded (or synthesized) odometry.
  bool teach_on_ground_truth = true;
  // Odometry for a sequence that has none (KITTI, Strecha): the ground truth's increments through
  // this error model (sim/differential_drive.h), seeded. Stated in the output.
  OdometryErrorModel synthesized_odometry;
  std::uint64_t seed = 1;
  // A frame is in a turn where the ground truth turns faster than this [rad/m] over ±3 m; runs
  // shorter than 5 m are merged into their neighbours (segments of the summary).
  double turn_rate = 0.03;

  void validate() const;  // throws std::invalid_argument naming the bad field
};

// Which frames of which sequences: teach and repeat may be the same sequence (frames split
// between them) or two recordings.
struct SequenceSelection {
  std::vector<int> teach_frames;   // offered to the teach session, in this order
  std::vector<int> repeat_frames;  // processed by the repeat pipeline, in this order
  // One recording for both: the repeat frames that became keyframes are skipped.
  bool skip_taught_frames = false;
};

struct FrameOutcome {
  int frame = -1;
  double stamp = 0.0;
  std::string status;  // "OK" or the pipeline's status
  int keyframe = -1;   // the estimate's reference keyframe (-1: none)
  int scoring_keyframe = -1;
  int inliers = 0;
  bool degraded = false, tracked = false;
  std::string fixes;  // mu/hybrid: what corrected the filter (RepeatFrameResult::fixes)
  std::optional<Pose2D> pose;  // published pose (route frame)
  std::optional<Eigen::Matrix3d> covariance;
  std::optional<Pose2D> truth;  // ground truth in the route frame
  std::optional<double> position_error, heading_error, nees;  // [m], [rad]
  double time_ms = 0.0;  // processFrame wall clock
  std::string segment;   // e.g. "turn 1", "straight 1"
  double distance = 0.0;  // [m] along the ground truth from the first repeat frame
};

// A frame skipped because its image could not be read.
struct UnreadableFrame {
  std::string phase;  // "teach" or "repeat"
  int frame = -1;     // sequence index
  std::string reason;
};

struct SequenceEvaluation {
  std::vector<FrameOutcome> frames;
  std::vector<UnreadableFrame> unreadable_frames;  // skipped: their images could not be read
  std::vector<int> keyframe_frames;  // sequence index of each keyframe
  Route route;
  PlaneEstimationReport planes;
  std::string odometry_note;  // where the teach and repeat odometry came from
};

// Runs teach then repeat. A frame whose image cannot be read (corrupt, truncated) is skipped and
// listed in unreadable_frames. kInvalidInput naming the problem: no frames, an index outside a
// sequence, no ground truth where one is needed, a route directory
// that cannot be written; a failed teach (too few keyframes) with the teach session's status.
Expected<SequenceEvaluation> evaluateSequence(const RecordedSequence& teach, const RecordedSequence& repeat,
                                              const SequenceSelection& selection,
                                              const SequenceEvaluationOptions& options);

// Summary statistics (overall and per segment) and the per-frame table, as evaluate_sequence
// writes them (docs/evaluation.md lists the fields).
nlohmann::json toJson(const SequenceEvaluation& evaluation);

}  // namespace eval
}  // namespace homography_teach_repeat
