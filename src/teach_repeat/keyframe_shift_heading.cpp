#include "homography_teach_repeat/teach_repeat/keyframe_shift_heading.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>

namespace homography_teach_repeat {

void KeyframeShiftHeadingOptions::validate() const {
  shift.validate();
  if (cache_size < 1) throw std::invalid_argument("shift heading: cache_size must be >= 1");
  if (!(min_texture_std >= 0.0) || !std::isfinite(min_texture_std)) {
    throw std::invalid_argument("shift heading: min_texture_std must be >= 0");
  }
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
  const auto gray = toGray8(image);
  if (!gray) return gray.status();
  cv::Mat small;
  cv::resize(*gray, small, cv::Size(std::max(1, gray->cols / 8), std::max(1, gray->rows / 8)), 0.0, 0.0, cv::INTER_AREA);
  cv::Scalar mean, deviation;
  cv::meanStdDev(small, mean, deviation);
  if (deviation[0] < options_.min_texture_std) {
    char message[160];
    std::snprintf(message, sizeof(message), "shift heading: the image has no texture (grey-level sigma %.1f < %.1f)",
                  deviation[0], options_.min_texture_std);
    return Status(StatusCode::kTooFewPoints, message);
  }
  auto features = shift_heading_.describe(*gray);
  if (!features) return features.status();
  undistort(&*features);
  return features;
}

Status KeyframeShiftHeading::checkKeyframe(int keyframe) const {
  if (keyframe >= 0 && keyframe < keyframeCount()) return Status::ok();
  return Status(StatusCode::kInvalidInput, "shift heading: keyframe " + std::to_string(keyframe) +
                                               " is not in the route (" + std::to_string(keyframeCount()) + ")");
}

Expected<const ShiftFeatures*> KeyframeShiftHeading::viewFeatures(int keyframe, int experience) {
  const std::pair<int, int> key(keyframe, experience);
  for (auto it = cache_.begin(); it != cache_.end(); ++it) {
    if (it->first != key) continue;
    cache_.splice(cache_.begin(), cache_, it);
    return &cache_.front().second;
  }
  const Status in_route = checkKeyframe(keyframe);
  if (!in_route.isOk()) return in_route;
  const RouteKeyframe& taught = route_.keyframes[static_cast<std::size_t>(keyframe)];
  Expected<cv::Mat> image = Status(StatusCode::kInvalidInput, "no such view");
  if (experience == 0) {
    image = loadKeyframeImage(route_, static_cast<std::size_t>(keyframe));
  } else if (experience <= static_cast<int>(taught.experiences.size())) {
    const std::string path = routeFilePath(route_.directory, taught.experiences[static_cast<std::size_t>(experience - 1)].image_file);
    cv::Mat read = cv::imread(path, cv::IMREAD_UNCHANGED);
    if (read.empty()) {
      image = Status(StatusCode::kInvalidInput, "experience image '" + path + "' cannot be decoded");
    } else {
      image = read;
    }
  }
  if (!image) return image.status();
  auto features = describe(*image);
  if (!features) {
    return Status(features.status().code(), "shift heading, keyframe " + std::to_string(keyframe) + ": " +
                                                features.status().message());
  }
  cache_.emplace_front(key, std::move(*features));
  while (static_cast<int>(cache_.size()) > options_.cache_size) cache_.pop_back();
  return &cache_.front().second;
}

Expected<ShiftHeadingFix> KeyframeShiftHeading::measure(int keyframe, const ShiftFeatures& current) {
  const auto reference = viewFeatures(keyframe, 0);
  if (!reference) return reference.status();
  return shift_heading_.measure(**reference, current, camera_.cx(), camera_.fx());
}

Expected<ViewShiftFix> KeyframeShiftHeading::measureViews(int keyframe, const ShiftFeatures& current) {
  const Status in_route = checkKeyframe(keyframe);
  if (!in_route.isOk()) return in_route;
  const auto taught = measure(keyframe, current);
  std::optional<ViewShiftFix> best;
  const auto better = [](const ViewShiftFix& a, const std::optional<ViewShiftFix>& b) {
    if (!b) return true;
    if (a.fix.ambiguous != b->fix.ambiguous) return !a.fix.ambiguous;
    return a.fix.shift.support > b->fix.shift.support;
  };
  const RouteKeyframe& kf = route_.keyframes[static_cast<std::size_t>(keyframe)];
  if (taught) best = ViewShiftFix{*taught, 0, kf.pose, 0.0};
  for (std::size_t e = 0; e < kf.experiences.size(); ++e) {
    const auto reference = viewFeatures(keyframe, static_cast<int>(e) + 1);
    if (!reference) continue;
    const auto fix = shift_heading_.measure(**reference, current, camera_.cx(), camera_.fx());
    if (!fix) continue;
    const RouteExperience& learned = kf.experiences[e];
    const ViewShiftFix candidate{*fix, learned.id, learned.pose, learned.pose_covariance(2, 2)};
    if (better(candidate, best)) best = candidate;
  }
  if (!best) return taught.status();
  return *best;
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
    // (Cached: the next keyframe's vote finds it described.)
    const auto features = shift.viewFeatures(k, 0);
    if (!features) {
      a.problem = features.status().message();
      audits.push_back(a);
      continue;
    }
    for (const ImageFeatures& set : (*features)->sets) a.features += static_cast<int>(set.keypoints.size());
    a.neighbour = k + 1 < n ? k + 1 : k - 1;
    if (a.neighbour < 0) {
      a.problem = "the route has one keyframe";
    } else {
      const auto fix = shift.measure(a.neighbour, **features);
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
