// Vertical line segments of an image (paper 002 §2): near-vertical edges with sub-pixel x,
// length, polarity (which side is dark; the two polarities never match each other) and the mean
// brightness on both sides; the x used by the 1D homography is taken after correcting the
// endpoints for lens distortion.
//
// A dedicated extractor instead of a general segment detector (cv::LineSegmentDetector takes
// ~28 ms on 640x480 here): only vertical structure matters, so
//  1. the horizontal and vertical gradients come from cv::Sobel (3x3, 16-bit, vectorised);
//  2. per row, edge pixels are the local maxima of |gx| along x above `min_gradient` (or a share
//     of the image's mean |gx|, `min_gradient_fraction`, where that is higher) whose
//     gradient direction is within `max_angle_deg` of horizontal (|gy| <= tan(tol) |gx|), with
//     the sub-pixel x from a parabola through |gx| at x-1, x, x+1;
//  3. edge pixels are linked down the columns: a pixel continues the chain of the same polarity
//     that ended in the previous `max_row_gap` + 1 rows within `max_step_px` in x;
//  4. chains of at least `min_length_px` rows get a least-squares line x = a + b y, kept when
//     |b| <= tan(max_angle_deg) and the RMS residual is below `max_fit_rms_px`. With a lens
//     model the chain points are undistorted first (radial distortion bends long lines), so the
//     fit, the endpoints and x are in undistorted pixels.
// The x of a line is its undistorted x at the principal-point row cy (a vertical 3D line seen by
// a level camera is the image line x = const).
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <vector>

#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

// kDarkLeft: dark on the left, bright on the right (gx > 0); kDarkRight: the opposite.
enum class EdgePolarity { kDarkLeft, kDarkRight };

struct VerticalLine {
  double x = 0.0;                  // undistorted x at row cy [px] (the 1D homography's coordinate)
  Eigen::Vector2d top = Eigen::Vector2d::Zero();  // first/last edge pixel, distorted image [px]
  Eigen::Vector2d bottom = Eigen::Vector2d::Zero();
  Eigen::Vector2d top_undistorted = Eigen::Vector2d::Zero();  // ends of the fitted line
  Eigen::Vector2d bottom_undistorted = Eigen::Vector2d::Zero();
  double length = 0.0;             // [px], distorted image
  EdgePolarity polarity = EdgePolarity::kDarkLeft;
  double left_brightness = 0.0;    // mean grey level a few pixels left / right of the edge
  double right_brightness = 0.0;
  double contrast = 0.0;           // mean |gx| along the line (Sobel units)
};

struct VerticalLineOptions {
  double max_angle_deg = 5.0;    // angular tolerance around vertical
  // The shortest line kept [rows]: min_length_px where it is > 0 (at least 3), otherwise
  // min_length_fraction of the image's height (rounded, at least 3 rows), so that it scales with the
  // image: 25 rows of the simulator's 480, 20 of KITTI 07's 376, 10 at half that size
  // (docs/evaluation.md, "KITTI 07": 25 rows there lost 5 of 120 frames in mu, at half size 24).
  int min_length_px = 0;
  double min_length_fraction = 0.0521;  // (0, 1]
  int minLengthFor(int image_rows) const;
  double min_gradient = 40.0;    // |gx| threshold (3x3 Sobel on 8-bit: a step of 10 grey ~ 40)
  // Relative to the image's contrast: the threshold is max(min_gradient, this x the image's mean
  // |gx|), so a dim or hazy view keeps its lines and a sharp one is not flooded [0: min_gradient alone].
  double min_gradient_fraction = 0.0;
  double max_step_px = 1.0;      // largest x jump between linked rows
  int max_row_gap = 1;           // rows without an edge pixel that a chain may bridge
  double max_fit_rms_px = 0.7;   // largest RMS residual of the line fit
  int brightness_offset_px = 3;  // distance of the brightness samples from the edge

  void validate() const;  // throws std::invalid_argument naming the bad field
};

class VerticalLineExtractor {
 public:
  explicit VerticalLineExtractor(const VerticalLineOptions& options = {});

  // `camera` (optional) undistorts the endpoints and gives cy; without it x is taken at the image
  // centre row with no distortion correction. Accepts 8-bit grey or BGR/BGRA. Status:
  // kInvalidInput (empty image, another pixel type, camera size different from the image). An
  // image without vertical structure gives an OK empty list.
  Expected<std::vector<VerticalLine>> extract(const cv::Mat& image,
                                              const PinholeCamera* camera = nullptr);

  const VerticalLineOptions& options() const { return options_; }

 private:
  VerticalLineOptions options_;
  // Work buffers kept between calls (no reallocation per frame).
  cv::Mat gray_, gx_, gy_;
};

}  // namespace homography_teach_repeat
