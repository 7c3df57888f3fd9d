// controller_node's parameters (config/controller_node.yaml documents each); its dynamic_reconfigure
// tunables (cfg/Controller.cfg) are applied by ControllerNode::onReconfigure, in the same source.
#pragma once

#include <ros/node_handle.h>

#include "homography_teach_repeat/control/route_follower.h"

namespace homography_teach_repeat {

// The route follower's options from the node's private parameters. Throws std::runtime_error
// naming the bad parameter.
RouteFollowerOptions readRouteFollowerOptions(const ros::NodeHandle& nh);

}  // namespace homography_teach_repeat
