// The nodes as nodelets (zero-copy images when the camera driver runs in the same manager):
//   homography_teach_repeat/TeachNodelet, RepeatNodelet, ControllerNodelet, TrifocalLocalizerNodelet.
// Each wraps the same node class as the executable; callbacks run on the nodelet's single-threaded
// queue (getNodeHandle), like ros::spin in the executables.
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>
#include <stdexcept>

#include "homography_teach_repeat/ros/controller_node.h"
#include "homography_teach_repeat/ros/repeat_node.h"
#include "homography_teach_repeat/ros/teach_node.h"
#include "homography_teach_repeat/ros/trifocal_localizer_node.h"

namespace homography_teach_repeat {

template <class Node>
class NodeletOf : public nodelet::Nodelet {
 private:
  void onInit() override {
    try {
      node_ = std::make_unique<Node>(getNodeHandle(), getPrivateNodeHandle());
    } catch (const std::exception& e) {
      NODELET_FATAL("%s: %s", getName().c_str(), e.what());
      throw;  // the manager reports the failed load
    }
  }
  std::unique_ptr<Node> node_;
};

class TeachNodelet : public NodeletOf<TeachNode> {};
class RepeatNodelet : public NodeletOf<RepeatNode> {};
class ControllerNodelet : public NodeletOf<ControllerNode> {};
class TrifocalLocalizerNodelet : public NodeletOf<TrifocalLocalizerNode> {};

}  // namespace homography_teach_repeat

PLUGINLIB_EXPORT_CLASS(homography_teach_repeat::TeachNodelet, nodelet::Nodelet)
PLUGINLIB_EXPORT_CLASS(homography_teach_repeat::RepeatNodelet, nodelet::Nodelet)
PLUGINLIB_EXPORT_CLASS(homography_teach_repeat::ControllerNodelet, nodelet::Nodelet)
PLUGINLIB_EXPORT_CLASS(homography_teach_repeat::TrifocalLocalizerNodelet, nodelet::Nodelet)
