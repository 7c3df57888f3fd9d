// Point features of an image: SURF where OpenCV was built with the non-free xfeatures2d module,
// otherwise SIFT, ORB or AKAZE (always present in OpenCV >= 4.4), and BRIEF on AGAST corners
// (features/brief.h, upright and single-scale: the seasonal heading's features).
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include <string>
#include <vector>

#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

enum class FeatureType { kSurf, kSift, kOrb, kAkaze, kBrief };

// "surf", "sift", "orb", "akaze", "brief". Throws std::invalid_argument on an unknown name, and for
// "surf" when this OpenCV has no SURF (the message names the available alternatives).
FeatureType featureTypeFromString(const std::string& name);
std::string toString(FeatureType type);
// Whether this OpenCV build can create the detector (SURF needs xfeatures2d with non-free).
bool isFeatureTypeAvailable(FeatureType type);
// Comma-separated names of the available types, for messages.
std::string availableFeatureTypes();
// Binary descriptors are matched with the Hamming norm, float descriptors with L2.
bool hasBinaryDescriptor(FeatureType type);

// The strongest features the teach and the repeat keep per image unless configured (teach_node's
// and repeat_node's `max_features`, evaluate_sequence's --max-features): on a real street (KITTI 07
// at full size, SIFT) 2000 localized more frames, with a smaller error and a NEES nearer its
// expectation, than 1500; 3000 keeps every feature of fountain-P11's views at 768x512 (the cap
// bound at 2000: median error 0.0080 → 0.0055 m) and of most KITTI 07 frames, at the same frame
// time (docs/evaluation.md, "KITTI 07", "fountain-P11").
inline constexpr int kRouteMaxFeatures = 3000;

struct FeatureOptions {
  FeatureType type = FeatureType::kSift;
  int max_features = 1000;  // strongest features kept (by detector response)
  // Upright descriptors: every keypoint's orientation is 0 (image up), so a descriptor no longer
  // turns with the patch. A ground robot's camera does not roll; rotation invariance only costs
  // matches there (docs/evaluation.md, "Heading across seasons": upright SIFT fails a third as
  // many seasonal pairs as SIFT). SIFT: one keypoint per location (orientation duplicates
  // dropped); AKAZE: its upright MLDB descriptor; ORB: the detector's angle replaced by 0; BRIEF
  // is upright either way.
  bool upright = false;

  void validate() const;  // throws std::invalid_argument
};

struct ImageFeatures {
  FeatureType type = FeatureType::kSift;
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;  // one row per keypoint
};

class FeatureExtractor {
 public:
  // Throws std::invalid_argument on invalid options or an unavailable type.
  explicit FeatureExtractor(const FeatureOptions& options);

  // Accepts 8-bit grey (CV_8UC1) and 8-bit BGR/BGRA (CV_8UC3/4) images. Status kInvalidInput for
  // an empty image or any other pixel type (named in the message). An image without texture
  // gives an OK result with zero keypoints; callers decide whether that is enough.
  Expected<ImageFeatures> extract(const cv::Mat& image, const cv::Mat& mask = cv::Mat());

  const FeatureOptions& options() const { return options_; }

 private:
  FeatureOptions options_;
  cv::Ptr<cv::Feature2D> detector_;
};

// The features at `indices` (in that order; each a valid index), of the same type.
ImageFeatures selectFeatures(const ImageFeatures& features, const std::vector<int>& indices);

// Converts an 8-bit grey/BGR/BGRA image to grey; kInvalidInput for anything else.
Expected<cv::Mat> toGray8(const cv::Mat& image);

}  // namespace homography_teach_repeat
