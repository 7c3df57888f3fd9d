// Vertical lines as landmarks with their own depth (docs/math.md §4.8-4.9). μ = h12/h22 models the lines
// of one wall; on a street the lines stand at 2-60 m on both sides, and between a keyframe and a
// frame 1 m from it a line on a facade 5 m to the side moves 40 px that no single 1D homography
// explains. Here each keyframe line is triangulated from the keyframe and its taught neighbours
// (known odometry motion), verified in a third view, and a repeat image's lines are then each a
// bearing measurement of the robot pose: the μ mode's filter takes them all in one update
// (LocalizationFilter::correctWithLineLandmarks).
//
// Conventions (docs/math.md §4.1): top view (x, z) of a camera frame, x right, z forward; a view's
// camera pose is a PlanarPose in the keyframe camera frame; image x = x0 + f X/Z (undistorted, at
// the principal row: VerticalLine::x).
#pragma once

#include <Eigen/Core>

#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/features/vertical_lines.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/mu/heading_1d.h"

namespace homography_teach_repeat {

struct LineLandmarkOptions {
  double pixel_sigma_px = 1.0;        // of a line's x (the fit, the row at which x is taken, the tilt)
  double max_reprojection_px = 2.0;   // every view of a landmark within this of its projection
  double min_depth_m = 1.0;           // in front of every view that sees it, nearer than max_depth_m
  double max_depth_m = 80.0;
  double max_brightness_difference = 40.0;  // grey levels, left and right of the edge alike
  int min_views = 3;                  // >= 3: a pair of bearings always intersects, a third checks it
  // The landmark's position must be known to this [m] (the larger axis of its 1σ ellipse, relative
  // to its depth): a line at the focus of expansion has no parallax and no depth.
  double max_relative_sigma = 0.5;

  void validate() const;  // throws std::invalid_argument naming the bad field
};

// A keyframe line with its position in the keyframe camera frame.
struct LineLandmark {
  int line = -1;                                    // index into the keyframe's lines
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  // (x, z) [m]
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();  // of `position` [m²]
  int views = 0;                                    // views that saw it (the keyframe's included)
  double rms_px = 0.0;                              // reprojection RMS over those views
};

// A view of the same place: its camera in the keyframe camera frame and its lines.
struct LineView {
  PlanarPose camera;
  const std::vector<VerticalLine>* lines = nullptr;
};

// The image x [px] of a landmark at `position` (keyframe camera frame) seen by a camera at
// `camera` (keyframe camera frame). kDegenerate when it is less than 0.1 m in front of the camera.
Expected<double> projectLineLandmark(const PlanarPose& camera, const Eigen::Vector2d& position, const LineCamera& lens);

// Triangulates the keyframe's `lines` with the `others` views (docs/math.md §4.8): for each line, the
// lines of the same polarity and brightness in a neighbour view whose rays meet between
// min_depth_m and max_depth_m are candidates; a candidate needs lines at its projection in further
// views (min_views in all); a line with two such candidates that disagree is ambiguous (a row of
// windows) and left out. The position is refined over all its views (Gauss-Newton on the image x)
// and its covariance is pixel_sigma_px² (JᵀJ)⁻¹. kInvalidInput for a bad camera, a null view or a
// non-finite pose.
Expected<std::vector<LineLandmark>> triangulateLineLandmarks(const std::vector<VerticalLine>& lines,
                                                             const std::vector<LineView>& others,
                                                             const LineCamera& lens,
                                                             const LineLandmarkOptions& options = {});

// Whether two lines may be the same edge seen twice: same polarity, brightness on both sides within
// `max_difference` grey levels.
bool lineAppearanceAgrees(const VerticalLine& a, const VerticalLine& b, double max_difference);

// The lines of a reference keyframe with their positions, and a current image's lines.
struct LineLandmarkObservation {
  Pose2D reference_pose;         // route-frame base pose of the reference keyframe
  Pose2D camera_mount;           // camera forward frame in base_link (x, y, yaw)
  LineCamera lens;               // focal length and principal point along x [px]
  double image_width = 0.0;      // [px]; landmarks projecting outside [0, width) are not looked for
  std::vector<LineLandmark> landmarks;        // in the reference camera frame
  std::vector<VerticalLine> reference_lines;  // what landmarks[i].line indexes
  std::vector<VerticalLine> current_lines;
};

}  // namespace homography_teach_repeat
