#include <gtest/gtest.h>

#include <Eigen/Cholesky>

#include <cmath>
#include <limits>
#include <random>

#include "homography_teach_repeat/eval/pose_consistency.h"

using namespace homography_teach_repeat;

namespace {

// A correlated (x, y, yaw) covariance like a pose's: centimetres, a degree, coupled.
Eigen::Matrix3d correlatedCovariance() {
  Eigen::Matrix3d a;
  a << 0.03, 0.00, 0.0, 0.01, 0.02, 0.0, 0.002, -0.004, 0.015;
  return a * a.transpose();
}

// Errors drawn from N(0, truth_covariance), scored against `reported` covariance.
PoseConsistencySummary scoreGaussianErrors(const Eigen::Matrix3d& truth_covariance,
                                           const Eigen::Matrix3d& reported, int samples) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal;
  const Eigen::Matrix3d l = truth_covariance.llt().matrixL();
  PoseConsistency consistency;
  const Pose2D truth(2.0, -1.0, 3.1);  // near +pi: the yaw errors cross the wrap
  for (int i = 0; i < samples; ++i) {
    const Eigen::Vector3d e = l * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    const Pose2D estimate(truth.x + e.x(), truth.y + e.y(), wrapToPi(truth.yaw + e.z()));
    EXPECT_TRUE(consistency.add(estimate, reported, truth).isOk());
  }
  return consistency.summary().value();
}

}  // namespace

TEST(PoseConsistency, AnHonestCovarianceScoresChiSquareWithThreeDegreesOfFreedom) {
  const Eigen::Matrix3d p = correlatedCovariance();
  const PoseConsistencySummary s = scoreGaussianErrors(p, p, 20000);
  EXPECT_EQ(s.samples, 20000U);
  // chi-square(3): mean 3 (standard error sqrt(6 / 20000) = 0.017), median 2.366, 5 % above 7.81.
  EXPECT_NEAR(s.nees_mean, 3.0, 0.07);
  EXPECT_NEAR(s.nees_median, 2.366, 0.07);
  EXPECT_NEAR(s.fraction_above_chi2_95, 0.05, 0.006);
  EXPECT_NEAR(s.position_error_rms, std::sqrt(p(0, 0) + p(1, 1)),
              0.02 * std::sqrt(p(0, 0) + p(1, 1)));
  EXPECT_NEAR(s.heading_error_rms, std::sqrt(p(2, 2)), 0.02 * std::sqrt(p(2, 2)));
  EXPECT_NEAR(s.position_sigma_rms, std::sqrt(p(0, 0) + p(1, 1)), 1e-12);
  EXPECT_NEAR(s.heading_sigma_rms, std::sqrt(p(2, 2)), 1e-12);
}

TEST(PoseConsistency, AnOverconfidentCovarianceScoresHigh) {
  // Claiming half the standard deviation: the NEES is four times chi-square(3).
  const Eigen::Matrix3d p = correlatedCovariance();
  const PoseConsistencySummary s = scoreGaussianErrors(p, p / 4.0, 20000);
  EXPECT_NEAR(s.nees_mean, 12.0, 0.3);
  EXPECT_GT(s.fraction_above_chi2_95, 0.4);  // P(chi2(3) > 7.81 / 4) = 0.58
}

TEST(PoseConsistency, KnownErrorAndHeadingAcrossThePiWrap) {
  PoseConsistency consistency;
  const Eigen::Matrix3d covariance = Eigen::Vector3d(0.01, 1.0, 1e-4).asDiagonal();
  // 0.1 m along x with a 0.1 m sigma: NEES 1; yaw +pi - 0.01 against -pi + 0.01 is 0.02 rad off,
  // not 2 pi: NEES 4.
  ASSERT_TRUE(consistency.add(Pose2D(1.1, 0.0, 0.0), covariance, Pose2D(1.0, 0.0, 0.0)).isOk());
  ASSERT_TRUE(
      consistency.add(Pose2D(0.0, 0.0, M_PI - 0.01), covariance, Pose2D(0.0, 0.0, -M_PI + 0.01))
          .isOk());
  const auto s = consistency.summary();
  ASSERT_TRUE(s.isOk());
  EXPECT_NEAR(s->nees_mean, 2.5, 1e-9);
  EXPECT_NEAR(s->nees_median, 2.5, 1e-9);  // even count: the mean of the middle two
  EXPECT_NEAR(s->position_error_rms, std::sqrt(0.01 / 2.0), 1e-12);
  EXPECT_NEAR(s->heading_error_rms, std::sqrt(0.0004 / 2.0), 1e-9);
  EXPECT_EQ(s->fraction_above_chi2_95, 0.0);
}

