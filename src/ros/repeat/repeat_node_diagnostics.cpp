// RepeatNode's diagnostics (docs/nodes/repeat_node.md, "Diagnostics"): the localization state, the
// camera's silence, the integrity, the image transport, the timing of the last frames.
#include "homography_teach_repeat/ros/repeat_node.h"

#include <cmath>
#include <cstdio>
#include <optional>

namespace homography_teach_repeat {

double RepeatNode::cameraSilence() const {
  const bool images = !last_image_arrival_.isZero();
  if (!images && start_time_.isZero()) return 0.0;  // simulated clock not started yet
  return (ros::Time::now() - (images ? last_image_arrival_ : start_time_)).toSec();
}

void RepeatNode::produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(mutex_);
  static const RepeatStatistics kNoRepeat;
  const RepeatPipeline* repeat = pipeline();
  const RepeatStatistics& s = repeat != nullptr ? repeat->statistics() : kNoRepeat;
  const double silence = cameraSilence();
  if (navigator_) addMapDiagnostics(stat);
  if (silence > image_timeout_) {
    // A camera that stops is an error: no pose is published and the controller stops the robot.
    char text[160];
    std::snprintf(text, sizeof text, "%s: no image for %.1f s (image_timeout %.1f s)",
                  last_image_arrival_.isZero() ? "waiting for the camera" : "camera stopped", silence, image_timeout_);
    const bool images = !last_image_arrival_.isZero();
    stat.summary(images ? diagnostic_msgs::DiagnosticStatus::ERROR : diagnostic_msgs::DiagnosticStatus::WARN, text);
  } else if (repeat == nullptr) {
    // A map, no way followed yet: relocalizing (LOST), or placed and waiting for a destination.
    stat.summary(last_integrity_.level == IntegrityLevel::kOk ? diagnostic_msgs::DiagnosticStatus::OK
                                                               : diagnostic_msgs::DiagnosticStatus::WARN,
                 last_integrity_.reason);
  } else if (!s.last_status.isOk()) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, s.last_status.toString());
  } else if (s.last_degraded) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "degraded: localized against the temporary reference (route keyframes fail)");
  } else if (last_integrity_.level != IntegrityLevel::kOk) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                 "integrity " + toString(last_integrity_.level) + ": " + last_integrity_.reason);
  } else if (!mount_warning_.empty()) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, mount_warning_);
  } else {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "localized");
  }
  if (camera_subscriber_) camera_subscriber_->addDiagnostics(stat);
  stat.add("frames", s.frames);
  if (!mount_warning_.empty()) stat.add("camera mount", mount_warning_);
  stat.add("seconds since the last image", s.frames > 0 ? silence : -1.0);
  stat.add("integrity", toString(last_integrity_.level) +
                            (last_integrity_.reason.empty() ? "" : ": " + last_integrity_.reason));
  stat.addf("integrity 95 % bounds [m, deg]", "%.3f, %.2f", last_integrity_.position_bound,
            last_integrity_.heading_bound * 180.0 / M_PI);
  stat.addf("integrity NIS per dof (fixes)", "%.2f (%d)", last_integrity_.nis_per_dof, last_integrity_.nis_count);
  stat.addf("integrity time / distance without a fix [s, m]", "%.1f, %.2f", last_integrity_.time_without_fix,
            last_integrity_.distance_without_fix);
  if (repeat != nullptr && !repeat->hybridNotes().empty()) stat.add("hybrid: missing from the route", repeat->hybridNotes());
  stat.add("failures", s.failures);
  stat.add("degraded frames", s.degraded);
  stat.add("poses refused by the odometry gate", s.gated);
  stat.add("failed frames in a row", s.failures_in_a_row);
  stat.addf("whole-route searches (found a pose)", "%u (%u)", s.searches_all, s.found_by_search_all);
  stat.addf("seasonal heading fixes", "%u", s.shift_heading_fixes);
  // Median and maximum over the last frames (the latency an image sees is its age + processing).
  using Figure = std::optional<double>;
  stat.add("processing time median / max [ms]", timing_.medianAndMax([](const FrameTiming& t) { return Figure(t.processing_ms); }));
  stat.add("image age at processing start median / max [ms]", timing_.medianAndMax([](const FrameTiming& t) { return Figure(t.age_ms); }));
  stat.add("feature extraction median / max [ms]", timing_.medianAndMax([](const FrameTiming& t) {
             return t.localize ? Figure(t.localize->extraction_ms) : std::nullopt;
           }));
  stat.add("matching and estimation median / max [ms]", timing_.medianAndMax([](const FrameTiming& t) {
             return t.localize ? Figure(t.localize->references_ms) : std::nullopt;
           }));
  stat.add("references tried per frame median / max", timing_.medianAndMax([](const FrameTiming& t) {
             return t.localize ? Figure(t.localize->references_tried) : std::nullopt;
           }));
  stat.addf("frames tracked by optical flow", "%zu of the last %zu", timing_.trackedFrames(), timing_.size());
  stat.add("last inliers", s.last_inliers);
  stat.add("reference keyframe", s.last_keyframe);
  stat.add("tracked keyframe", repeat != nullptr ? repeat->localizer().trackedKeyframe() : -1);
}

}  // namespace homography_teach_repeat
