#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "homography_teach_repeat/mu/image_shift.h"

using namespace homography_teach_repeat;

namespace {

// `inliers` matches shifted by `shift` with Gaussian noise `noise` in x, `outliers` matched at
// random across a 1024 x 384 image.
PointMatches makeMatches(double shift, int inliers, int outliers, double noise, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(0.0, 1024.0), y(0.0, 384.0);
  std::normal_distribution<double> n(0.0, noise);
  PointMatches matches;
  for (int i = 0; i < inliers; ++i) {
    const Eigen::Vector2d p(x(rng), y(rng));
    matches.push_back({p, p + Eigen::Vector2d(shift + n(rng), n(rng))});
  }
  for (int i = 0; i < outliers; ++i) {
    const Eigen::Vector2d p(x(rng), y(rng));
    matches.push_back({p, Eigen::Vector2d(x(rng), p.y() + 0.3 * (y(rng) - 192.0))});
  }
  return matches;
}

}  // namespace

TEST(ImageShift, FindsTheShiftAmongThreeTimesAsManyWrongMatches) {
  for (const double truth : {-240.0, -13.0, 0.0, 57.5, 180.0}) {
    const auto shift = estimateImageShift(makeMatches(truth, 40, 120, 2.0, 3), 1024);
    ASSERT_TRUE(shift.isOk()) << shift.status().toString();
    EXPECT_NEAR(shift->shift_px, truth, 1.5);
    EXPECT_GE(shift->support, 38);
    EXPECT_LT(shift->runner_up_support, shift->support / 2);
    EXPECT_NEAR(shift->spread_px, 2.0, 0.8);
    EXPECT_NEAR(shift->sigma_px, shift->spread_px / std::sqrt(shift->support), 1e-12);
  }
}

TEST(ImageShift, AHandfulOfAgreeingMatchesSuffices) {
  const auto shift = estimateImageShift(makeMatches(-75.0, 8, 8, 1.0, 5), 1024);
  ASSERT_TRUE(shift.isOk()) << shift.status().toString();
  EXPECT_NEAR(shift->shift_px, -75.0, 2.0);
  EXPECT_LT(shift->chance_probability, 1e-6);
}

// Views of different places: their matches' x differences spread at random, and the fullest
// window holds what chance puts there (300 matches: ~10 expected, 15-20 in the fullest of the
// vote's windows and scales). That is no consensus, however many clear min_support; a handful
// agreeing among many wrong matches is not either, while 40 among 160 is.
TEST(ImageShift, WhatChanceExplainsIsNoConsensus) {
  for (const unsigned seed : {11U, 12U, 13U, 14U, 15U}) {
    const auto chance = estimateImageShift(makeMatches(0.0, 0, 300, 1.0, seed), 1024);
    ASSERT_FALSE(chance.isOk()) << seed;
    EXPECT_EQ(chance.status().code(), StatusCode::kNoConsensus);
    EXPECT_NE(chance.status().message().find("chance"), std::string::npos) << chance.status().message();
    ImageShiftOptions no_test;
    no_test.max_chance_probability = 1.0;
    const auto taken = estimateImageShift(makeMatches(0.0, 0, 300, 1.0, seed), 1024, no_test);
    ASSERT_TRUE(taken.isOk());  // the window it found: more than min_support, explained by chance
    EXPECT_GE(taken->support, no_test.min_support);
    EXPECT_GT(taken->chance_probability, 1e-6);
    EXPECT_NEAR(taken->chance_support, 300 * 0.035, 1e-9);
  }
  EXPECT_EQ(estimateImageShift(makeMatches(-75.0, 6, 30, 1.0, 5), 1024).status().code(), StatusCode::kNoConsensus);
  const auto clear = estimateImageShift(makeMatches(-75.0, 40, 160, 1.0, 5), 1024);
  ASSERT_TRUE(clear.isOk()) << clear.status().toString();
  EXPECT_LT(clear->chance_probability, 1e-15);
}