TEST(PoseConsistency, RefusesWhatCannotBeScored) {
  PoseConsistency consistency;
  EXPECT_EQ(consistency.summary().status().code(), StatusCode::kTooFewPoints);
  const Eigen::Matrix3d good = Eigen::Matrix3d::Identity() * 0.01;
  const Pose2D origin(0.0, 0.0, 0.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(consistency.add(Pose2D(nan, 0.0, 0.0), good, origin).code(), StatusCode::kInvalidInput);
  EXPECT_EQ(consistency.add(origin, good, Pose2D(0.0, 0.0, nan)).code(), StatusCode::kInvalidInput);
  Eigen::Matrix3d bad = good;
  bad(2, 2) = 0.0;  // a zero variance: the pose claims to be exact
  EXPECT_EQ(consistency.add(origin, bad, origin).code(), StatusCode::kInvalidInput);
  bad(2, 2) = -0.01;
  EXPECT_EQ(consistency.add(origin, bad, origin).code(), StatusCode::kInvalidInput);
  bad = good;
  bad(0, 1) = 0.005;  // asymmetric
  EXPECT_EQ(consistency.add(origin, bad, origin).code(), StatusCode::kInvalidInput);
  bad = good;
  bad(1, 1) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(consistency.add(origin, bad, origin).code(), StatusCode::kInvalidInput);
  EXPECT_EQ(consistency.rejected(), 6U);
  EXPECT_EQ(consistency.summary().status().code(), StatusCode::kTooFewPoints);
  EXPECT_TRUE(consistency.add(origin, good, origin).isOk());
  EXPECT_EQ(consistency.summary()->samples, 1U);
}

// The integrity score: wrong poses (0.3 m or 5° off) flagged or not, right ones flagged or not.
TEST(IntegrityScore, DetectionAndFalseAlarms) {
  IntegrityScore score;
  const Pose2D truth(1.0, 2.0, 0.5);
  EXPECT_DOUBLE_EQ(score.summary().detection, 1.0);  // nothing wrong yet
  ASSERT_TRUE(score.add(Pose2D(1.0, 2.4, 0.5), true, truth).isOk());    // 0.4 m off, flagged
  ASSERT_TRUE(score.add(Pose2D(1.0, 2.0, 0.6), false, truth).isOk());   // 5.7° off, missed
  ASSERT_TRUE(score.add(Pose2D(1.1, 2.1, 0.52), false, truth).isOk());  // right, quiet
  ASSERT_TRUE(score.add(Pose2D(1.1, 2.1, 0.52), true, truth).isOk());   // right, false alarm
  ASSERT_TRUE(score.add(Pose2D(1.0, 2.0, 0.5), false, truth).isOk());   // right, quiet
  EXPECT_EQ(score.add(Pose2D(NAN, 2.0, 0.5), true, truth).code(), StatusCode::kInvalidInput);
  const IntegritySummary s = score.summary();
  EXPECT_EQ(s.poses, 5u);
  EXPECT_EQ(s.wrong, 2u);
  EXPECT_EQ(s.wrong_flagged, 1u);
  EXPECT_EQ(s.right, 3u);
  EXPECT_EQ(s.right_flagged, 1u);
  EXPECT_DOUBLE_EQ(s.detection, 0.5);
  EXPECT_DOUBLE_EQ(s.false_alarm, 1.0 / 3.0);
}
