#include <gtest/gtest.h>

#include <opencv2/features2d.hpp>

#include "homography_teach_repeat/features/brief.h"
#include "support/test_images.h"

using namespace homography_teach_repeat;

namespace {

struct Described {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
};

Described describe(const cv::Mat& image, int max_features = 500) {
  Described d;
  createAgastBrief(max_features)->detectAndCompute(image, cv::noArray(), d.keypoints, d.descriptors);
  return d;
}

}  // namespace

TEST(AgastBrief, ThirtyTwoBytesPerKeypointAwayFromTheBorder) {
  const cv::Mat image = test_support::makeTexture(320, 240, 5);
  const Described d = describe(image);
  ASSERT_GT(d.keypoints.size(), 100u);
  EXPECT_LE(d.keypoints.size(), 500u);
  EXPECT_EQ(d.descriptors.rows, static_cast<int>(d.keypoints.size()));
  EXPECT_EQ(d.descriptors.cols, 32);
  EXPECT_EQ(d.descriptors.type(), CV_8U);
  for (const auto& k : d.keypoints) {
    EXPECT_GE(k.pt.x, 24.0F);
    EXPECT_GE(k.pt.y, 24.0F);
    EXPECT_LT(k.pt.x, 320.0F - 24.0F);
    EXPECT_LT(k.pt.y, 240.0F - 24.0F);
    EXPECT_EQ(k.angle, 0.0F);
  }
}

TEST(AgastBrief, TheSameImageGivesTheSameDescriptors) {
  const cv::Mat image = test_support::makeTexture(320, 240, 6);
  const Described a = describe(image), b = describe(image);
  ASSERT_EQ(a.descriptors.rows, b.descriptors.rows);
  EXPECT_EQ(cv::norm(a.descriptors, b.descriptors, cv::NORM_HAMMING), 0.0);
}

// Intensity comparisons do not change under a brightness gain and offset: the darker, brighter
// image's descriptors at the same keypoints are (nearly) the same bits.
TEST(AgastBrief, DescriptorsSurviveABrightnessChange) {
  const cv::Mat image = test_support::makeTexture(320, 240, 7);
  Described original = describe(image);
  cv::Mat changed;
  image.convertTo(changed, -1, 0.6, 30.0);
  Described again;
  again.keypoints = original.keypoints;
  createAgastBrief(500)->detectAndCompute(changed, cv::noArray(), again.keypoints, again.descriptors, true);
  ASSERT_EQ(again.keypoints.size(), original.keypoints.size());
  double bits = 0.0;
  for (int r = 0; r < again.descriptors.rows; ++r) {
    bits += cv::norm(original.descriptors.row(r), again.descriptors.row(r), cv::NORM_HAMMING);
  }
  EXPECT_LT(bits / again.descriptors.rows, 256 * 0.05) << "mean bits changed of 256";
}

TEST(AgastBrief, ProvidedKeypointsTooNearTheBorderAreDropped) {
  const cv::Mat image = test_support::makeTexture(200, 150, 8);
  std::vector<cv::KeyPoint> keypoints = {cv::KeyPoint(5.0F, 70.0F, 7.0F), cv::KeyPoint(100.0F, 70.0F, 7.0F),
                                         cv::KeyPoint(100.0F, 140.0F, 7.0F)};
  cv::Mat descriptors;
  createAgastBrief(10)->detectAndCompute(image, cv::noArray(), keypoints, descriptors, true);
  ASSERT_EQ(keypoints.size(), 1u);
  EXPECT_EQ(keypoints[0].pt, cv::Point2f(100.0F, 70.0F));
  EXPECT_EQ(descriptors.rows, 1);
}
