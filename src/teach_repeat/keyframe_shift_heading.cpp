#include "homography_teach_repeat/teach_repeat/keyframe_shift_heading.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace homography_teach_repeat {

void KeyframeShiftHeadingOptions::validate() const {
  shift.validate();
  if (cache_size < 1) throw std::invalid_argument("shift heading: cache_size must be >= 1");
}

KeyframeShiftHeading::KeyframeShiftHeading(const Route& route, const PinholeCamera& camera,
                                           const KeyframeShiftHeadingOptions& options)
    : route_(route), camera_(camera), options_(options), shift_heading_((options.validate(), options.shift)) {}

void KeyframeShiftHeading::undistort(ShiftFeatures* features) const {
  if (!camera_.hasDistortion()) return;
  for (ImageFeatures& set : features->sets) {
    for (cv::KeyPoint& keypoint : set.keypoints) {
      const cv::Point2d ideal = camera_.undistortPixel(cv::Point2d(keypoint.pt));
      keypoint.pt = cv::Point2f(static_cast<float>(ideal.x), static_cast<float>(ideal.y));
    }
  }
}

Expected<ShiftFeatures> KeyframeShiftHeading::describe(const cv::Mat& image) {
  if (image.cols != camera_.width() || image.rows != camera_.height()) {
    return Status(StatusCode::kInvalidInput, "shift heading: the image is " + std::to_string(image.cols) + "x" +
                                                 std::to_string(image.rows) + ", the route's camera " +
                                                 std::to_string(camera_.width()) + "x" +
                                                 std::to_string(camera_.height()));
  }
  auto features = shift_heading_.describe(image);
  if (!features) return features.status();
  undistort(&*features);
  return features;
}

Expected<const ShiftFeatures*> KeyframeShiftHeading::keyframeFeatures(int keyframe) {
  for (auto it = cache_.begin(); it != cache_.end(); ++it) {
    if (it->first != keyframe) continue;
    cache_.splice(cache_.begin(), cache_, it);
    return &cache_.front().second;
  }
  if (keyframe < 0 || keyframe >= keyframeCount()) {
    return Status(StatusCode::kInvalidInput, "shift heading: keyframe " + std::to_string(keyframe) +
                                                 " is not in the route (" + std::to_string(keyframeCount()) + ")");
  }
  const auto image = loadKeyframeImage(route_, static_cast<std::size_t>(keyframe));
  if (!image) return image.status();
  auto features = describe(*image);
  if (!features) {
    return Status(features.status().code(), "shift heading, keyframe " + std::to_string(keyframe) + ": " +
                                                features.status().message());
  }
  cache_.emplace_front(keyframe, std::move(*features));
  while (static_cast<int>(cache_.size()) > options_.cache_size) cache_.pop_back();
  return &cache_.front().second;
}

Expected<ShiftHeadingFix> KeyframeShiftHeading::measure(int keyframe, const ShiftFeatures& current) {
  const auto reference = keyframeFeatures(keyframe);
  if (!reference) return reference.status();
  return shift_heading_.measure(**reference, current, camera_.cx(), camera_.fx());
}

std::vector<ShiftHeadingAudit> auditShiftHeading(const Route& route, const PinholeCamera& camera,
                                                 const KeyframeShiftHeadingOptions& options) {
  KeyframeShiftHeadingOptions two = options;
  two.cache_size = std::max(2, options.cache_size);  // this keyframe and the next one
  KeyframeShiftHeading shift(route, camera, two);
  const int n = shift.keyframeCount();
  std::vector<ShiftHeadingAudit> audits;
  for (int k = 0; k < n; ++k) {
    ShiftHeadingAudit a;
    a.keyframe = k;
    const auto image = loadKeyframeImage(route, static_cast<std::size_t>(k));
    const auto features = image ? shift.describe(*image) : Expected<ShiftFeatures>(image.status());
    if (!features) {
      a.problem = features.status().message();
      audits.push_back(a);
      continue;
    }
    for (const ImageFeatures& set : features->sets) a.features += static_cast<int>(set.keypoints.size());
    a.neighbour = k + 1 < n ? k + 1 : k - 1;
    if (a.neighbour < 0) {
      a.problem = "the route has one keyframe";
    } else {
      const auto fix = shift.measure(a.neighbour, *features);
      if (fix) {
        a.support = fix->shift.support;
        a.ambiguous = fix->ambiguous;
      } else {
        a.problem = fix.status().message();
      }
    }
    audits.push_back(a);
  }
  return audits;
}

}  // namespace homography_teach_repeat
