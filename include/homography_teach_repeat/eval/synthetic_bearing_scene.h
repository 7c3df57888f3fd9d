// Synthetic three-view bearing data for the 1D trifocal tensor (tests, eval_trifocal, bench):
// landmarks in the top view seen by 1D pinhole cameras (paper 003 §V.A: 53° field of view,
// 1024 px), Gaussian pixel noise, outliers. Frames and conventions of trifocal_motion.h.
#pragma once

#include <Eigen/Core>

#include <cmath>
#include <random>
#include <vector>

#include "homography_teach_repeat/trifocal/trifocal_motion.h"
#include "homography_teach_repeat/trifocal/trifocal_tensor_1d.h"

namespace homography_teach_repeat {

// A 1D pinhole camera: column x = f X/Z + u0 for |x − u0| < width/2 and Z > 0.
struct LineCamera1d {
  double focal_px = 512.0 / std::tan(26.5 * M_PI / 180.0);  // 53° over 1024 px
  double principal_px = 512.0;
  double width_px = 1024.0;

  static LineCamera1d withFieldOfView(double fov_rad, double width_px);
  // False when the landmark (camera frame) is behind the camera or outside the image.
  bool project(const Eigen::Vector2d& camera_point, double* x_px) const;
  Bearing bearing(double x_px) const { return bearingFromPixel(x_px, focal_px, principal_px); }
};

// Views 2 and 3 given by their camera centres (frame of view 1) and headings θ (> 0: turned left,
// towards −X): t = −R(θ) c.
TrifocalMotion motionFromCentres(const Eigen::Vector2d& centre_second, double theta_second,
                                 const Eigen::Vector2d& centre_third, double theta_third);

// The two movements of the paper's simulations (its Fig. 2 is not in the text; these are our
// reconstruction of the described scenarios, in units of the landmark field):
//  - MovA, "a common multi-robot configuration": three robots side by side 2 units apart, the
//    outer ones converging towards the common field (views 2 and 3 at x = −2 and +2, z = 1,
//    turned by +/-0.15 rad);
//  - MovB, "a mobile robot going forward": views 2 and 3 at 1.5 and 3 units ahead with a small
//    sideways drift and heading change.
TrifocalMotion movementA();
TrifocalMotion movementB();

struct BearingSceneOptions {
  double noise_px = 0.0;        // σ of the Gaussian noise on each view's column
  double depth_min = 8.0;       // landmarks from this depth ...
  double depth_max = 25.0;      // ... to this one (view 1's Z), spread across view 1's field
  int max_attempts = 100000;    // landmark draws before giving up (nothing visible)
};

struct BearingScene {
  std::vector<Eigen::Vector2d> landmarks;  // frame of view 1
  std::vector<BearingTriplet> triplets;    // noisy, calibrated
};

// `count` random landmarks visible in the three views of `motion`.
BearingScene randomBearingScene(const TrifocalMotion& motion, const LineCamera1d& camera, int count,
                                const BearingSceneOptions& options, std::mt19937& rng);
// `count` landmarks on the line Z = depth of view 1 (a wall parallel to the first image plane),
// visible in the three views.
BearingScene planeBearingScene(const TrifocalMotion& motion, const LineCamera1d& camera, int count, double depth,
                               const BearingSceneOptions& options, std::mt19937& rng);
// Replaces the second and third bearings of a `fraction` of the triplets by random visible ones
// (wrong matches); returns the indices of the replaced triplets.
std::vector<int> corruptTriplets(std::vector<BearingTriplet>& triplets, double fraction, const LineCamera1d& camera,
                                 std::mt19937& rng);

}  // namespace homography_teach_repeat
