// route_info: the audit of a taught route (teach_repeat/route_audit.h, docs/route_audit.md). Prints
// one line per keyframe (what fast_hd and mu have there, the predicted fix, aliasing, weaknesses),
// writes OUT/route_audit.json and draws OUT/route_audit.png (top view coloured by the predicted
// position uncertainty, weak keyframes marked; per-keyframe figures along the route).
// `route_info --migrate DIR` rewrites a route's index in the current format (a version-1 route
// becomes version 2, docs/route_format.md).
// A map of routes (a folder with map.yaml, docs/map_format.md) is audited whole: each route as above
// into OUT/<route>/, and the map's junctions (network/map_audit.h: each measured again from the two
// keyframes' views; those too weak to relocalize across named) and the groups of routes no junction
// joins into OUT/map_audit.json and OUT/map_audit.png (the routes from above in the map frame).
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>

#include "homography_teach_repeat/common/command_line.h"
#include "homography_teach_repeat/eval/plots.h"
#include "homography_teach_repeat/network/map_audit.h"
#include "homography_teach_repeat/network/route_map.h"
#include "homography_teach_repeat/teach_repeat/keyframe_shift_heading.h"
#include "homography_teach_repeat/teach_repeat/route_audit.h"
#include "homography_teach_repeat/teach_repeat/teach_session.h"

using namespace homography_teach_repeat;

