// camera_info of the synthetic camera of the core tests (test/support/synthetic_route.h).
#pragma once

#include <sensor_msgs/CameraInfo.h>

#include "support/synthetic_route.h"
#include "node_test_helpers.h"

namespace homography_teach_repeat {
namespace test_support {

inline sensor_msgs::CameraInfo syntheticCameraInfo() {
  const CameraCalibration c = syntheticCalibration();
  sensor_msgs::CameraInfo info = makeCameraInfo(c.width, c.height, c.fx);
  info.K[2] = c.cx;
  info.K[5] = c.cy;
  info.P[2] = c.cx;
  info.P[6] = c.cy;
  return info;
}

}  // namespace test_support
}  // namespace homography_teach_repeat
