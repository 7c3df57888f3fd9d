// Synthetic images for the core tests: a blurred random texture (rich in corners and blobs for
// every feature type) and its warp by a known homography.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <string>
#include <sys/stat.h>

namespace homography_teach_repeat {
namespace test_support {

inline cv::Mat makeTexture(int width, int height, unsigned seed) {
  cv::RNG rng(seed);
  cv::Mat texture(height, width, CV_8UC1, cv::Scalar(128));
  // Random rectangles and circles of random grey: many corners at several scales.
  for (int i = 0; i < width * height / 400; ++i) {
    const cv::Point centre(rng.uniform(0, width), rng.uniform(0, height));
    const int size = rng.uniform(3, 25);
    const cv::Scalar grey(rng.uniform(0, 256));
    if (i % 2 == 0) {
      cv::rectangle(texture, centre, centre + cv::Point(size, size * 2 / 3), grey, cv::FILLED);
    } else {
      cv::circle(texture, centre, size / 2, grey, cv::FILLED);
    }
  }
  cv::GaussianBlur(texture, texture, cv::Size(3, 3), 0.8);
  return texture;
}

// A 640 x 480 view of a wider `scene` whose left edge is at column `left` when `shift` is 0: the
// camera turned so the scene moves `shift` px to the right, the light changed by `gain` and `offset`.
inline cv::Mat turnedView(const cv::Mat& scene, int left, int shift, double gain = 1.0, double offset = 0.0) {
  cv::Mat image = scene(cv::Rect(left - shift, 0, 640, 480)).clone();
  if (gain != 1.0 || offset != 0.0) image.convertTo(image, -1, gain, offset);
  return image;
}

inline cv::Mat toCv(const Eigen::Matrix3d& H) {
  cv::Mat m(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.at<double>(r, c) = H(r, c);
  return m;
}

inline cv::Mat warp(const cv::Mat& image, const Eigen::Matrix3d& H) {
  cv::Mat warped;
  cv::warpPerspective(image, warped, toCv(H), image.size(), cv::INTER_LINEAR,
                      cv::BORDER_CONSTANT, cv::Scalar(128));
  return warped;
}

// A moderate viewpoint change of a 640x480 image.
inline Eigen::Matrix3d moderateHomography() {
  Eigen::Matrix3d H;
  H << 0.95, -0.08, 25.0, 0.06, 0.98, -15.0, 1.5e-4, -8e-5, 1.0;
  return H;
}

inline bool fileExists(const std::string& path) {
  struct stat info {};
  return stat(path.c_str(), &info) == 0;
}

}  // namespace test_support
}  // namespace homography_teach_repeat
