#include "homography_teach_repeat/homography/homography.h"
#include "homography_teach_repeat/homography/image_registration.h"

#include <opencv2/imgproc.hpp>

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
  reference_size_ = image.size();
  return Status::ok();
}

const ImageFeatures& ImageRegistration::referenceFeatures() const {
  if (!reference_) throw std::logic_error("ImageRegistration: no reference image set");
  return *reference_;
}

Expected<RegistrationResult> registerFeatures(const ImageFeatures& reference, const ImageFeatures& current,
                                              const MatchOptions& matching, const RobustHomographyOptions& robust,
                                              const PinholeCamera* camera) {
  const auto matches = matchFeatures(reference, current, matching);
  if (!matches) return matches.status();
  RegistrationResult result;
  result.reference_features = static_cast<int>(reference.keypoints.size());
  result.current_features = static_cast<int>(current.keypoints.size());
  result.matches = toPointMatches(reference, current, *matches);
  if (camera != nullptr) result.matches = undistortMatches(*camera, result.matches);
  if (result.matches.size() < 4) {
    return Status(StatusCode::kTooFewPoints, std::to_string(result.matches.size()) + " tentative matches (" +
                                                 std::to_string(result.current_features) + " features in the image)");
  }
  auto homography = estimateHomographyRobust(result.matches, robust);
  if (!homography) return homography.status();
  result.homography = std::move(homography.value());
  return result;
}

Expected<RegistrationResult> ImageRegistration::registerImage(const cv::Mat& image,
                                                              const PinholeCamera* camera) {
  if (!reference_) return Status(StatusCode::kInvalidInput, "no reference image set");
  const auto current = extractor_.extract(image);
  if (!current) return current.status();
  return registerFeatures(*reference_, *current, options_.matching, options_.robust, camera);
}

cv::Mat drawRegistration(const cv::Mat& current_image, const RegistrationResult& result,
                         const cv::Size& reference_size) {
  cv::Mat canvas;
  if (current_image.channels() == 1) {
    cv::cvtColor(current_image, canvas, cv::COLOR_GRAY2BGR);
  } else {
    canvas = current_image.clone();
  }
  const auto toPoint = [](const Eigen::Vector2d& p) { return cv::Point2d(p.x(), p.y()); };
  std::vector<bool> is_inlier(result.matches.size(), false);
  for (int i : result.homography.inliers) is_inlier[static_cast<std::size_t>(i)] = true;
  for (std::size_t i = 0; i < result.matches.size(); ++i) {
    const cv::Scalar colour = is_inlier[i] ? cv::Scalar(0, 200, 0) : cv::Scalar(0, 0, 220);
    cv::circle(canvas, toPoint(result.matches[i].current), 3, colour, 1, cv::LINE_AA);
  }
  const double w = reference_size.width - 1.0;
  const double h = reference_size.height - 1.0;
  std::vector<cv::Point> border;
  for (const Eigen::Vector2d& corner :
       {Eigen::Vector2d(0, 0), Eigen::Vector2d(w, 0), Eigen::Vector2d(w, h), Eigen::Vector2d(0, h)}) {
    const Eigen::Vector2d mapped = applyHomography(result.homography.H, corner);
    if (!mapped.allFinite() || mapped.cwiseAbs().maxCoeff() > 1e6) return canvas;
    border.emplace_back(cvRound(mapped.x()), cvRound(mapped.y()));
  }
  cv::polylines(canvas, border, true, cv::Scalar(255, 80, 0), 2, cv::LINE_AA);
  return canvas;
}

}  // namespace homography_teach_repeat
