#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "homography_teach_repeat/geometry/scene_plane.h"

using namespace homography_teach_repeat;

namespace {
// A wall 4 m ahead, turned 0.6 rad about the vertical: seen obliquely, its point nearest the camera
// lies well to the side of where the camera sees it.
ScenePlane obliqueWall() {
  ScenePlane plane;
  plane.normal = Eigen::Vector3d(std::sin(0.6), 0.0, std::cos(0.6));
  plane.distance = 4.0;
  return plane;
}
}  // namespace

// centroidOnPlane (docs/math.md §3.6): the mean of the points where the rays meet the plane; rays
// that meet it behind the camera, run parallel to it or are not finite are left out.
TEST(ScenePlane, TheCentroidIsTheMeanOfTheRaysPointsOnThePlane) {
  const ScenePlane plane = obliqueWall();
  const std::vector<Eigen::Vector3d> points{{-1.0, 0.5, 0.0}, {0.5, -0.5, 0.0}, {1.0, 0.2, 0.0}};
  std::vector<Eigen::Vector3d> rays;
  Eigen::Vector3d expected = Eigen::Vector3d::Zero();
  for (Eigen::Vector3d point : points) {
    // On the plane: solve for z.
    point.z() = (plane.distance - plane.normal.x() * point.x() - plane.normal.y() * point.y()) / plane.normal.z();
    expected += point / 3.0;
    rays.push_back(point * 0.37);  // any length
  }
  rays.push_back(-rays.front());                                      // behind the camera
  rays.emplace_back(plane.normal.z(), 0.0, -plane.normal.x());        // parallel to the plane
  rays.emplace_back(std::nan(""), 0.0, 1.0);                          // not finite
  const auto centroid = centroidOnPlane(plane, rays);
  ASSERT_TRUE(centroid.has_value());
  EXPECT_LT((*centroid - expected).norm(), 1e-12);
  EXPECT_NEAR(plane.normal.dot(*centroid), plane.distance, 1e-12);
  EXPECT_FALSE(centroidOnPlane(plane, {}).has_value());
  EXPECT_FALSE(centroidOnPlane(plane, {Eigen::Vector3d(0.0, 0.0, -1.0)}).has_value());
}

// turnedAbout: the normal turned (normalised), the pivot stays on the plane; about the point
// nearest the camera the distance does not change, about a point off to the side it does.
TEST(ScenePlane, APlaneTurnedAboutAPointKeepsThatPointOnIt) {
  const ScenePlane plane = obliqueWall();
  const Eigen::Vector3d turned_normal = Eigen::Vector3d(std::sin(0.7), 0.0, std::cos(0.7)) * 3.0;
  const Eigen::Vector3d ahead = plane.distance / plane.normal.z() * Eigen::Vector3d::UnitZ();  // on the axis
  const ScenePlane about_ahead = turnedAbout(plane, turned_normal, ahead);
  EXPECT_NEAR(about_ahead.normal.norm(), 1.0, 1e-12);
  EXPECT_NEAR(about_ahead.normal.dot(ahead), about_ahead.distance, 1e-12);
  const ScenePlane about_nearest = turnedAbout(plane, turned_normal, plane.distance * plane.normal);
  EXPECT_NEAR(about_nearest.distance, plane.distance * std::cos(0.1), 1e-12);
  EXPECT_GT(std::abs(about_ahead.distance - about_nearest.distance), 0.1);
}
