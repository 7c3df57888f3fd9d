// teach_node's parameters (config/teach_node.yaml documents each).
#pragma once

#include <ros/node_handle.h>

#include "homography_teach_repeat/teach_repeat/route_audit.h"
#include "homography_teach_repeat/teach_repeat/teach_session.h"

namespace homography_teach_repeat {

// Throws std::runtime_error naming the bad parameter, or a route_directory that cannot be written.
// `into_map`: the route goes into a map (map_directory), which chooses its folder; route_directory
// is then not read.
TeachOptions readTeachOptions(const ros::NodeHandle& nh, bool into_map);
// The thresholds of the teach node's warnings (the rest of the audit keeps its defaults).
RouteAuditOptions readAuditOptions(const ros::NodeHandle& nh);

}  // namespace homography_teach_repeat