namespace {

nlohmann::json toJson(const KeyframeAudit& a) {
  nlohmann::json k = {{"keyframe", a.keyframe},
                      {"pose", {a.pose.x, a.pose.y, a.pose.yaw}},
                      {"features", a.features},
                      {"has_plane", a.has_plane},
                      {"plane_features", a.plane_features},
                      {"lines", a.lines},
                      {"line_landmarks", a.line_landmarks},
                      {"neighbour_inliers", a.neighbour_inliers}, {"pixel_noise_scale", a.pixel_noise_scale},
                          {"stretch_noise_scale", a.stretch_noise_scale},
                      {"alias_keyframe", a.alias_keyframe},
                      {"alias_inliers", a.alias_inliers},
                      {"fast_hd_weaknesses", a.fast_hd_weaknesses},
                      {"mu_weaknesses", a.mu_weaknesses}};
  if (a.has_plane) {
    k["plane_distance_m"] = a.plane_distance_m;
    k["plane_normal_sigma_rad"] = a.plane_normal_sigma_rad;
    k["plane_distance_sigma"] = a.plane_distance_sigma;
    if (a.neighbour_fix_error_per_m) {
      const Eigen::Vector3d& e = *a.neighbour_fix_error_per_m;
      k["neighbour_fix_error_per_m"] = {{"x", e.x()}, {"z", e.y()}, {"heading", e.z()}};
    }
    if (a.neighbour_fix_heading_floor_rad) k["neighbour_fix_heading_floor_rad"] = *a.neighbour_fix_heading_floor_rad;
  }
  if (a.predicted_covariance) {
    const Eigen::Matrix3d& c = *a.predicted_covariance;
    k["predicted_sigma"] = {{"along_m", std::sqrt(c(0, 0))}, {"across_m", std::sqrt(c(1, 1))},
                            {"heading_rad", std::sqrt(c(2, 2))}};
    k["predicted_covariance"] = std::vector<double>(c.data(), c.data() + 9);
    const Eigen::Matrix3d& spread = *a.predicted_fix_to_fix_covariance;
    k["predicted_fix_to_fix_sigma"] = {{"along_m", std::sqrt(spread(0, 0))}, {"across_m", std::sqrt(spread(1, 1))},
                                       {"heading_rad", std::sqrt(spread(2, 2))}};
    k["predicted_matches"] = a.predicted_matches;
    k["expected_match_fraction"] = a.expected_match_fraction;
    k["neighbour_plane_features_in_view"] = a.neighbour_plane_features_in_view;
    k["neighbour_match_fraction"] = a.neighbour_match_fraction;
    k["match_stretch_scale"] = a.match_stretch_scale;
  } else {
    k["predicted_sigma"] = nullptr;
    k["prediction_problem"] = a.prediction_problem;
  }
  return k;
}

// Writes `document` to `json_path` (its folder created) and, with `plots`, draws it; 0 or 1.
int writeDocument(const nlohmann::json& document, const std::string& json_path, bool plots) {
  std::error_code error;
  std::filesystem::create_directories(std::filesystem::path(json_path).parent_path(), error);
  std::ofstream file(json_path);
  file << std::setw(1) << document << "\n";
  file.close();
  if (!file) {
    std::cerr << "route_info: cannot write " << json_path << "\n";
    return 1;
  }
  std::cout << "wrote " << json_path << "\n";
  std::fflush(stdout);
  if (plots && eval::drawPlots(json_path, "route_info") != 0) return 1;
  return 0;
}

// The audit of one route: its table on stdout, OUT/route_audit.json (and .png with `plots`).
int auditOneRoute(const Route& route, const RouteAuditOptions& options, bool shift_heading, const std::string& out,
                  bool plots) {
  const auto audit = auditRoute(route, options);
  if (!audit) {
    std::cerr << "route_info: " << audit.status().toString() << "\n";
    return 1;
  }
  // The seasonal heading fix's material (keyframe_shift_heading.h): its features per keyframe and
  // its vote's support against the next keyframe.
  std::vector<ShiftHeadingAudit> shift;
  if (shift_heading) shift = auditShiftHeading(route, PinholeCamera(route.info.camera));
  std::printf("%4s %8s %8s %6s %6s %10s %10s %9s %6s %6s %9s %12s %11s  %s\n", "kf", "x [m]", "y [m]", "feat", "plane",
              "sigma [m]", "sigma [deg]", "alias", "lines", "lmarks", "plane [m]", "plane sd °/%", "shift f/vote", "weak");
  for (const KeyframeAudit& a : audit->keyframes) {
    double position = NAN, heading = NAN;
    if (a.predicted_covariance) {
      position = std::sqrt(std::max((*a.predicted_covariance)(0, 0), (*a.predicted_covariance)(1, 1)));
      heading = std::sqrt((*a.predicted_covariance)(2, 2)) * 180.0 / M_PI;
    }
    const std::string alias = a.alias_keyframe >= 0 ? std::to_string(a.alias_inliers) + "@" + std::to_string(a.alias_keyframe) : "-";
    std::string weak;
    for (const auto& w : a.fast_hd_weaknesses) weak += "fast_hd: " + w + "; ";
    for (const auto& w : a.mu_weaknesses) weak += "mu: " + w + "; ";
    std::string seasonal = "-";
    if (static_cast<std::size_t>(a.keyframe) < shift.size()) {
      const ShiftHeadingAudit& h = shift[static_cast<std::size_t>(a.keyframe)];
      seasonal = std::to_string(h.features) + "/" + std::to_string(h.support) + (h.ambiguous ? "?" : "");
    }
    char plane_sd[32] = "-";  // the plane's normal [deg] and distance [%] std, from its neighbours
    if (a.has_plane && (a.plane_normal_sigma_rad > 0.0 || a.plane_distance_sigma > 0.0)) {
      std::snprintf(plane_sd, sizeof(plane_sd), "%.2f/%.1f", a.plane_normal_sigma_rad * 180.0 / M_PI,
                    100.0 * a.plane_distance_sigma);
    }
    std::printf("%4d %8.2f %8.2f %6d %6d %10.4f %10.3f %9s %6d %6d %9.2f %12s %11s  %s\n", a.keyframe, a.pose.x,
                a.pose.y, a.features, a.plane_features, position, heading, alias.c_str(), a.lines, a.line_landmarks,
                a.has_plane ? a.plane_distance_m : NAN, plane_sd, seasonal.c_str(), weak.c_str());
  }
  for (const auto& note : audit->notes) std::printf("note: %s\n", note.c_str());
  std::printf("match noise: %s\n", describeMeasuredNoise(options.repeat, route).c_str());
  std::printf("%d keyframes; weak for fast_hd: %d, for mu: %d\n", static_cast<int>(audit->keyframes.size()),
              audit->weak_for_fast_hd, audit->weak_for_mu);

  nlohmann::json document;
  document["kind"] = "route_audit";
  document["route"] = route.directory;
  document["format_version"] = route.loaded_format_version;
  // Where the keyframes' plane_normal_sigma_rad, plane_distance_sigma and neighbour_fix_error_per_m
  // come from: the route (its teach run's or a migration's measurement) or measured by this load.
  document["plane_uncertainty"] = planeUncertaintyStored(route) ? "stored" : planeUncertaintyMissing(route) ? "measured at load" : "none";
  const RepeatOptions used = withMeasuredNoise(options.repeat, route);
  document["setup"] = {{"probe_offset_m", options.probe_offset_m}, {"aliasing", options.aliasing},
                       {"pixel_sigma", used.pose.pixel_sigma_px},
                       {"pixel_sigma_fallback", options.repeat.pose.pixel_sigma_px},
                       {"match_residual_gain", options.repeat.match_residual_gain},
                       {"match_residual_px", routeMatchResidual(route).value_or(0.0)},
                       {"match_noise_measured", route.info.match_noise_measured},
                       {"plane_normal_sigma", options.repeat.pose.plane_normal_sigma_rad},
                       {"plane_distance_sigma", options.repeat.pose.plane_distance_sigma},
                       {"tilt_sigma", used.pose.tilt_sigma_rad},
                       {"tilt_sigma_fallback", options.repeat.pose.tilt_sigma_rad},
                       {"measured_tilt_gain", options.repeat.measured_tilt_gain},
                       {"measured_tilt_rad", routeTiltSigma(route).value_or(0.0)},
                       {"tilt_measured", route.info.tilt_measured},
                       {"heading_sigma", options.repeat.pose.heading_sigma_rad},
                       {"common_shift_sigma_px", options.repeat.pose.common_shift_sigma_px},
                       {"min_plane_features", options.min_plane_features},
                       {"max_position_sigma_m", options.max_position_sigma_m},
                       {"max_heading_sigma_rad", options.max_heading_sigma_rad},
                       {"max_alias_ratio", options.max_alias_ratio}, {"min_lines", options.min_lines}};
  document["summary"] = {{"keyframes", audit->keyframes.size()}, {"weak_for_fast_hd", audit->weak_for_fast_hd},
                         {"weak_for_mu", audit->weak_for_mu}, {"notes", audit->notes}};
  const auto residualJson = [](const std::optional<MatchResidual>& measured) {
    return measured ? nlohmann::json{{"rms_px", measured->rms_px}, {"inliers", measured->inliers}} : nlohmann::json();
  };
  const auto tiltJson = [](const std::optional<PairTilt>& tilt) {
    return tilt ? nlohmann::json{{"pitch_rad", tilt->pitch}, {"roll_rad", tilt->roll}} : nlohmann::json();
  };
  for (const KeyframeAudit& a : audit->keyframes) {
    nlohmann::json k = toJson(a);
    const RouteKeyframe& keyframe = route.keyframes[static_cast<std::size_t>(a.keyframe)];
    k["match_residual"] = residualJson(keyframe.match_residual);
    k["tilt_to_next"] = tiltJson(keyframe.tilt_to_next);
    // The learned views' own pair measurements (ExperienceRecorder::commit), in the route's noise too.
    k["experiences"] = nlohmann::json::array();
    for (const RouteExperience& e : keyframe.experiences) {
      k["experiences"].push_back({{"id", e.id}, {"stamp", e.stamp}, {"match_residual", residualJson(e.match_residual)},
                                  {"tilt_to_next", tiltJson(e.tilt_to_next)}});
    }
    if (static_cast<std::size_t>(a.keyframe) < shift.size()) {
      const ShiftHeadingAudit& h = shift[static_cast<std::size_t>(a.keyframe)];
      k["shift_heading"] = {{"features", h.features}, {"neighbour", h.neighbour}, {"support", h.support},
                            {"ambiguous", h.ambiguous}, {"problem", h.problem}};
    }
    document["keyframes"].push_back(k);
  }
  return writeDocument(document, out + "/route_audit.json", plots);
}

// The map's junctions and groups: a table on stdout, OUT/map_audit.json (and .png with `plots`).
int auditJunctions(const RouteMap& map, const RepeatOptions& repeat, const std::string& out, bool plots) {
  const auto audit = auditMap(map, repeat);
  if (!audit) {
    std::cerr << "route_info: " << audit.status().toString() << "\n";
    return 1;
  }
  std::printf("\n== junctions\n%-24s %-24s %8s %10s %10s %12s  %s\n", "from", "to", "inliers", "sigma [m]",
              "sigma [deg]", "off [m/deg]", "weak");
  nlohmann::json document;
  document["kind"] = "map_audit";
  document["map"] = map.directory;
  const auto frames = routeFramesInMap(map);
  document["frame"] = map.routes.front().name;
  for (const MapRoute& r : map.routes) {
    nlohmann::json route = {{"name", r.name}, {"keyframes", r.route.keyframes.size()}, {"in_map_frame", frames.count(r.name) > 0}};
    route["poses"] = nlohmann::json::array();
    if (frames.count(r.name) > 0) {
      for (const RouteKeyframe& k : r.route.keyframes) {
        const Pose2D p = frames.at(r.name).compose(k.pose);
        route["poses"].push_back({p.x, p.y, p.yaw});
      }
    }
    document["routes"].push_back(route);
  }
  document["junctions"] = nlohmann::json::array();
  for (const JunctionAudit& j : audit->junctions) {
    std::string weak;
    for (const std::string& w : j.weaknesses) weak += w + "; ";
    const double sigma = std::sqrt(std::max(j.covariance(0, 0), j.covariance(1, 1)));
    const double heading_deg = std::sqrt(j.covariance(2, 2)) * 180.0 / M_PI;
    std::printf("%-24s %-24s %8d %10.4f %10.3f %5.3f/%5.2f  %s\n", toString(j.stored.from).c_str(),
                toString(j.stored.to).c_str(), j.inliers, j.measured ? sigma : NAN, j.measured ? heading_deg : NAN,
                j.disagreement_m, j.disagreement_rad * 180.0 / M_PI, weak.empty() ? "-" : weak.c_str());
    nlohmann::json row = {{"from", toString(j.stored.from)}, {"to", toString(j.stored.to)},
                          {"stored", {j.stored.to_in_from.x, j.stored.to_in_from.y, j.stored.to_in_from.yaw}},
                          {"measured", j.measured}, {"inliers", j.inliers}, {"weaknesses", j.weaknesses}};
    if (j.measured) {
      row["measured_to_in_from"] = {j.measured_to_in_from.x, j.measured_to_in_from.y, j.measured_to_in_from.yaw};
      row["sigma_m"] = sigma;
      row["sigma_heading_rad"] = std::sqrt(j.covariance(2, 2));
      row["disagreement_m"] = j.disagreement_m;
      row["disagreement_rad"] = j.disagreement_rad;
    } else {
      row["problem"] = j.problem;
    }
    // Where it is, in the map frame (when its route is).
    const MapRoute* from = map.find(j.stored.from.route);
    const int position = map.keyframePosition(j.stored.from);
    if (from != nullptr && position >= 0 && frames.count(from->name) > 0) {
      const Pose2D at = frames.at(from->name).compose(from->route.keyframes[static_cast<std::size_t>(position)].pose);
      row["position"] = {at.x, at.y};
    }
    document["junctions"].push_back(row);
  }
  for (const auto& note : audit->notes) std::printf("note: %s\n", note.c_str());
  std::printf("%zu routes, %zu junctions; weak junctions: %d; groups of joined routes: %zu\n", map.routes.size(),
              audit->junctions.size(), audit->weak_junctions, audit->groups.size());
  document["groups"] = audit->groups;
  document["summary"] = {{"routes", map.routes.size()}, {"junctions", audit->junctions.size()},
                         {"weak_junctions", audit->weak_junctions}, {"groups", audit->groups.size()},
                         {"notes", audit->notes}};
  return writeDocument(document, out + "/map_audit.json", plots);
}

// The program's arguments with the repeat's own defaults (repeat_node's and config/repeat_node.yaml's):
// a flag only changes them.
cli::Arguments routeInfoArguments() {
  const RepeatOptions repeat_defaults;
  const PlanarPoseEstimatorOptions& pose_defaults = repeat_defaults.pose;
  return cli::Arguments(
      "route_info",
      {{"route", ""}, {"out", ""}, {"offset", "0.3"}, {"aliasing", "1"}, {"plots", "1"},
       {"pixel-sigma", std::to_string(pose_defaults.pixel_sigma_px)},
       {"match-residual-gain", std::to_string(repeat_defaults.match_residual_gain)},
       {"plane-normal-sigma", std::to_string(pose_defaults.plane_normal_sigma_rad)},
       {"plane-distance-sigma", std::to_string(pose_defaults.plane_distance_sigma)},
       {"tilt-sigma", std::to_string(pose_defaults.tilt_sigma_rad)},
       {"measured-tilt-gain", std::to_string(repeat_defaults.measured_tilt_gain)},
       {"heading-sigma", std::to_string(pose_defaults.heading_sigma_rad)},
       {"common-shift-sigma", std::to_string(pose_defaults.common_shift_sigma_px)},
       {"plane-sigma-from-neighbours", repeat_defaults.plane_sigma_from_neighbours ? "1" : "0"},
       {"pixel-noise-per-keyframe", repeat_defaults.pixel_noise_per_keyframe ? "1" : "0"}, {"stretch-noise-gain", "2"}, {"match-stretch-decay", "1.8"}, {"min-plane-features", "40"}, {"max-position-sigma", "0.05"},
       {"max-heading-sigma", "0.0087"}, {"max-alias-ratio", "0.5"}, {"min-lines", "10"}, {"shift-heading", "1"}, {"migrate", ""}},
      "--route DIR --out DIR\n"
      "  | --migrate DIR (rewrite a route's index in the current format, docs/route_format.md)\n"
      "  [--offset M] (the predicted fix: this far to the side of each keyframe)\n"
      "  [--aliasing 0|1] (match every keyframe against every other: n² matchings)\n"
      "  [--match-residual-gain G] (the pixel sigma: G x the route's measured match residual; 0 or none: --pixel-sigma)\n"
      "  [--measured-tilt-gain G] (the tilt sigma: G x the route's measured tilt; 0 or none: --tilt-sigma)\n"
      "  [--pixel-sigma PX] [--plane-normal-sigma RAD] [--plane-distance-sigma FRACTION] [--tilt-sigma RAD]\n"
      "  [--heading-sigma RAD] [--common-shift-sigma PX] [--plane-sigma-from-neighbours 0|1] (the repeat's covariance\n"
      "  terms, as repeat_node's parameters; the defaults are its defaults)\n"
      "  [--pixel-noise-per-keyframe 0|1] (each keyframe's pixel sigma scaled by its teach pairs' residual, as the repeat's)\n"
      "  [--stretch-noise-gain K] (a match's noise 1 + K (stretch - 1) where the view stretches it; 0: off)\n"
      "  [--match-stretch-decay L] (a match's chance exp(-L (stretch - 1)) where the view stretches it; 0: off)\n"
      "  [--min-plane-features N] [--max-position-sigma M] [--max-heading-sigma RAD] [--max-alias-ratio R]\n"
      "  [--min-lines N] (what makes a keyframe weak)\n"
      "  [--shift-heading 0|1] (1: the seasonal heading fix's features and vote per keyframe, ~0.2 s each)\n"
      "  [--plots 0|1]");
}

}  // namespace

