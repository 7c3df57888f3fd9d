#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <random>

#include "homography_teach_repeat/mu/heading_correction.h"

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

// The same wall (fronto-parallel, `distance` [m] in front of the reference camera, which sees it
// as wallImage(0)) seen by a camera at `pose` in the reference camera frame: the image warp is
// the 3D plane homography, whose x-z part is the 1D one (planeHomography1d, docs/math.md §4.4) and
// whose y row is 1 at that scale.
cv::Mat wallImageFrom(const PlanarPose& pose, double distance, bool periodic) {
  const auto h = planeHomography1d(pose, Eigen::Vector2d(0.0, 1.0), distance, kF);
  EXPECT_TRUE(h.isOk()) << h.status().toString();
  const cv::Matx33d centred((*h)(0, 0), 0, (*h)(0, 1), 0, 1, 0, (*h)(1, 0), 0, (*h)(1, 1));
  const cv::Matx33d to_centred(1, 0, -kX0, 0, 1, -239.5, 0, 0, 1);
  const cv::Mat reference = wallImage(0.0, periodic);
  cv::Mat image;
  cv::warpPerspective(reference, image, to_centred.inv() * centred * to_centred, reference.size(), cv::INTER_LINEAR,
                      cv::BORDER_CONSTANT, cv::Scalar(128));
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

// Guided by the wall: on the periodic wall 2 m away a lateral offset of 15 cm moves the lines by
// about one period (37 of 36 px), so the rotation alone, even the true one, pairs every line with
// its twin and μ is a period off (as against a calibration board in the simulator); the 1D
// homography of the wall at a prediction 3 cm, 5 cm and 0.5° off (the heading-aided odometry's)
// pairs them right.
TEST(HeadingCorrection, PredictedWallHomographyGuidesTheMatchingPastAPeriod) {
  VerticalLineExtractor extractor;
  const auto reference = *extractor.extract(wallImage(0.0, true));
  ASSERT_GE(reference.size(), 15u);
  const HeadingCorrector corrector(HeadingCorrectionOptions(), LineCamera{kF, kX0});
  const double distance = 2.0;
  const Eigen::Vector2d wall_normal(0.0, 1.0);
  for (const double offset : {-0.15, 0.15}) {
    const PlanarPose truth(offset, 0.05, 2.0 * M_PI / 180.0);
    const auto current = *extractor.extract(wallImageFrom(truth, distance, true));
    const double true_mu = *predictedMu(truth, wall_normal, distance, kF);
    const PlanarPose predicted(offset - std::copysign(0.03, offset), 0.0, truth.theta + 0.5 * M_PI / 180.0);
    const auto guide = planeHomography1d(predicted, wall_normal, distance, kF);
    ASSERT_TRUE(guide.isOk());
    const auto guided = corrector.estimate(reference, current, *guide);
    ASSERT_TRUE(guided.isOk()) << offset << ": " << guided.status().toString();
    EXPECT_NEAR(guided->mu, true_mu, 2.0) << offset;
    const auto by_rotation = corrector.estimate(reference, current, truth.theta);
    // The twins agree on a 1D homography too: a fix, a period off (what the filter cannot tell).
    ASSERT_TRUE(by_rotation.isOk()) << offset << ": " << by_rotation.status().toString();
    EXPECT_GT(std::abs(by_rotation->mu - true_mu), 20.0) << offset << ": the rotation alone found the right lines";
  }
  // A non-finite guide is no guide.
  const auto current = *extractor.extract(wallImage(0.01, true));
  const auto plain = corrector.estimate(reference, current, Eigen::Matrix2d::Constant(NAN));
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
