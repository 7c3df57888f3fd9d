#include <gtest/gtest.h>

#include <opencv2/features2d.hpp>

#include <set>
#include <tuple>

#include "homography_teach_repeat/features/feature_extractor.h"
#include "support/test_images.h"

using namespace homography_teach_repeat;

namespace {
class AllFeatureTypes : public ::testing::TestWithParam<FeatureType> {};
}  // namespace

TEST(FeatureType, ParsesNamesAndListsAlternatives) {
  EXPECT_EQ(featureTypeFromString("sift"), FeatureType::kSift);
  EXPECT_EQ(featureTypeFromString("orb"), FeatureType::kOrb);
  EXPECT_EQ(featureTypeFromString("akaze"), FeatureType::kAkaze);
  EXPECT_EQ(featureTypeFromString("brief"), FeatureType::kBrief);
  try {
    featureTypeFromString("freak");
    FAIL() << "accepted an unknown feature type";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("sift, orb, akaze, brief"), std::string::npos) << e.what();
  }
}

// SURF exists only with OpenCV's non-free xfeatures2d; without it, asking for it must fail with
// a message naming the alternatives (Debian's OpenCV has no SURF).
TEST(FeatureType, SurfAvailableOrRejectedWithAlternatives) {
  if (isFeatureTypeAvailable(FeatureType::kSurf)) {
    EXPECT_EQ(featureTypeFromString("surf"), FeatureType::kSurf);
    return;
  }
  try {
    featureTypeFromString("surf");
    FAIL() << "SURF is unavailable but was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("available: sift, orb, akaze"), std::string::npos)
        << e.what();
  }
}

TEST_P(AllFeatureTypes, DetectsFeaturesOnTexture) {
  FeatureOptions options;
  options.type = GetParam();
  options.max_features = 500;
  FeatureExtractor extractor(options);
  const auto features = extractor.extract(test_support::makeTexture(640, 480, 1));
  ASSERT_TRUE(features.isOk()) << features.status().toString();
  EXPECT_GT(features->keypoints.size(), 100u);
  EXPECT_LE(features->keypoints.size(), 500u);
  EXPECT_EQ(features->descriptors.rows, static_cast<int>(features->keypoints.size()));
  EXPECT_EQ(features->type, GetParam());
}

TEST_P(AllFeatureTypes, BlankImageGivesNoFeatures) {
  FeatureOptions options;
  options.type = GetParam();
  FeatureExtractor extractor(options);
  const auto features = extractor.extract(cv::Mat(480, 640, CV_8UC1, cv::Scalar(90)));
  ASSERT_TRUE(features.isOk());
  EXPECT_TRUE(features->keypoints.empty());
}

// Upright: every keypoint at angle 0, one per location (SIFT's orientation copies dropped), and the
// descriptors still find a shifted copy of the image.
TEST_P(AllFeatureTypes, UprightKeypointsPointUpAndMatchAShiftedImage) {
  FeatureOptions options;
  options.type = GetParam();
  options.max_features = 800;
  options.upright = true;
  FeatureExtractor extractor(options);
  const cv::Mat texture = test_support::makeTexture(680, 480, 4);
  const cv::Mat reference = texture(cv::Rect(40, 0, 640, 480)).clone();
  const cv::Mat shifted = texture(cv::Rect(0, 0, 640, 480)).clone();  // scene 40 px to the right
  const auto a = extractor.extract(reference);
  const auto b = extractor.extract(shifted);
  ASSERT_TRUE(a.isOk() && b.isOk());
  ASSERT_GT(a->keypoints.size(), 100u);
  std::set<std::tuple<float, float, float>> locations;
  for (const auto& k : a->keypoints) {
    EXPECT_EQ(k.angle, 0.0F);
    EXPECT_TRUE(locations.insert({k.pt.x, k.pt.y, k.size}).second) << "duplicate keypoint at " << k.pt;
  }
  cv::BFMatcher matcher(hasBinaryDescriptor(GetParam()) ? cv::NORM_HAMMING : cv::NORM_L2, true);
  std::vector<cv::DMatch> matches;
  matcher.match(a->descriptors, b->descriptors, matches);
  int right = 0;
  for (const auto& m : matches) {
    const cv::Point2f d = b->keypoints[m.trainIdx].pt - a->keypoints[m.queryIdx].pt;
    right += std::abs(d.x - 40.0F) < 1.5F && std::abs(d.y) < 1.5F ? 1 : 0;
  }
  EXPECT_GT(right, static_cast<int>(matches.size()) * 7 / 10) << right << " of " << matches.size();
}

INSTANTIATE_TEST_SUITE_P(Available, AllFeatureTypes,
                         ::testing::Values(FeatureType::kSift, FeatureType::kOrb,
                                           FeatureType::kAkaze, FeatureType::kBrief));

TEST(FeatureExtractor, ColourImageGivesSameFeaturesAsGrey) {
  FeatureExtractor extractor(FeatureOptions{});
  const cv::Mat grey = test_support::makeTexture(320, 240, 2);
  cv::Mat colour;
  cv::cvtColor(grey, colour, cv::COLOR_GRAY2BGR);
  EXPECT_EQ(extractor.extract(grey)->keypoints.size(), extractor.extract(colour)->keypoints.size());
}

TEST(FeatureExtractor, RejectsEmptyAndUnsupportedImages) {
  FeatureExtractor extractor(FeatureOptions{});
  EXPECT_EQ(extractor.extract(cv::Mat()).status().code(), StatusCode::kInvalidInput);
  const auto depth16 = extractor.extract(cv::Mat(48, 64, CV_16UC1, cv::Scalar(1000)));
  EXPECT_EQ(depth16.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(depth16.status().message().find("8-bit"), std::string::npos);
  EXPECT_EQ(extractor.extract(cv::Mat(48, 64, CV_8UC2)).status().code(), StatusCode::kInvalidInput);
  const cv::Mat image = test_support::makeTexture(64, 48, 3);
  EXPECT_EQ(extractor.extract(image, cv::Mat(10, 10, CV_8UC1)).status().code(),
            StatusCode::kInvalidInput);
}

TEST(FeatureExtractor, InvalidOptionsThrow) {
  FeatureOptions options;
  options.max_features = 0;
  EXPECT_THROW(FeatureExtractor{options}, std::invalid_argument);
}
