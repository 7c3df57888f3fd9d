#include "homography_teach_repeat/geometry/camera_tilt.h"

#include <cmath>

namespace homography_teach_repeat {
namespace {

Eigen::Matrix3d rotationX(double a) {
  Eigen::Matrix3d r;
  r << 1.0, 0.0, 0.0, 0.0, std::cos(a), -std::sin(a), 0.0, std::sin(a), std::cos(a);
  return r;
}
Eigen::Matrix3d rotationZ(double a) {
  Eigen::Matrix3d r;
  r << std::cos(a), -std::sin(a), 0.0, std::sin(a), std::cos(a), 0.0, 0.0, 0.0, 1.0;
  return r;
}
Eigen::Matrix3d rotationXDerivative(double a) {
  Eigen::Matrix3d r;
  r << 0.0, 0.0, 0.0, 0.0, -std::sin(a), -std::cos(a), 0.0, std::cos(a), -std::sin(a);
  return r;
}
Eigen::Matrix3d rotationZDerivative(double a) {
  Eigen::Matrix3d r;
  r << -std::sin(a), -std::cos(a), 0.0, std::cos(a), -std::sin(a), 0.0, 0.0, 0.0, 0.0;
  return r;
}

}  // namespace

CameraTilt cameraTilt(double pitch, double roll) {
  const Eigen::Matrix3d Rx = rotationX(pitch);
  const Eigen::Matrix3d Rz = rotationZ(roll);
  return CameraTilt{Rx * Rz, rotationXDerivative(pitch) * Rz, Rx * rotationZDerivative(roll)};
}

}  // namespace homography_teach_repeat
