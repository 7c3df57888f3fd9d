#include "homography_teach_repeat/teach_repeat/repeat_estimate.h"

#include <cmath>
#include <stdexcept>

namespace homography_teach_repeat {

RepeatMode repeatModeFromString(const std::string& name) {
  if (name == "fast_hd") return RepeatMode::kFastHd;
  if (name == "mu") return RepeatMode::kMu;
  if (name == "classic") return RepeatMode::kClassic;
  if (name == "hybrid") return RepeatMode::kHybrid;
  throw std::invalid_argument("unknown mode '" + name + "' (fast_hd, mu, classic, hybrid)");
}

std::string toString(RepeatMode mode) {
  switch (mode) {
    case RepeatMode::kFastHd: return "fast_hd";
    case RepeatMode::kMu: return "mu";
    case RepeatMode::kClassic: return "classic";
    case RepeatMode::kHybrid: return "hybrid";
  }
  return "unknown";
}

void RepeatOptions::validate() const {
  if (max_features < 1) throw std::invalid_argument("max_features must be >= 1");
  matching.validate();
  pose.validate();
  heading.validate();
  lines.validate();
  if (min_inliers < 4) throw std::invalid_argument("min_inliers must be >= 4");
  if (neighbour_search < 0) throw std::invalid_argument("neighbour_search must be >= 0");
  if (max_degraded_frames < 0) throw std::invalid_argument("max_degraded_frames must be >= 0");
  if (max_tracked_frames < 0) throw std::invalid_argument("max_tracked_frames must be >= 0");
  if (!(tracking_tolerance_px > 0.0 && std::isfinite(tracking_tolerance_px))) {
    throw std::invalid_argument("tracking_tolerance_px must be > 0");
  }
  if (!std::isfinite(max_plane_residual_px) || !(max_plane_residual_px > 0.0)) {
    throw std::invalid_argument("max_plane_residual_px must be > 0");
  }
  if (!(max_normal_angle > 0.0 && max_normal_angle <= M_PI) || !std::isfinite(min_normal_check_parallax) ||
      min_normal_check_parallax < 0.0) {
    throw std::invalid_argument("max_normal_angle must be in (0, pi], min_normal_check_parallax >= 0");
  }
  if (!std::isfinite(plane_feature_tolerance_px) || plane_feature_tolerance_px < 0.0) {
    throw std::invalid_argument("plane_feature_tolerance_px must be finite and >= 0");
  }
  if (!std::isfinite(closed_route_gap) || closed_route_gap < 0.0) {
    throw std::invalid_argument("closed_route_gap must be finite and >= 0");
  }
  line_landmarks.validate();
  if (!(mu_max_reference_angle > 0.0 && mu_max_reference_angle <= M_PI)) {
    throw std::invalid_argument("mu_max_reference_angle must be in (0, pi]");
  }
}

}  // namespace homography_teach_repeat
