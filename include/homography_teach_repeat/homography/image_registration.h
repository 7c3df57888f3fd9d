// Registration of current images against one reference image by a plane homography:
// features (feature_extractor.h) -> matches (feature_matcher.h) -> robust H (robust_homography.h).
// The reference features are computed once, when the reference is set.
#pragma once

#include <opencv2/core.hpp>

#include <optional>

#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/features/feature_matcher.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/homography/robust_homography.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

struct RegistrationOptions {
  FeatureOptions features;
  MatchOptions matching;
  RobustHomographyOptions robust;

  void validate() const;  // throws std::invalid_argument naming the bad field
};

struct RegistrationResult {
  RobustHomographyResult homography;  // maps reference pixels to current pixels
  PointMatches matches;  // all tentative matches, undistorted if a camera was given
                         // (homography.inliers indexes these)
  int reference_features = 0;
  int current_features = 0;
};

// The chain every registration uses, between two sets of features (of one camera): matches,
// undistorted by `camera` when it is given (undistortMatches: pixels that do not undistort drop
// their match), then the robust homography. kTooFewPoints below 4 matches; otherwise the matcher's
// or the robust estimator's status.
Expected<RegistrationResult> registerFeatures(const ImageFeatures& reference, const ImageFeatures& current,
                                              const MatchOptions& matching, const RobustHomographyOptions& robust,
                                              const PinholeCamera* camera);

class ImageRegistration {
 public:
  explicit ImageRegistration(const RegistrationOptions& options);

  // Computes and stores the reference features. On failure the previous reference is kept.
  Status setReference(const cv::Mat& image);
  bool hasReference() const { return reference_.has_value(); }
  const ImageFeatures& referenceFeatures() const;
  // Size of the reference image (for drawRegistration).
  cv::Size referenceSize() const { return reference_size_; }

  // Status kInvalidInput without a reference or for a bad image; kTooFewPoints when fewer than
  // 4 tentative matches; otherwise the robust estimator's status. With a `camera` that has lens
  // distortion, the matched points of both images (taken by the same camera) are undistorted
  // first, so H maps pixels of the ideal pinhole images.
  Expected<RegistrationResult> registerImage(const cv::Mat& image,
                                             const PinholeCamera* camera = nullptr);

 private:
  RegistrationOptions options_;
  FeatureExtractor extractor_;
  std::optional<ImageFeatures> reference_;
  cv::Size reference_size_;
};

// Visualisation of a registration on the current image (BGR copy): the border of the reference
// image mapped by H (blue), the inlier matches (green) and the rejected tentative matches (red).
// H maps undistorted pixels, so with a distorted camera the overlay is only approximate.
cv::Mat drawRegistration(const cv::Mat& current_image, const RegistrationResult& result,
                         const cv::Size& reference_size);

}  // namespace homography_teach_repeat
