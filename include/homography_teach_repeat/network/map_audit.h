// The audit of a map of routes (docs/route_audit.md, "A map of routes"): whether the repeat can
// cross each junction and which routes can reach which. A junction is crossed by localizing
// against the other route's keyframes where they meet: the overlap of the two keyframes' views is
// measured again from their stored features (junction_measurement.h), and a junction whose
// measurement fails, rests on few inliers, is uncertain, or disagrees with the pose the map stores
// is named weak (too weak to relocalize across).
#pragma once

#include <Eigen/Core>

#include <string>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/network/route_map.h"
#include "homography_teach_repeat/teach_repeat/repeat_estimate.h"

namespace homography_teach_repeat {

struct MapAuditOptions {
  int min_inliers = 40;                   // fewer: weak (a repeat fix needs RepeatOptions::min_inliers)
  double max_position_sigma_m = 0.05;     // larger (either axis): weak
  double max_heading_sigma_rad = 0.0175;  // larger: weak (1°)
  double max_disagreement_m = 0.10;       // measured again, further from the stored pose: weak
  double max_disagreement_rad = 0.035;    // (2°)
};

struct JunctionAudit {
  Junction stored;
  bool measured = false;
  std::string problem;                    // why it could not be measured (when !measured)
  Pose2D measured_to_in_from;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  int inliers = 0;
  double disagreement_m = 0.0;            // measured against stored
  double disagreement_rad = 0.0;
  std::vector<std::string> weaknesses;    // empty: strong enough to relocalize across
};

struct MapAudit {
  std::vector<JunctionAudit> junctions;
  // Routes joined to each other by junctions (directly or through others); more than one group:
  // no way leads from one group to another.
  std::vector<std::vector<std::string>> groups;
  int weak_junctions = 0;
  std::vector<std::string> notes;
};

// kInvalidInput for bad options. A junction that cannot be measured is weak, not an error.
Expected<MapAudit> auditMap(const RouteMap& map, const RepeatOptions& repeat, const MapAuditOptions& options = {});

}  // namespace homography_teach_repeat
