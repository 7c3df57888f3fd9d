#include "homography_teach_repeat/ros/repeat_parameters.h"

#include <string>

#include "homography_teach_repeat/ros/parameters.h"

namespace homography_teach_repeat {

// config/repeat_node.yaml documents every parameter.
RepeatPipelineOptions readRepeatPipelineOptions(const ros::NodeHandle& nh) {
  RepeatPipelineOptions o;
  readParameters(nh, [&] {
    RepeatOptions& r = o.localization;
    r.mode = repeatModeFromString(readParameter<std::string>(nh, "mode", toString(kDefaultRepeatMode)));
    r.max_features = readParameter(nh, "max_features", r.max_features);
    r.pose.pixel_sigma_px = readParameter(nh, "pixel_sigma", r.pose.pixel_sigma_px);
    r.match_residual_gain = readParameter(nh, "match_residual_gain", r.match_residual_gain);
    r.pixel_noise_per_keyframe = readParameter(nh, "pixel_noise_per_keyframe", r.pixel_noise_per_keyframe);
    r.pixel_noise_per_fix = readParameter(nh, "pixel_noise_per_fix", r.pixel_noise_per_fix);
    r.pose.refine = readParameter(nh, "refine", r.pose.refine);
    r.pose.plane_normal_sigma_rad = readParameter(nh, "plane_normal_sigma", r.pose.plane_normal_sigma_rad);
    r.pose.plane_distance_sigma = readParameter(nh, "plane_distance_sigma", r.pose.plane_distance_sigma);
    r.pose.tilt_sigma_rad = readParameter(nh, "tilt_sigma", r.pose.tilt_sigma_rad);
    r.measured_tilt_gain = readParameter(nh, "measured_tilt_gain", r.measured_tilt_gain);
    r.pose.heading_sigma_rad = readParameter(nh, "heading_sigma", r.pose.heading_sigma_rad);
    r.pose.common_shift_sigma_px = readParameter(nh, "common_shift_sigma", r.pose.common_shift_sigma_px);
    r.plane_sigma_from_neighbours = readParameter(nh, "plane_sigma_from_neighbours", r.plane_sigma_from_neighbours);
    r.min_inliers = readParameter(nh, "min_inliers", r.min_inliers);
    r.neighbour_search = readParameter(nh, "neighbour_search", r.neighbour_search);
    r.max_degraded_frames = readParameter(nh, "max_degraded_frames", r.max_degraded_frames);
    r.max_tracked_frames = readParameter(nh, "max_tracked_frames", r.max_tracked_frames);
    r.tracking_tolerance_px = readParameter(nh, "tracking_tolerance", r.tracking_tolerance_px);
    r.background_detection = readParameter(nh, "background_detection", r.background_detection);
    r.use_experiences = readParameter(nh, "use_experiences", r.use_experiences);
    r.max_plane_residual_px = readParameter(nh, "max_plane_residual", r.max_plane_residual_px);
    r.closed_route_gap = readParameter(nh, "closed_route_gap", r.closed_route_gap);
    r.mu_skip_turn_keyframes = readParameter(nh, "mu_skip_turn_keyframes", r.mu_skip_turn_keyframes);
    r.mu_max_reference_angle = readParameter(nh, "mu_max_reference_angle", r.mu_max_reference_angle);
    r.lines.min_length_px = readParameter(nh, "line_min_length_px", r.lines.min_length_px);
    r.mu_line_landmarks = readParameter(nh, "mu_line_landmarks", r.mu_line_landmarks);
    r.line_landmarks.max_reprojection_px = readParameter(nh, "line_landmark_max_reprojection", r.line_landmarks.max_reprojection_px);
    r.line_landmarks.max_depth_m = readParameter(nh, "line_landmark_max_depth", r.line_landmarks.max_depth_m);
    LocalizationFilterOptions& m = o.mu_filter;
    m.initial_position_variance = readParameter(nh, "mu_initial_position_variance", m.initial_position_variance);
    m.position_variance_per_metre = readParameter(nh, "mu_position_variance_per_metre", m.position_variance_per_metre);
    m.heading_fix_variance = readParameter(nh, "mu_heading_fix_variance", m.heading_fix_variance);
    m.heading_variance_per_metre = readParameter(nh, "mu_heading_variance_per_metre", m.heading_variance_per_metre);
    m.heading_variance_per_radian = readParameter(nh, "mu_heading_variance_per_radian", m.heading_variance_per_radian);
    m.position_variance_per_radian = readParameter(nh, "mu_position_variance_per_radian", m.position_variance_per_radian);
    m.pose_innovation_gate = readParameter(nh, "pose_innovation_gate", m.pose_innovation_gate);
    m.pose_common_fraction = readParameter(nh, "pose_common_fraction", m.pose_common_fraction);
    m.min_mu_variance = readParameter(nh, "mu_variance", m.min_mu_variance);
    m.innovation_gate = readParameter(nh, "mu_innovation_gate", m.innovation_gate);
    m.refused_before_reset = readParameter(nh, "mu_gate_switch_after", m.refused_before_reset);
    m.max_mu_step_px = readParameter(nh, "mu_max_step", m.max_mu_step_px);
    m.max_confirmation_distance = readParameter(nh, "mu_max_confirmation_distance", m.max_confirmation_distance);
    m.line_sigma_px = readParameter(nh, "mu_line_sigma", m.line_sigma_px);
    m.min_landmark_lines = readParameter(nh, "mu_min_landmark_lines", m.min_landmark_lines);
    m.line_position_sigma_m = readParameter(nh, "mu_line_position_sigma", m.line_position_sigma_m);
    m.line_heading_sigma_rad = readParameter(nh, "mu_line_heading_sigma", m.line_heading_sigma_rad);
    if (readParameter(nh, "odometry_gate", true)) {
      OdometryGateOptions& g = o.odometry_gate.emplace();
      g.position_tolerance = readParameter(nh, "gate_position_tolerance", g.position_tolerance);
      g.heading_tolerance = readParameter(nh, "gate_heading_tolerance", g.heading_tolerance);
      g.drift_fraction = readParameter(nh, "gate_drift_fraction", g.drift_fraction);
      g.heading_drift_per_metre = readParameter(nh, "gate_heading_drift_per_metre", g.heading_drift_per_metre);
      g.rotation_drift_fraction = readParameter(nh, "gate_rotation_drift_fraction", g.rotation_drift_fraction);
      g.switch_after = readParameter(nh, "gate_switch_after", g.switch_after);
      g.window = readParameter(nh, "gate_window", g.window);
    } else {
      o.odometry_gate.reset();
    }
    o.start_keyframe = readParameter(nh, "start_keyframe", o.start_keyframe);
    o.max_unaided_distance = readParameter(nh, "max_unaided_distance", o.max_unaided_distance);
    o.follow_odometry_distance = readParameter(nh, "follow_odometry_distance", o.follow_odometry_distance);
    o.search_all_after = readParameter(nh, "search_all_after", o.search_all_after);
    o.hybrid_fuse_both = readParameter(nh, "hybrid_fuse_both", o.hybrid_fuse_both);
    o.fast_hd_retry_period = readParameter(nh, "fast_hd_retry_period", o.fast_hd_retry_period);
    o.hybrid_skip_turn_keyframes = readParameter(nh, "hybrid_skip_turn_keyframes", o.hybrid_skip_turn_keyframes);
    o.shift_heading = readParameter(nh, "shift_heading", o.shift_heading);
    o.shift_heading_period = readParameter(nh, "shift_heading_period", o.shift_heading_period);
    o.shift_heading_options.cache_size = readParameter(nh, "shift_heading_cache_size", o.shift_heading_options.cache_size);
    IntegrityOptions& i = o.integrity;
    i.degraded_position_bound = readParameter(nh, "integrity_degraded_position_bound", i.degraded_position_bound);
    i.lost_position_bound = readParameter(nh, "integrity_lost_position_bound", i.lost_position_bound);
    i.degraded_heading_bound = readParameter(nh, "integrity_degraded_heading_bound", i.degraded_heading_bound);
    i.lost_heading_bound = readParameter(nh, "integrity_lost_heading_bound", i.lost_heading_bound);
    i.nis_window = readParameter(nh, "integrity_nis_window", i.nis_window);
    i.degraded_nis = readParameter(nh, "integrity_degraded_nis", i.degraded_nis);
    i.degraded_refused_in_a_row = readParameter(nh, "integrity_degraded_refused_in_a_row", i.degraded_refused_in_a_row);
    i.lost_refused_in_a_row = readParameter(nh, "integrity_lost_refused_in_a_row", i.lost_refused_in_a_row);
    i.degraded_time_without_fix = readParameter(nh, "integrity_degraded_time_without_fix", i.degraded_time_without_fix);
    i.lost_time_without_fix = readParameter(nh, "integrity_lost_time_without_fix", i.lost_time_without_fix);
    i.degraded_min_inliers = readParameter(nh, "integrity_degraded_min_inliers", i.degraded_min_inliers);
    o.validate();
  });
  return o;
}

RelocalizationOptions readRelocalizationOptions(const ros::NodeHandle& nh) {
  RelocalizationOptions o;
  readParameters(nh, [&] {
    o.candidates = readParameter(nh, "relocalization_candidates", o.candidates);
    o.checks_per_frame = readParameter(nh, "relocalization_checks_per_frame", o.checks_per_frame);
    o.confirmations = readParameter(nh, "relocalization_confirmations", o.confirmations);
    o.confirmation_distance = readParameter(nh, "relocalization_confirmation_distance", o.confirmation_distance);
    o.confirmation_turn = readParameter(nh, "relocalization_confirmation_turn", o.confirmation_turn);
    o.gate_distance = readParameter(nh, "relocalization_gate_distance", o.gate_distance);
    o.gate_yaw = readParameter(nh, "relocalization_gate_yaw", o.gate_yaw);
    o.max_hypotheses = readParameter(nh, "relocalization_max_hypotheses", o.max_hypotheses);
    o.cached_keyframes = static_cast<std::size_t>(readCheckedParameter(
        nh, "relocalization_cached_keyframes", static_cast<int>(o.cached_keyframes), [](int n) { return n >= 1; },
        "must be at least 1"));
    o.hint_radius = readParameter(nh, "relocalization_hint_radius", o.hint_radius);
    o.max_place_distance = readParameter(nh, "relocalization_max_place_distance", o.max_place_distance);
    o.validate();
  });
  return o;
}

std::optional<ExperienceLearningOptions> readExperienceLearningOptions(const ros::NodeHandle& nh) {
  if (!readParameter(nh, "learn_experiences", false)) return std::nullopt;
  ExperienceLearningOptions o;
  readParameters(nh, [&] {
    o.learn_below_inliers = readParameter(nh, "learn_below_inliers", o.learn_below_inliers);
    o.max_distance = readParameter(nh, "learn_max_distance", o.max_distance);
    o.max_angle = readParameter(nh, "learn_max_angle", o.max_angle);
    o.max_position_sigma = readParameter(nh, "learn_max_position_sigma", o.max_position_sigma);
    o.max_experiences = readParameter(nh, "max_experiences", o.max_experiences);
    o.validate();
  });
  return o;
}

// The run-time tunables of RepeatOptions as dynamic_reconfigure reports them.
void writeRepeatTunables(const RepeatOptions& options, RepeatConfig& config) {
  config.mode = toString(options.mode);
  config.pixel_sigma = options.pose.pixel_sigma_px;
  config.refine = options.pose.refine;
  config.min_inliers = options.min_inliers;
  config.neighbour_search = options.neighbour_search;
  config.max_degraded_frames = options.max_degraded_frames;
}

}  // namespace homography_teach_repeat
