#include "homography_teach_repeat/image_registration.h"

#include <cmath>
#include <stdexcept>

namespace homography_teach_repeat {

void RegistrationOptions::validate() const {
  features.validate();
  matching.validate();
  robust.validate();
}

ImageRegistration::ImageRegistration(const RegistrationOptions& options)
    : options_(options), extractor_(options.features) {
  options_.validate();
}

Status ImageRegistration::setReference(const cv::Mat& image) {
  auto features = extractor_.extract(image);
  if (!features) {
    return Status(features.status().code(), "reference image: " + features.status().message());
  }
  if (features->keypoints.size() < 4) {
    return Status(StatusCode::kTooFewPoints,
                  "reference image has only " + std::to_string(features->keypoints.size()) +
                      " features");
  }
  reference_ = std::move(features.value());
  return Status::ok();
}

const ImageFeatures& ImageRegistration::referenceFeatures() const {
  if (!reference_) throw std::logic_error("ImageRegistration: no reference image set");
  return *reference_;
}

Expected<RegistrationResult> ImageRegistration::registerImage(const cv::Mat& image,
                                                              const PinholeCamera* camera) {
  if (!reference_) return Status(StatusCode::kInvalidInput, "no reference image set");
  const auto current = extractor_.extract(image);
  if (!current) return current.status();
  const auto matches = matchFeatures(*reference_, *current, options_.matching);
  if (!matches) return matches.status();

  RegistrationResult result;
  result.reference_features = static_cast<int>(reference_->keypoints.size());
  result.current_features = static_cast<int>(current->keypoints.size());
  result.matches = toPointMatches(*reference_, *current, *matches);
  if (camera != nullptr && camera->hasDistortion()) {
    PointMatches undistorted;
    undistorted.reserve(result.matches.size());
    for (const auto& match : result.matches) {
      const cv::Point2d r =
          camera->undistortPixel(cv::Point2d(match.reference.x(), match.reference.y()));
      const cv::Point2d c =
          camera->undistortPixel(cv::Point2d(match.current.x(), match.current.y()));
      // Points outside the lens model's valid region undistort to NaN: drop them.
      if (std::isfinite(r.x + r.y + c.x + c.y)) {
        undistorted.push_back({Eigen::Vector2d(r.x, r.y), Eigen::Vector2d(c.x, c.y)});
      }
    }
    result.matches = std::move(undistorted);
  }
  if (result.matches.size() < 4) {
    return Status(StatusCode::kTooFewPoints,
                  std::to_string(result.matches.size()) + " tentative matches (" +
                      std::to_string(result.current_features) + " features in the image)");
  }
  auto homography = estimateHomographyRobust(result.matches, options_.robust);
  if (!homography) return homography.status();
  result.homography = std::move(homography.value());
  return result;
}

}  // namespace homography_teach_repeat
