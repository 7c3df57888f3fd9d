#include <gtest/gtest.h>

#include <algorithm>
#include <iterator>
#include <set>
#include <utility>

#include <opencv2/features2d.hpp>

#include "homography_teach_repeat/features/feature_matcher.h"
#include "homography_teach_repeat/homography/homography.h"
#include "support/test_images.h"

using namespace homography_teach_repeat;

namespace {

struct Pair {
  ImageFeatures reference, current;
};

Pair extractPair(FeatureType type) {
  FeatureOptions options;
  options.type = type;
  FeatureExtractor extractor(options);
  const cv::Mat reference = test_support::makeTexture(640, 480, 5);
  const cv::Mat current = test_support::warp(reference, test_support::moderateHomography());
  return {*extractor.extract(reference), *extractor.extract(current)};
}

class MatcherForType : public ::testing::TestWithParam<FeatureType> {};

}  // namespace

// Most accepted matches must agree with the known warp; no current feature is used twice.
TEST_P(MatcherForType, MatchesAreMostlyCorrectAndOneToOne) {
  const Pair pair = extractPair(GetParam());
  const auto matches = matchFeatures(pair.reference, pair.current, MatchOptions{});
  ASSERT_TRUE(matches.isOk());
  ASSERT_GT(matches->size(), 50u);
  const PointMatches points = toPointMatches(pair.reference, pair.current, *matches);
  int correct = 0;
  for (const auto& m : points) {
    if (transferError(test_support::moderateHomography(), m) < 3.0) ++correct;
  }
  EXPECT_GT(correct, static_cast<int>(0.9 * points.size()));
  std::set<int> used;
  for (const auto& m : *matches) EXPECT_TRUE(used.insert(m.trainIdx).second);
}

// The distance matrix (popcount Hamming for binary descriptors, batchDistance for SIFT) gives
// exactly the matches of OpenCV's brute-force matcher with the same ratio test and mutual check.
TEST_P(MatcherForType, SameMatchesAsOpenCvBruteForce) {
  const Pair pair = extractPair(GetParam());
  const MatchOptions options;
  const auto matches = matchFeatures(pair.reference, pair.current, options);
  ASSERT_TRUE(matches.isOk());
  const int norm = hasBinaryDescriptor(GetParam()) ? cv::NORM_HAMMING : cv::NORM_L2;
  cv::BFMatcher matcher(norm);
  std::vector<std::vector<cv::DMatch>> forward;
  matcher.knnMatch(pair.reference.descriptors, pair.current.descriptors, forward, 2);
  std::vector<cv::DMatch> backward;
  matcher.match(pair.current.descriptors, pair.reference.descriptors, backward);
  std::set<std::pair<int, int>> expected;
  for (const auto& two : forward) {
    if (two.size() < 2 || !(two[0].distance < options.ratio * two[1].distance)) continue;
    if (backward[static_cast<std::size_t>(two[0].trainIdx)].trainIdx != two[0].queryIdx) continue;
    expected.emplace(two[0].queryIdx, two[0].trainIdx);
  }
  std::set<std::pair<int, int>> got;
  for (const auto& m : *matches) got.emplace(m.queryIdx, m.trainIdx);
  // Ties between equal distances may resolve differently; allow 1% of them.
  std::vector<std::pair<int, int>> differing;
  std::set_symmetric_difference(got.begin(), got.end(), expected.begin(), expected.end(),
                                std::back_inserter(differing));
  EXPECT_LE(differing.size(), expected.size() / 100) << got.size() << " vs " << expected.size();
  EXPECT_GT(expected.size(), 50u);
}

INSTANTIATE_TEST_SUITE_P(Available, MatcherForType,
                         ::testing::Values(FeatureType::kSift, FeatureType::kOrb,
                                           FeatureType::kAkaze, FeatureType::kBrief));

TEST(FeatureMatcher, RatioTestRemovesAmbiguousMatches) {
  const Pair pair = extractPair(FeatureType::kSift);
  MatchOptions strict, loose;
  strict.ratio = 0.5;
  loose.ratio = 1.0;
  loose.mutual = false;
  EXPECT_LT(matchFeatures(pair.reference, pair.current, strict)->size(),
            matchFeatures(pair.reference, pair.current, loose)->size());
}

TEST(FeatureMatcher, DifferentTypesAreRejected) {
  const Pair sift = extractPair(FeatureType::kSift);
  const Pair orb = extractPair(FeatureType::kOrb);
  const auto matches = matchFeatures(sift.reference, orb.current, MatchOptions{});
  EXPECT_EQ(matches.status().code(), StatusCode::kInvalidInput);
}

TEST(FeatureMatcher, TooFewFeaturesGiveEmptyResult) {
  const Pair pair = extractPair(FeatureType::kSift);
  ImageFeatures empty;
  empty.type = FeatureType::kSift;
  const auto matches = matchFeatures(pair.reference, empty, MatchOptions{});
  ASSERT_TRUE(matches.isOk());
  EXPECT_TRUE(matches->empty());
}

TEST(FeatureMatcher, InvalidRatioThrows) {
  MatchOptions options;
  options.ratio = 1.5;
  EXPECT_THROW(options.validate(), std::invalid_argument);
}
