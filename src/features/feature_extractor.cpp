#include "homography_teach_repeat/features/feature_extractor.h"

#include "homography_teach_repeat/features/brief.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <stdexcept>
#include <tuple>
#include <utility>

#ifdef HTR_HAVE_XFEATURES2D
#include <opencv2/xfeatures2d.hpp>
#endif

namespace homography_teach_repeat {
namespace {

cv::Ptr<cv::Feature2D> createDetector(FeatureType type, int max_features, bool upright = false) {
  switch (type) {
    case FeatureType::kSurf:
#ifdef HTR_HAVE_XFEATURES2D
      try {
        return cv::xfeatures2d::SURF::create();
      } catch (const cv::Exception&) {
        return nullptr;  // xfeatures2d without the non-free algorithms
      }
#else
      return nullptr;
#endif
    case FeatureType::kSift:
      return cv::SIFT::create(max_features);
    case FeatureType::kOrb:
      return cv::ORB::create(max_features);
    case FeatureType::kAkaze:
      return cv::AKAZE::create(upright ? cv::AKAZE::DESCRIPTOR_MLDB_UPRIGHT : cv::AKAZE::DESCRIPTOR_MLDB);
    case FeatureType::kBrief:
      return createAgastBrief(max_features);
  }
  return nullptr;
}

// SIFT gives one keypoint per dominant orientation at a location; with the orientation set to 0
// those are copies.
void makeUpright(std::vector<cv::KeyPoint>& keypoints) {
  for (cv::KeyPoint& keypoint : keypoints) keypoint.angle = 0.0F;
  const auto key = [](const cv::KeyPoint& k) { return std::make_tuple(k.pt.x, k.pt.y, k.size, k.octave); };
  std::sort(keypoints.begin(), keypoints.end(), [&](const cv::KeyPoint& a, const cv::KeyPoint& b) { return key(a) < key(b); });
  keypoints.erase(std::unique(keypoints.begin(), keypoints.end(),
                              [&](const cv::KeyPoint& a, const cv::KeyPoint& b) { return key(a) == key(b); }),
                  keypoints.end());
}

}  // namespace

std::string toString(FeatureType type) {
  switch (type) {
    case FeatureType::kSurf:
      return "surf";
    case FeatureType::kSift:
      return "sift";
    case FeatureType::kOrb:
      return "orb";
    case FeatureType::kAkaze:
      return "akaze";
    case FeatureType::kBrief:
      return "brief";
  }
  return "sift";
}

bool isFeatureTypeAvailable(FeatureType type) { return createDetector(type, 100) != nullptr; }

std::string availableFeatureTypes() {
  std::string names;
  for (FeatureType type :
       {FeatureType::kSurf, FeatureType::kSift, FeatureType::kOrb, FeatureType::kAkaze, FeatureType::kBrief}) {
    if (!isFeatureTypeAvailable(type)) continue;
    if (!names.empty()) names += ", ";
    names += toString(type);
  }
  return names;
}

FeatureType featureTypeFromString(const std::string& name) {
  FeatureType type;
  if (name == "surf") {
    type = FeatureType::kSurf;
  } else if (name == "sift") {
    type = FeatureType::kSift;
  } else if (name == "orb") {
    type = FeatureType::kOrb;
  } else if (name == "akaze") {
    type = FeatureType::kAkaze;
  } else if (name == "brief") {
    type = FeatureType::kBrief;
  } else {
    throw std::invalid_argument("unknown feature type '" + name +
                                "' (available: " + availableFeatureTypes() + ")");
  }
  if (!isFeatureTypeAvailable(type)) {
    throw std::invalid_argument("feature type '" + name +
                                "' is not available in this OpenCV build (it needs the non-free "
                                "xfeatures2d module); available: " +
                                availableFeatureTypes());
  }
  return type;
}

bool hasBinaryDescriptor(FeatureType type) {
  return type == FeatureType::kOrb || type == FeatureType::kAkaze || type == FeatureType::kBrief;
}

void FeatureOptions::validate() const {
  if (max_features < 1) throw std::invalid_argument("max_features must be >= 1");
  if (!isFeatureTypeAvailable(type)) {
    throw std::invalid_argument("feature type '" + toString(type) +
                                "' is not available; available: " + availableFeatureTypes());
  }
}

FeatureExtractor::FeatureExtractor(const FeatureOptions& options) : options_(options) {
  options_.validate();
  detector_ = createDetector(options_.type, options_.max_features, options_.upright);
}

Expected<cv::Mat> toGray8(const cv::Mat& image) {
  if (image.empty()) return Status(StatusCode::kInvalidInput, "empty image");
  if (image.depth() != CV_8U) {
    return Status(StatusCode::kInvalidInput,
                  "unsupported pixel depth " + std::to_string(image.depth()) +
                      " (8-bit images expected)");
  }
  cv::Mat gray;
  switch (image.channels()) {
    case 1:
      return image;
    case 3:
      cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
      return gray;
    case 4:
      cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
      return gray;
    default:
      return Status(StatusCode::kInvalidInput,
                    "unsupported channel count " + std::to_string(image.channels()));
  }
}

ImageFeatures selectFeatures(const ImageFeatures& features, const std::vector<int>& indices) {
  ImageFeatures kept;
  kept.type = features.type;
  kept.keypoints.reserve(indices.size());
  kept.descriptors.create(static_cast<int>(indices.size()), features.descriptors.cols, features.descriptors.type());
  for (std::size_t row = 0; row < indices.size(); ++row) {
    kept.keypoints.push_back(features.keypoints[static_cast<std::size_t>(indices[row])]);
    features.descriptors.row(indices[row]).copyTo(kept.descriptors.row(static_cast<int>(row)));
  }
  return kept;
}

Expected<ImageFeatures> FeatureExtractor::extract(const cv::Mat& image, const cv::Mat& mask) {
  const auto gray = toGray8(image);
  if (!gray) return gray.status();
  if (!mask.empty() && (mask.size() != image.size() || mask.type() != CV_8UC1)) {
    return Status(StatusCode::kInvalidInput, "the mask must be CV_8UC1 of the image size");
  }
  ImageFeatures features;
  features.type = options_.type;
  if (options_.upright && options_.type != FeatureType::kAkaze && options_.type != FeatureType::kBrief) {
    // Detect, turn the keypoints upright, describe them as given (SIFT, ORB and SURF describe a
    // provided keypoint at its own angle).
    detector_->detect(*gray, features.keypoints, mask);
    makeUpright(features.keypoints);
    detector_->compute(*gray, features.keypoints, features.descriptors);
  } else {
    detector_->detectAndCompute(*gray, mask, features.keypoints, features.descriptors);
    // AKAZE's upright descriptor ignores the angle it still reports.
    if (options_.upright) {
      for (cv::KeyPoint& keypoint : features.keypoints) keypoint.angle = 0.0F;
    }
  }
  // AKAZE has no feature budget of its own: keep the strongest responses.
  if (static_cast<int>(features.keypoints.size()) > options_.max_features) {
    std::vector<int> order(features.keypoints.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return features.keypoints[static_cast<std::size_t>(a)].response >
             features.keypoints[static_cast<std::size_t>(b)].response;
    });
    order.resize(static_cast<std::size_t>(options_.max_features));
    return selectFeatures(features, order);
  }
  return features;
}

}  // namespace homography_teach_repeat
