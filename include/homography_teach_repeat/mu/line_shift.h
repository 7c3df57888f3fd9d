// μ from vertical lines across seasons: the horizontal image shift at the principal point between
// a reference view and a current view of the same place, measured on their vertical lines alone
// (docs/math.md §4.10, docs/evaluation.md "Heading across seasons").
//
// The μ mode's line matching (features/vertical_line_matcher.h) compares lines by their sides'
// brightness and polarity; between seasons neither holds, and its extractor's absolute
// thresholds find few lines in real photographs (7 per GRIEF michigan image). Here:
//  - the lines are extracted with tolerances for real edges (a gradient threshold relative to the
//    image's contrast, links across gaps and a minimum length that scale with the image height, a
//    fit RMS of 1.5 px): the short, rough verticals of trunks, posts and frames, about 150 per
//    1024x384 image;
//  - each line is described by BRIEF (features/brief.h: intensity comparisons, upright) at points
//    every `point_spacing_px` along it: a line descriptor that survives light and seasons
//    and does not depend on polarity;
//  - the points are matched by mutual nearest neighbours and vote with their line's x (undistorted,
//    at the principal point's row) on the shift (mu/image_shift.h, the vote ShiftHeading uses).
// A line seen in both views moves by the shift; a wrong match scatters. On GRIEF michigan /
// planetarium (330 pairs each, 35 px tolerance) it fails 3.3 % / 10.9 % of the pairs, with an
// estimate on every michigan pair (docs/evaluation.md).
#pragma once

#include <opencv2/core.hpp>

#include <optional>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/features/vertical_lines.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/mu/shift_heading.h"

namespace homography_teach_repeat {

struct LineShiftOptions {
  // The extraction's tolerances (min_length_px and max_row_gap are replaced by the fractions below).
  VerticalLineOptions lines = seasonalLineOptions();
  // A line's shortest length (at least 3 rows) and the rows without an edge pixel it may bridge, as
  // fractions of the image height (0.02: 8 rows of a 384-row image, 10 of 480).
  double min_length_fraction = 0.02;
  double max_row_gap_fraction = 0.02;
  double point_spacing_px = 4.0;  // between the described points along a line [px, >= 1]
  // The vote, without its chance test: a line's points match and move together, so they are not
  // the independent matches that test counts (with it, GRIEF michigan / planetarium fail 8.5 /
  // 21.2 % instead of 3.3 / 10.9 %, mostly 8-15 points of one or two lines refused).
  ImageShiftOptions vote = voteWithoutChanceTest();
  // As ShiftHeadingOptions: the floor of μ's variance [px², > 0] and the runner-up's share of the
  // winner's support from which a fix is ambiguous (0, 1].
  double min_variance_px2 = 4.0;
  double ambiguity_ratio = 0.6;

  static VerticalLineOptions seasonalLineOptions();
  static ImageShiftOptions voteWithoutChanceTest();
  void validate() const;  // throws std::invalid_argument naming the bad field
};

// The vertical lines of one view and their described points (BRIEF; each keypoint's class_id is
// its line's index, its x the line's x).
struct LineShiftFeatures {
  std::vector<VerticalLine> lines;
  ImageFeatures points;
  cv::Size image_size;
};

class LineShift {
 public:
  // Throws std::invalid_argument on invalid options.
  explicit LineShift(const LineShiftOptions& options = LineShiftOptions());

  // `camera` (optional): undistorts the lines (VerticalLineExtractor::extract). Status: the
  // extractor's (kInvalidInput for an empty or unsupported image, a camera of another size). An
  // image without vertical structure gives OK features without lines.
  Expected<LineShiftFeatures> describe(const cv::Mat& image, const PinholeCamera* camera = nullptr);
  // As ShiftHeading::measure: `principal_x` [px] where the shift is taken, `focal_px` (fx) for a
  // vote on angles. Status: kInvalidInput (views of different sizes, a non-finite principal_x, a
  // focal length <= 0), kTooFewPoints / kNoConsensus (the vote's: too few line points matched or
  // agreeing).
  Expected<ShiftHeadingFix> measure(const LineShiftFeatures& reference, const LineShiftFeatures& current,
                                    double principal_x, std::optional<double> focal_px = std::nullopt) const;

  const LineShiftOptions& options() const { return options_; }

 private:
  LineShiftOptions options_;
  cv::Ptr<cv::Feature2D> brief_;
  std::optional<VerticalLineExtractor> extractor_;  // for images of extractor_rows_ rows
  int extractor_rows_ = -1;
};

}  // namespace homography_teach_repeat
