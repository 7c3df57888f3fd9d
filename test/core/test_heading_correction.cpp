#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <random>

#include "homography_teach_repeat/heading_correction.h"

using namespace homography_teach_repeat;

namespace {

constexpr double kF = 500.0;
constexpr double kX0 = 319.5;

// A textured "wall" of vertical bands of random grey, seen by a camera that yaws by `theta`
// (exact image warp by K R K⁻¹).
cv::Mat wallImage(double theta, bool periodic = false) {
  // Periodic: the same 36 px pair of bands repeated, so every line has a twin 36 px away.
  static const cv::Mat periodic_texture = [] {
    cv::Mat t(480, 1600, CV_8UC1, cv::Scalar(200));
    for (int x = 0; x < t.cols; x += 36) t.colRange(x, std::min(t.cols, x + 18)).setTo(60);
    t.rowRange(0, 60).setTo(128);
    t.rowRange(420, 480).setTo(128);
    return t;
  }();
  static const cv::Mat random_texture = [] {
    std::mt19937 rng(4);
    std::uniform_int_distribution<int> grey(20, 235), width(12, 40);
    cv::Mat t(480, 1600, CV_8UC1);
    int x = 0;
    while (x < t.cols) {
      const int w = width(rng);
      t.colRange(x, std::min(t.cols, x + w)).setTo(grey(rng));
      x += w;
    }
    t.rowRange(0, 60).setTo(128);
    t.rowRange(420, 480).setTo(128);
    return t;
  }();
  const cv::Mat& texture = periodic ? periodic_texture : random_texture;
  const cv::Matx33d K(kF, 0, kX0, 0, kF, 239.5, 0, 0, 1);
  // The texture is a fronto-parallel wall imaged with the same K, centred 480 px to the right.
  const cv::Matx33d shift(1, 0, -480, 0, 1, 0, 0, 0, 1);
  const cv::Matx33d R(std::cos(theta), 0, std::sin(theta), 0, 1, 0, -std::sin(theta), 0,
                      std::cos(theta));
  cv::Mat image;
  cv::warpPerspective(texture, image, K * R * K.inv() * shift, cv::Size(640, 480), cv::INTER_AREA,
                      cv::BORDER_CONSTANT, cv::Scalar(128));
  cv::GaussianBlur(image, image, cv::Size(3, 3), 0.6);
  return image;
}

}  // namespace

// The whole chain on rendered images: extraction, matching, LMedS, μ; and f calibrated back from
// μ against the known rotations (paper 002 §4.1).
TEST(HeadingCorrection, RecoversYawAndCalibratesFocalLength) {
  VerticalLineExtractor extractor;
  const auto reference = *extractor.extract(wallImage(0.0));
  ASSERT_GE(reference.size(), 15u);
  const HeadingCorrector corrector(HeadingCorrectionOptions(), LineCamera{kF, kX0});
  std::vector<std::pair<double, double>> samples;
  for (const double degrees : {-6.0, -3.0, -1.0, 1.0, 3.0, 6.0}) {
    const double theta = degrees * M_PI / 180.0;
    const auto current = *extractor.extract(wallImage(theta));
    const auto correction = corrector.estimate(reference, current);
    ASSERT_TRUE(correction.isOk()) << degrees << ": " << correction.status().toString();
    EXPECT_NEAR(correction->theta, theta, 0.1 * M_PI / 180.0) << degrees;
    EXPECT_GE(correction->inliers, 10);
    samples.emplace_back(theta, correction->mu);
  }
  const auto fit = fitFocalFromMu(samples);
  ASSERT_TRUE(fit.isOk());
  EXPECT_NEAR(fit->f, kF, 0.02 * kF);
}

// Guided matching: on a wall whose lines repeat every 36 px, a yaw of 8° (≈ 70 px, two periods)
// pairs each line with a twin unless the matcher knows roughly how far the image turned; with a
// prediction 1.5° off (odometry), μ gives the yaw.
TEST(HeadingCorrection, PredictedRotationGuidesTheMatching) {
  VerticalLineExtractor extractor;
  const auto reference = *extractor.extract(wallImage(0.0, true));
  ASSERT_GE(reference.size(), 15u);
  const HeadingCorrector corrector(HeadingCorrectionOptions(), LineCamera{kF, kX0});
  for (const double degrees : {-8.0, 8.0}) {
    const double theta = degrees * M_PI / 180.0;
    const auto current = *extractor.extract(wallImage(theta, true));
    const auto guided = corrector.estimate(reference, current, theta - std::copysign(1.5, degrees) * M_PI / 180.0);
    ASSERT_TRUE(guided.isOk()) << degrees << ": " << guided.status().toString();
    EXPECT_NEAR(guided->theta, theta, 0.1 * M_PI / 180.0) << degrees;
    const auto unguided = corrector.estimate(reference, current);
    if (unguided) {
      EXPECT_GT(std::abs(unguided->theta - theta), 1.0 * M_PI / 180.0) << degrees << ": the twins were matched";
    }
  }
  // A non-finite prediction is no prediction.
  const auto current = *extractor.extract(wallImage(0.01, true));
  const auto plain = corrector.estimate(reference, current, NAN);
  ASSERT_TRUE(plain.isOk()) << plain.status().toString();
  EXPECT_NEAR(plain->theta, 0.01, 0.1 * M_PI / 180.0);
}

TEST(HeadingCorrection, FailureStatuses) {
  const HeadingCorrector corrector(HeadingCorrectionOptions(), LineCamera{kF, kX0});
  VerticalLineExtractor extractor;
  const auto reference = *extractor.extract(wallImage(0.0));
  // Blank image: no lines, so too few matches.
  const auto blank = *extractor.extract(cv::Mat(480, 640, CV_8UC1, cv::Scalar(100)));
  EXPECT_EQ(corrector.estimate(reference, blank).status().code(), StatusCode::kTooFewPoints);
  // All reference lines of one polarity, all current lines of the other: nothing may match.
  std::vector<VerticalLine> dark_left, dark_right;
  for (const auto& l : reference) {
    (l.polarity == EdgePolarity::kDarkLeft ? dark_left : dark_right).push_back(l);
  }
  ASSERT_GE(dark_left.size(), 3u);
  ASSERT_GE(dark_right.size(), 3u);
  EXPECT_EQ(corrector.estimate(dark_left, dark_right).status().code(), StatusCode::kTooFewPoints);
  // Lines that agree on nothing: random positions.
  std::vector<VerticalLine> scrambled = reference;
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> x(0.0, 640.0);
  for (auto& l : scrambled) l.x = x(rng);
  const auto status = corrector.estimate(reference, scrambled).status().code();
  EXPECT_TRUE(status == StatusCode::kNoConsensus || status == StatusCode::kTooFewPoints)
      << static_cast<int>(status);
  // NaN calibration is refused at construction.
  EXPECT_THROW(HeadingCorrector(HeadingCorrectionOptions(), LineCamera{std::nan(""), kX0}),
               std::invalid_argument);
  std::vector<VerticalLine> with_nan = reference;
  with_nan[0].x = std::nan("");
  EXPECT_EQ(corrector.estimate(with_nan, reference).status().code(), StatusCode::kInvalidInput);
}