TEST(ImageShift, PoissonUpperTail) {
  EXPECT_NEAR(poissonUpperTail(14, 7.0), 0.0128114, 1e-6);
  EXPECT_NEAR(poissonUpperTail(5, 2.0), 1.0 - 7.0 * std::exp(-2.0), 1e-12);
  EXPECT_NEAR(poissonUpperTail(5, 0.5), 1.72116e-4, 1e-9);
  EXPECT_EQ(poissonUpperTail(3, 3.0), 1.0);  // at or below the mean: never significant
  EXPECT_EQ(poissonUpperTail(0, 0.0), 1.0);
  EXPECT_GT(poissonUpperTail(400, 100.0), 0.0);
  EXPECT_LT(poissonUpperTail(400, 100.0), 1e-60);
}

TEST(ImageShift, TwoCompetingShiftsShowInTheRunnerUp) {
  PointMatches matches = makeMatches(20.0, 30, 0, 1.0, 7);
  const PointMatches other = makeMatches(-100.0, 25, 0, 1.0, 8);
  matches.insert(matches.end(), other.begin(), other.end());
  const auto shift = estimateImageShift(matches, 1024);
  ASSERT_TRUE(shift.isOk());
  EXPECT_NEAR(shift->shift_px, 20.0, 1.0);
  EXPECT_EQ(shift->runner_up_support, 25);
  EXPECT_NEAR(shift->runner_up_shift_px, -100.0, 2.0);
}

TEST(ImageShift, TheWindowScalesWithTheImage) {
  // Half the image: half the window (17.5 px); two groups 25 px apart are two windows then. At
  // full width (35 px) one window holds both, and the robust mean keeps the larger group.
  PointMatches matches = makeMatches(10.0, 20, 0, 0.5, 9);
  const PointMatches other = makeMatches(35.0, 15, 0, 0.5, 10);
  matches.insert(matches.end(), other.begin(), other.end());
  ImageShiftOptions shifts_only;  // (the scale search could fuse two groups spread over x)
  shifts_only.max_scale_change = 0.0;
  const auto half = estimateImageShift(matches, 512, shifts_only);
  ASSERT_TRUE(half.isOk());
  EXPECT_NEAR(half->shift_px, 10.0, 0.5);
  EXPECT_EQ(half->runner_up_support, 15);
  const auto full = estimateImageShift(matches, 1024, shifts_only);
  ASSERT_TRUE(full.isOk());
  EXPECT_NEAR(full->shift_px, 10.0, 0.5);
  EXPECT_EQ(full->support, 20);
  EXPECT_EQ(full->runner_up_support, 0);
  EXPECT_TRUE(std::isnan(full->runner_up_shift_px));
}

TEST(ImageShift, MatchesThatMoveVerticallyAreDropped) {
  PointMatches matches = makeMatches(0.0, 10, 0, 0.5, 11);
  for (int i = 0; i < 30; ++i) {
    matches.push_back({Eigen::Vector2d(100.0 + i, 50.0), Eigen::Vector2d(400.0 + i, 300.0)});  // 250 px down
  }
  const auto shift = estimateImageShift(matches, 1024);
  ASSERT_TRUE(shift.isOk());
  EXPECT_EQ(shift->matches, 10);
  EXPECT_NEAR(shift->shift_px, 0.0, 0.5);
}

TEST(ImageShift, TooFewOrDisagreeingMatchesAreStatuses) {
  EXPECT_EQ(estimateImageShift({}, 1024).status().code(), StatusCode::kTooFewPoints);
  EXPECT_EQ(estimateImageShift(makeMatches(5.0, 4, 0, 0.5, 12), 1024).status().code(), StatusCode::kTooFewPoints);
  PointMatches scattered;
  for (int i = 0; i < 40; ++i) {
    scattered.push_back({Eigen::Vector2d(500.0, 100.0), Eigen::Vector2d(500.0 + 40.0 * (i - 20), 100.0)});
  }
  const auto none = estimateImageShift(scattered, 1024);
  EXPECT_EQ(none.status().code(), StatusCode::kNoConsensus) << none.status().toString();
}

