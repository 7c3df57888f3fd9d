// The heading fix that holds across seasons (docs/math.md §4.10, docs/evaluation.md "Heading across
// seasons"): upright AKAZE and BRIEF features of a reference view and of the current view, each
// type matched by mutual nearest neighbours, and one vote on the horizontal image shift at the
// principal point (mu/image_shift.h). The shift is μ of the 1D homography (docs/math.md §4.5):
// the heading plus the coupling to a lateral offset, for the localization filter's μ model.
// On the GRIEF seasonal benchmark it fails 2.4 % (campus) and 0.6 % (park) of 330 pairs each.
#pragma once

#include <opencv2/core.hpp>

#include <optional>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/mu/image_shift.h"

namespace homography_teach_repeat {

struct ShiftHeadingOptions {
  // The feature types that vote together (each matched within its own type). Default: upright
  // AKAZE and BRIEF, 1600 of each per image.
  std::vector<FeatureOptions> features = defaultFeatures();
  ImageShiftOptions vote;
  // [px²] The variance of μ is the vote's standard error squared plus this (> 0): the parallax of
  // the scene's depths that the vote averages (docs/math.md §4.10) and the matches' shared error.
  double min_variance_px2 = 4.0;
  // A fix is `ambiguous` when a second shift has at least this share of the winner's support
  // (repeated structure, a near object's parallax): on the GRIEF benchmark every wrong fix was
  // (10 of 10, both sites) and 47 of 650 right ones (docs/evaluation.md). The caller decides
  // (e.g. take it only where the odometry predicts it). In (0, 1].
  double ambiguity_ratio = 0.6;

  static std::vector<FeatureOptions> defaultFeatures();
  void validate() const;  // throws std::invalid_argument naming the bad field
};

// The features of one view, one set per feature type of the options.
struct ShiftFeatures {
  std::vector<ImageFeatures> sets;
  cv::Size image_size;
};

struct ShiftHeadingFix {
  double mu = 0.0;        // current x − reference x at the principal point [px]
  double variance = 0.0;  // [px²]
  ImageShift shift;       // the vote (support, runner-up, scale)
  int matches = 0;        // mutual nearest matches of all types
  bool ambiguous = false; // shift.runner_up_support >= ambiguity_ratio · shift.support

  // Whether a prediction of μ [px] (e.g. the localization filter's) picks this fix: always for an
  // unambiguous one; for an ambiguous one when the prediction is at most half as far from `mu` as
  // from the runner-up's shift (shift.runner_up_shift_px). False for a non-finite prediction.
  bool pickedBy(double predicted_mu) const;
};

// What makes a vote a fix: the floor of μ's variance [px²] and the runner-up's share of the
// winner's support from which it is ambiguous (ShiftHeadingOptions', LineShiftOptions').
struct ShiftFixRules {
  double min_variance_px2 = 4.0;
  double ambiguity_ratio = 0.6;
};

// The vote of `matches` (reference -> current pixels of two views `size` wide and high) as a fix:
// μ the vote's shift at `principal_x` (on angles with `focal_px`, estimateImageShift), its variance
// the vote's standard error squared plus rules.min_variance_px2, ambiguous from rules.ambiguity_ratio.
// The vote's status when it has none. ShiftHeading and LineShift (line_shift.h) both end here.
Expected<ShiftHeadingFix> shiftFixFromMatches(const PointMatches& matches, const cv::Size& size,
                                              const ImageShiftOptions& vote, const ShiftFixRules& rules,
                                              double principal_x, std::optional<double> focal_px);
// kInvalidInput naming both sizes when two views differ in size, OK otherwise.
Status requireSameSize(const cv::Size& reference, const cv::Size& current);

class ShiftHeading {
 public:
  // Throws std::invalid_argument on invalid options (an unavailable feature type included).
  explicit ShiftHeading(const ShiftHeadingOptions& options = ShiftHeadingOptions());

  // Status: the extractor's (kInvalidInput for an empty or unsupported image).
  Expected<ShiftFeatures> describe(const cv::Mat& image);
  // `principal_x` [px]: where the shift is taken (the camera's cx; the image's middle without a
  // calibration); `focal_px`: the camera's fx, when known (the vote then runs on angles,
  // estimateImageShift). Status: kInvalidInput (views of different sizes or feature sets, a
  // non-finite principal_x, a focal length <= 0), otherwise the vote's (kTooFewPoints, kNoConsensus).
  Expected<ShiftHeadingFix> measure(const ShiftFeatures& reference, const ShiftFeatures& current,
                                    double principal_x, std::optional<double> focal_px = std::nullopt) const;

  const ShiftHeadingOptions& options() const { return options_; }

 private:
  ShiftHeadingOptions options_;
  std::vector<FeatureExtractor> extractors_;
};

}  // namespace homography_teach_repeat