int main(int argc, char** argv) {
  cli::Arguments args = routeInfoArguments();
  args.parse(argc, argv);
  if (!args.text("migrate").empty()) {
    const auto before = loadRoute(args.text("migrate"));
    const Status migrated = migrateRoute(args.text("migrate"));
    if (!migrated.isOk()) {
      std::cerr << "route_info: " << migrated.message() << "\n";
      return 1;
    }
    std::printf("route '%s': format_version %d -> %d\n", args.text("migrate").c_str(), before->loaded_format_version,
                kRouteFormatVersion);
    return 0;
  }
  if (args.text("route").empty() || args.text("out").empty()) args.fail("--route DIR and --out DIR are required");
  RouteAuditOptions options;
  options.probe_offset_m = args.number("offset");
  options.aliasing = args.integer("aliasing") != 0;
  options.repeat.pose.pixel_sigma_px = args.number("pixel-sigma");
  options.repeat.match_residual_gain = args.number("match-residual-gain");
  options.repeat.pose.plane_normal_sigma_rad = args.number("plane-normal-sigma");
  options.repeat.pose.plane_distance_sigma = args.number("plane-distance-sigma");
  options.repeat.pose.tilt_sigma_rad = args.number("tilt-sigma");
  options.repeat.measured_tilt_gain = args.number("measured-tilt-gain");
  options.repeat.pose.heading_sigma_rad = args.number("heading-sigma");
  options.repeat.pose.common_shift_sigma_px = args.number("common-shift-sigma");
  options.repeat.plane_sigma_from_neighbours = args.integer("plane-sigma-from-neighbours") != 0;
  options.repeat.pixel_noise_per_keyframe = args.integer("pixel-noise-per-keyframe") != 0;
  options.stretch_noise_gain = args.number("stretch-noise-gain");
  options.match_stretch_decay = args.number("match-stretch-decay");
  options.min_plane_features = args.integer("min-plane-features");
  options.max_position_sigma_m = args.number("max-position-sigma");
  options.max_heading_sigma_rad = args.number("max-heading-sigma");
  options.max_alias_ratio = args.number("max-alias-ratio");
  options.min_lines = args.integer("min-lines");

  const std::string directory = args.text("route");
  const bool shift_heading = args.integer("shift-heading") != 0;
  const bool plots = args.integer("plots") != 0;
  if (!std::filesystem::exists(directory + "/map.yaml")) {
    const auto route = loadRoute(directory);
    if (!route) {
      std::cerr << "route_info: " << route.status().toString() << "\n";
      return 1;
    }
    return auditOneRoute(*route, options, shift_heading, args.text("out"), plots);
  }
  const auto map = loadRouteMap(directory);
  if (!map) {
    std::cerr << "route_info: " << map.status().toString() << "\n";
    return 1;
  }
  for (const MapRoute& r : map->routes) {
    std::printf("\n== route %s (%s)\n", r.name.c_str(), r.route.directory.c_str());
    const int failed = auditOneRoute(r.route, options, shift_heading, args.text("out") + "/" + r.name, plots);
    if (failed != 0) return failed;
  }
  return auditJunctions(*map, options.repeat, args.text("out"), plots);
  return 0;
}
