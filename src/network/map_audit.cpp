#include "homography_teach_repeat/network/map_audit.h"

#include <cmath>
#include <map>

#include "homography_teach_repeat/common/text.h"
#include "homography_teach_repeat/network/junction_measurement.h"

namespace homography_teach_repeat {
namespace {

JunctionAudit auditJunction(const RouteMap& map, const Junction& junction, const RepeatOptions& repeat,
                            const MapAuditOptions& options) {
  JunctionAudit audit;
  audit.stored = junction;
  const auto measured = measureJunction(map, junction.from, junction.to, repeat);
  if (!measured) {
    audit.problem = measured.status().message();
    audit.weaknesses.push_back("the two keyframes' views give no pose: " + audit.problem);
    return audit;
  }
  audit.measured = true;
  audit.measured_to_in_from = measured->to_in_from;
  audit.covariance = measured->covariance;
  audit.inliers = measured->inliers;
  const Pose2D difference = junction.to_in_from.inverse().compose(measured->to_in_from);
  audit.disagreement_m = std::hypot(difference.x, difference.y);
  audit.disagreement_rad = std::abs(wrapToPi(difference.yaw));
  if (audit.inliers < options.min_inliers) {
    audit.weaknesses.push_back(std::to_string(audit.inliers) + " inliers (fewer than " +
                               std::to_string(options.min_inliers) + ")");
  }
  const double sigma = std::sqrt(std::max(audit.covariance(0, 0), audit.covariance(1, 1)));
  if (!(sigma <= options.max_position_sigma_m)) {
    audit.weaknesses.push_back("position sigma " + formatFixed(sigma, 3) + " m (more than " +
                               formatFixed(options.max_position_sigma_m, 3) + ")");
  }
  const double heading_sigma = std::sqrt(audit.covariance(2, 2));
  if (!(heading_sigma <= options.max_heading_sigma_rad)) {
    audit.weaknesses.push_back("heading sigma " + formatFixed(heading_sigma * 180.0 / M_PI, 2) + " deg (more than " +
                               formatFixed(options.max_heading_sigma_rad * 180.0 / M_PI, 2) + ")");
  }
  if (audit.disagreement_m > options.max_disagreement_m || audit.disagreement_rad > options.max_disagreement_rad) {
    audit.weaknesses.push_back("measured again " + formatFixed(audit.disagreement_m, 3) + " m and " +
                               formatFixed(audit.disagreement_rad * 180.0 / M_PI, 2) +
                               " deg from the stored pose (the map's junction is off, or the place changed)");
  }
  return audit;
}

}  // namespace

Expected<MapAudit> auditMap(const RouteMap& map, const RepeatOptions& repeat, const MapAuditOptions& options) {
  if (options.min_inliers < 1 || !(options.max_position_sigma_m > 0.0) || !(options.max_heading_sigma_rad > 0.0) ||
      !(options.max_disagreement_m > 0.0) || !(options.max_disagreement_rad > 0.0)) {
    return Status(StatusCode::kInvalidInput, "map audit: thresholds must be > 0");
  }
  MapAudit audit;
  for (const Junction& j : map.junctions) {
    audit.junctions.push_back(auditJunction(map, j, repeat, options));
    if (!audit.junctions.back().weaknesses.empty()) ++audit.weak_junctions;
  }
  // The groups of routes the junctions join (each route's frames as seen from a root).
  std::map<std::string, bool> grouped;
  for (const MapRoute& r : map.routes) {
    if (grouped[r.name]) continue;
    std::vector<std::string> group;
    for (const auto& [name, frame] : routeFramesInMap(map, r.name)) {
      group.push_back(name);
      grouped[name] = true;
    }
    audit.groups.push_back(group);
  }
  if (audit.groups.size() > 1) {
    std::string text;
    for (const auto& group : audit.groups) {
      text += text.empty() ? "" : " | ";
      for (std::size_t i = 0; i < group.size(); ++i) text += (i ? ", " : "") + group[i];
    }
    audit.notes.push_back(std::to_string(audit.groups.size()) + " groups of routes that no junction joins (" + text +
                          "): no way leads from one to another; add a junction (route_map junction)");
  }
  if (audit.weak_junctions > 0) {
    audit.notes.push_back(std::to_string(audit.weak_junctions) +
                          " junctions too weak to relocalize across: teach the two routes' meeting again with "
                          "more overlap, or measure the junction where their views share more");
  }
  return audit;
}

}  // namespace homography_teach_repeat