TEST(ImageShift, BadInputIsRefused) {
  PointMatches matches = makeMatches(5.0, 20, 0, 0.5, 13);
  EXPECT_EQ(estimateImageShift(matches, 0).status().code(), StatusCode::kInvalidInput);
  matches[3].current.x() = std::nan("");
  EXPECT_EQ(estimateImageShift(matches, 1024).status().code(), StatusCode::kInvalidInput);
  ImageShiftOptions options;
  options.window_fraction = 0.0;
  EXPECT_THROW(estimateImageShift(makeMatches(5.0, 20, 0, 0.5, 13), 1024, options), std::invalid_argument);
  options = ImageShiftOptions();
  options.min_support = 0;
  EXPECT_THROW(options.validate(), std::invalid_argument);
}

TEST(ImageShift, AViewScaledAboutTheCentreStillGivesTheCentreShift) {
  // The robot 8 % closer to the scene: x − 512 scaled by 1.08, then shifted by 30 px; the x
  // differences spread over ±40 px, wider than the window. Outliers as elsewhere.
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> x(0.0, 1024.0), y(0.0, 384.0);
  PointMatches matches;
  for (int i = 0; i < 60; ++i) {
    const Eigen::Vector2d p(x(rng), y(rng));
    matches.push_back({p, Eigen::Vector2d(512.0 + 1.08 * (p.x() - 512.0) + 30.0, 192.0 + 1.08 * (p.y() - 192.0))});
  }
  const PointMatches outliers = makeMatches(0.0, 0, 60, 1.0, 22);
  matches.insert(matches.end(), outliers.begin(), outliers.end());
  const auto shift = estimateImageShift(matches, 1024);
  ASSERT_TRUE(shift.isOk());
  EXPECT_NEAR(shift->shift_px, 30.0, 3.0);
  EXPECT_NEAR(shift->scale, 1.08, 0.03);  // a window of 35 px spans ±0.03 of scale over ±512 px
  EXPECT_GE(shift->support, 50);
  ImageShiftOptions shifts_only;
  shifts_only.max_scale_change = 0.0;
  const auto unscaled = estimateImageShift(matches, 1024, shifts_only);
  ASSERT_TRUE(unscaled.isOk());
  EXPECT_EQ(unscaled->scale, 1.0);
  EXPECT_LT(unscaled->support, 35);  // the window holds only part of the spread
}

// A pure rotation moves a point x px from the centre by more than the centre (x²θ/f): with the
// focal length the vote runs on angles and the centre's shift comes out exactly.
TEST(ImageShift, WithTheFocalLengthARotationGivesTheCentreShiftExactly) {
  const double f = 512.0, theta = 5.0 * M_PI / 180.0, cx = 320.0;
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> x(0.0, 640.0), y(0.0, 480.0);
  PointMatches matches;
  for (int i = 0; i < 80; ++i) {
    const Eigen::Vector2d p(x(rng), y(rng));
    const double turned = cx + f * std::tan(std::atan((p.x() - cx) / f) + theta);
    if (turned < 0.0 || turned > 640.0) continue;
    matches.push_back({p, Eigen::Vector2d(turned, p.y())});
  }
  ImageShiftOptions shifts_only;
  shifts_only.max_scale_change = 0.0;
  const auto exact = estimateImageShift(matches, 640, shifts_only, cx, f);
  ASSERT_TRUE(exact.isOk());
  EXPECT_NEAR(exact->shift_px, f * std::tan(theta), 1e-6);
  const auto pixels = estimateImageShift(matches, 640, shifts_only, cx);
  ASSERT_TRUE(pixels.isOk());
  EXPECT_GT(pixels->shift_px - f * std::tan(theta), 1.0);  // the x²θ/f bias
  EXPECT_EQ(estimateImageShift(matches, 640, shifts_only, cx, 0.0).status().code(), StatusCode::kInvalidInput);
}
