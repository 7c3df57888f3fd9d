#include "homography_teach_repeat/features/brief.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace homography_teach_repeat {
namespace {

constexpr int kPatchSize = 48;
constexpr int kHalfPatch = kPatchSize / 2;
constexpr int kBits = 256;
// A keypoint's comparisons reach kHalfPatch − 1 pixels from it.
constexpr int kBorder = kHalfPatch;

using Comparison = std::array<int, 4>;  // (dx1, dy1, dx2, dy2)

const std::vector<Comparison>& comparisons() {
  static const std::vector<Comparison> pairs = [] {
    cv::RNG rng(0x4252494546ULL);  // fixed: descriptors must be the same everywhere
    std::vector<Comparison> drawn;
    drawn.reserve(kBits);
    const auto coordinate = [&rng] {
      const int value = cvRound(rng.gaussian(kPatchSize / 5.0));
      return std::max(-(kHalfPatch - 1), std::min(kHalfPatch - 1, value));
    };
    while (static_cast<int>(drawn.size()) < kBits) {
      Comparison c{coordinate(), coordinate(), coordinate(), coordinate()};
      if (c[0] == c[2] && c[1] == c[3]) continue;  // a pixel against itself tells nothing
      drawn.push_back(c);
    }
    return drawn;
  }();
  return pairs;
}

class AgastBrief : public cv::Feature2D {
 public:
  explicit AgastBrief(int max_features)
      : max_features_(max_features), detector_(cv::AgastFeatureDetector::create(10, true)) {}

  int descriptorSize() const override { return kBits / 8; }
  int descriptorType() const override { return CV_8U; }
  int defaultNorm() const override { return cv::NORM_HAMMING; }
  cv::String getDefaultName() const override { return "homography_teach_repeat.AgastBrief"; }

  void detectAndCompute(cv::InputArray image, cv::InputArray mask, std::vector<cv::KeyPoint>& keypoints,
                        cv::OutputArray descriptors, bool use_provided_keypoints) override {
    const cv::Mat grey = image.getMat();
    CV_Assert(grey.type() == CV_8UC1);
    if (!use_provided_keypoints) {
      detector_->detect(grey, keypoints, mask);
      cv::KeyPointsFilter::retainBest(keypoints, max_features_);
    }
    cv::KeyPointsFilter::runByImageBorder(keypoints, grey.size(), kBorder);
    for (cv::KeyPoint& keypoint : keypoints) {
      keypoint.angle = 0.0F;
      keypoint.size = static_cast<float>(kPatchSize);
    }
    if (!descriptors.needed()) return;
    cv::Mat smooth;
    cv::GaussianBlur(grey, smooth, cv::Size(9, 9), 2.0, 2.0, cv::BORDER_REFLECT_101);
    descriptors.create(static_cast<int>(keypoints.size()), kBits / 8, CV_8U);
    cv::Mat out = descriptors.getMat();
    out.setTo(0);
    const auto& pairs = comparisons();
    for (int row = 0; row < out.rows; ++row) {
      const cv::KeyPoint& keypoint = keypoints[static_cast<std::size_t>(row)];
      const int x = cvRound(keypoint.pt.x), y = cvRound(keypoint.pt.y);
      uchar* bits = out.ptr<uchar>(row);
      for (int b = 0; b < kBits; ++b) {
        const Comparison& c = pairs[static_cast<std::size_t>(b)];
        if (smooth.at<uchar>(y + c[1], x + c[0]) < smooth.at<uchar>(y + c[3], x + c[2])) {
          bits[b / 8] = static_cast<uchar>(bits[b / 8] | (1U << (b % 8)));
        }
      }
    }
  }

 private:
  int max_features_;
  cv::Ptr<cv::AgastFeatureDetector> detector_;
};

}  // namespace

cv::Ptr<cv::Feature2D> createAgastBrief(int max_features) { return cv::makePtr<AgastBrief>(max_features); }

}  // namespace homography_teach_repeat
