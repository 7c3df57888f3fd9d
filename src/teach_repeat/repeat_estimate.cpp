#include "homography_teach_repeat/teach_repeat/repeat_estimate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>

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
  if (!(measured_tilt_gain >= 0.0 && measured_tilt_gain <= 10.0)) {
    throw std::invalid_argument("measured_tilt_gain must be in [0, 10]");
  }
  line_landmarks.validate();
  if (!(mu_max_reference_angle > 0.0 && mu_max_reference_angle <= M_PI)) {
    throw std::invalid_argument("mu_max_reference_angle must be in (0, pi]");
  }
}

RepeatOptions withMeasuredNoise(RepeatOptions options, const Route& route) {
  const std::optional<double> residual = routeMatchResidual(route);
  if (residual && options.match_residual_gain > 0.0) options.pose.pixel_sigma_px = options.match_residual_gain * *residual;
  options.pose.residual_sigma_gain = options.pixel_noise_per_fix ? options.match_residual_gain : 0.0;
  const std::optional<double> tilt = routeTiltSigma(route);
  if (tilt && options.measured_tilt_gain > 0.0) options.pose.tilt_sigma_rad = options.measured_tilt_gain * *tilt;
  return options;
}

namespace {
// "<what> <value>: <gain name> <gain> x the route's <measurement>" and the fallbacks' wording.
std::string describeOne(const char* what, double used, const char* unit, const char* gain_name, double gain,
                        const std::optional<double>& measured, const char* measurement, bool was_measured,
                        const char* configured_name) {
  char text[320];
  if (measured && gain > 0.0) {
    std::snprintf(text, sizeof(text), "%s %.4g %s: %s %.2f x the route's %s %.4g %s", what, used, unit, gain_name,
                  gain, measurement, *measured, unit);
  } else if (measured) {
    std::snprintf(text, sizeof(text), "%s %.4g %s from %s (%s 0; the route's %s is %.4g %s)", what, used, unit,
                  configured_name, gain_name, measurement, *measured, unit);
  } else if (was_measured) {
    std::snprintf(text, sizeof(text), "%s %.4g %s from %s: no keyframe pair of the route showed its %s", what, used,
                  unit, configured_name, measurement);
  } else {
    std::snprintf(text, sizeof(text), "%s %.4g %s from %s: the route has no measured %s", what, used, unit,
                  configured_name, measurement);
  }
  return text;
}
}  // namespace

double keyframePixelNoiseScale(const Route& route, std::size_t k, const std::optional<double>& route_residual) {
  // Within [0.5, 2]: a corner's pair can see two walls, and its residual says more of that than of
  // the pixels.
  constexpr double kSmallest = 0.5;
  constexpr double kLargest = 2.0;
  if (!route_residual) return 1.0;
  double squares = 0.0;
  int pairs = 0;
  for (const std::size_t j : {k - 1, k}) {  // (k - 1 wraps for k = 0: out of range)
    if (j >= route.keyframes.size() || !route.keyframes[j].match_residual) continue;
    squares += std::pow(route.keyframes[j].match_residual->rms_px, 2);
    ++pairs;
  }
  if (pairs == 0) return 1.0;
  return std::clamp(std::sqrt(squares / pairs) / *route_residual, kSmallest, kLargest);
}

bool routeMeasurementsMissing(const Route& route) {
  return !route.info.match_noise_measured || !route.info.tilt_measured || planeUncertaintyMissing(route);
}

std::string describeMeasuredNoise(const RepeatOptions& options, const Route& route) {
  const RepeatOptions used = withMeasuredNoise(options, route);
  std::string text = describeOne("pixel sigma", used.pose.pixel_sigma_px, "px", "match_residual_gain",
                                 options.match_residual_gain, routeMatchResidual(route), "match residual",
                                 route.info.match_noise_measured, "pixel_sigma");
  if (used.pose.residual_sigma_gain > 0.0) {
    text += " (a fix's own: match_residual_gain x its inliers' residual where more; pixel_noise_per_fix)";
  }
  text += "; " + describeOne("tilt sigma", used.pose.tilt_sigma_rad, "rad", "measured_tilt_gain",
                             options.measured_tilt_gain, routeTiltSigma(route), "tilt", route.info.tilt_measured,
                             "tilt_sigma");
  if (options.plane_sigma_from_neighbours && planeUncertaintyStored(route)) {
    text += "; the planes' uncertainty as the route stores it";
    int intercepts = 0;  // the heading floor's measurement (docs/math.md §3.8)
    double squares = 0.0;
    for (const RouteKeyframe& k : route.keyframes) {
      if (!k.plane_uncertainty || !k.plane_uncertainty->fix_heading_intercept_rad) continue;
      squares += std::pow(*k.plane_uncertainty->fix_heading_intercept_rad, 2);
      ++intercepts;
    }
    if (intercepts > 0) {
      char measured[200];
      std::snprintf(measured, sizeof(measured),
                    ", the heading floor where the fixes' error is measured from %d keyframes' intercepts "
                    "(%.2g rad rms) and common_shift_sigma",
                    intercepts, std::sqrt(squares / intercepts));
      text += measured;
    }
  } else if (options.plane_sigma_from_neighbours && planeUncertaintyMissing(route)) {
    text += "; the planes' uncertainty measured at load (the route does not store it)";
  }
  if (routeMeasurementsMissing(route)) {
    text += " (format " + std::to_string(route.loaded_format_version) +
            "; 'rosrun homography_teach_repeat route_info --migrate " + route.directory + "' measures it)";
  }
  return text;
}

}  // namespace homography_teach_repeat
