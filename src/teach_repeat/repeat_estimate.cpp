#include "homography_teach_repeat/teach_repeat/repeat_estimate.h"

#include <cmath>
#include <cstdio>
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
  if (!(match_residual_gain >= 0.0 && match_residual_gain <= 10.0)) {
    throw std::invalid_argument("match_residual_gain must be in [0, 10]");
  }
  line_landmarks.validate();
  if (!(mu_max_reference_angle > 0.0 && mu_max_reference_angle <= M_PI)) {
    throw std::invalid_argument("mu_max_reference_angle must be in (0, pi]");
  }
}

RepeatOptions withMeasuredNoise(RepeatOptions options, const Route& route) {
  const std::optional<double> residual = routeMatchResidual(route);
  if (residual && options.match_residual_gain > 0.0) options.pose.pixel_sigma_px = options.match_residual_gain * *residual;
  return options;
}

std::string describeMeasuredNoise(const RepeatOptions& options, const Route& route) {
  char text[320];
  const std::optional<double> residual = routeMatchResidual(route);
  const double sigma = withMeasuredNoise(options, route).pose.pixel_sigma_px;
  if (residual && options.match_residual_gain > 0.0) {
    std::snprintf(text, sizeof(text), "pixel sigma %.3f px: match_residual_gain %.2f x the route's match residual %.3f px",
                  sigma, options.match_residual_gain, *residual);
  } else if (residual) {
    std::snprintf(text, sizeof(text), "pixel sigma %.3f px from pixel_sigma (match_residual_gain 0; the route's match "
                  "residual is %.3f px)", sigma, *residual);
  } else if (route.info.match_noise_measured) {
    std::snprintf(text, sizeof(text), "pixel sigma %.3f px from pixel_sigma: no keyframe pair of the route registered "
                  "to measure its match residual", sigma);
  } else {
    std::snprintf(text, sizeof(text), "pixel sigma %.3f px from pixel_sigma: the route (format %d) has no measured match "
                  "noise; 'rosrun homography_teach_repeat route_info --migrate %s' measures it",
                  sigma, route.loaded_format_version, route.directory.c_str());
  }
  return text;
}

}  // namespace homography_teach_repeat
