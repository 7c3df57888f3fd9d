// The horizontal shift at the image centre between a reference image and a current image of the
// same place, from point matches by a vote: the heading correction a teach-and-repeat robot steers by, in pixels,
// the quantity μ of the 1D homography (docs/math.md §4.10). Under planar motion a point at depth Z
// moves by f tanθ + f t_x/Z (+ terms in x); the distant scene agrees on one shift, wrong matches
// and near objects scatter. The vote takes the window of the image's x differences that holds
// the most matches (RAS 2017's histogram vote without its bin edges): a handful of agreeing
// matches suffices where a homography needs 8 with a consensus, which is what holds across
// seasons (docs/evaluation.md, "Heading across seasons").
#pragma once

#include <cmath>
#include <optional>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/geometry/point_match.h"

namespace homography_teach_repeat {

struct ImageShiftOptions {
  // Width of the vote's window, as a fraction of the image width (0.035: 35 px at 1024 px, the
  // benchmark's tolerance; about 1° of heading for a 30° field of view).
  double window_fraction = 0.035;
  // Matches whose y differ by more than this fraction of the image width are dropped (a robot's
  // camera does not move vertically; a seasonal match that does is wrong).
  double vertical_limit_fraction = 0.1;
  // Fewer matches in the winning window: kNoConsensus.
  int min_support = 5;
  // A robot standing ahead of or behind the taught spot sees the scene scaled about the image
  // centre, which spreads the x differences by (s − 1) x: the vote also searches scales s within
  // 1 ± this (in steps of 2 %) and the shift is taken at the image centre. 0: shifts only.
  double max_scale_change = 0.1;
  // Matches of two views of different places agree by chance: their x differences spread over
  // the image, about n·window/width of the n matches in any one window (the most there). A winner
  // with a support that chance reaches with a probability above this (Poisson) is no consensus.
  // Two unrelated 640x480 views: 14 of 199 agreeing, p = 1e-2; the GRIEF seasonal pairs' right
  // fixes down to p = 1.5e-3 (ambiguous ones), all but 4 of 660 below 1e-6
  // (docs/evaluation.md, "Heading across seasons"). In (0, 1]; 1: no test.
  double max_chance_probability = 1e-6;

  void validate() const;  // throws std::invalid_argument naming the bad field
};

struct ImageShift {
  // current x − reference x at the image centre [px]: the mean of the winning window's x
  // differences (at the winning scale) within 3 robust σ (1.4826 MAD) of their median (wrong
  // matches that fall into the window are left out).
  double shift_px = 0.0;
  double scale = 1.0;      // the winning scale of the view about the image centre
  double spread_px = 0.0;  // standard deviation of those x differences [px]
  double sigma_px = 0.0;   // standard error of the shift: spread / √support [px]
  int support = 0;         // the matches the shift is the mean of
  // The most matches in a window whose centre is more than a window width from the winner's: a
  // value near `support` means two shifts compete (repeated structure, parallax of a near object).
  int runner_up_support = 0;
  double runner_up_shift_px = NAN;  // the median shift of that window (NaN: no runner-up)
  int matches = 0;         // matches within the vertical limit
  // The support expected by chance in one window (matches · window / the vote's range) and the
  // probability that chance reaches `support` there (Poisson upper tail).
  double chance_support = 0.0;
  double chance_probability = 1.0;
};

// P(X >= k) for X Poisson with mean `mean` (>= 0): 1 for k <= mean (never significant).
double poissonUpperTail(int k, double mean);

// `image_width` [px] scales the window and the vertical limit. The shift is taken at `centre_x`
// [px] (the principal point's x for a heading; default the image's middle, width / 2). With
// `focal_px` (the camera's fx) the vote runs on the matches' angles, f·atan(x/f), where a rotation
// shifts every point alike: without it a point x px from the centre moves by x²θ/f more than the
// centre (2 px of bias at 3° for 640 px and f = 512 px). Status: kInvalidInput (width <= 0, a
// non-finite centre or pixel, a focal length <= 0), kTooFewPoints (fewer than min_support matches
// within the vertical limit), kNoConsensus (no window with min_support matches, or a winner that
// chance explains: max_chance_probability).
Expected<ImageShift> estimateImageShift(const PointMatches& matches, int image_width,
                                        const ImageShiftOptions& options = ImageShiftOptions(),
                                        std::optional<double> centre_x = std::nullopt,
                                        std::optional<double> focal_px = std::nullopt);

}  // namespace homography_teach_repeat
