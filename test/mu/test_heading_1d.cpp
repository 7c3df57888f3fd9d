#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "homography_teach_repeat/mu/heading_1d.h"
#include "homography_teach_repeat/mu/homography_1d.h"
#include "homography_teach_repeat/eval/synthetic_line_scene.h"

using namespace homography_teach_repeat;

namespace {

const LineCamera kCamera{500.0, 331.0};  // x0 ≠ width/2: μ needs centred coordinates (§4.5)

// docs/math.md §4.4 in pixels: H ∝ K (R + t nᵀ/d) K⁻¹, K = [[f, x0], [0, 1]], for the wall nᵀX1 = d.
Eigen::Matrix2d wallHomography(double theta, const Eigen::Vector2d& t, double phi, double d) {
  Eigen::Matrix2d R, K;
  R << std::cos(theta), std::sin(theta), -std::sin(theta), std::cos(theta);
  K << kCamera.f, kCamera.x0, 0.0, 1.0;
  const Eigen::Vector2d n(std::sin(phi), std::cos(phi));
  return K * (R + t * n.transpose() / d) * K.inverse();
}

std::vector<double> referenceXs() { return {120.0, 250.0, 330.0, 415.0, 560.0}; }

}  // namespace

TEST(Heading1d, PureRotationAllMethodsExact) {
  for (const double theta : {-0.17, -0.02, 0.05, 0.17}) {
    const Eigen::Matrix2d H = 2.3 * wallHomography(theta, Eigen::Vector2d::Zero(), 0.4, 5.0);
    EXPECT_NEAR(*headingFromMu(H, kCamera), theta, 1e-12);
    EXPECT_NEAR(*muOf(H, kCamera.x0), kCamera.f * std::tan(theta), 1e-9);
    EXPECT_NEAR(*headingFromT(H, kCamera), theta, 1e-12);
    EXPECT_NEAR(*headingMagnitudeFromEigenvalues(-H), std::abs(theta), 1e-7);
    const auto motion = completeMotion1d(H, kCamera, referenceXs());
    ASSERT_TRUE(motion.isOk()) << motion.status().toString();
    bool found = false;
    for (const auto& m : *motion) found |= std::abs(m.theta - theta) < 1e-7;
    EXPECT_TRUE(found) << theta;
  }
}

// With translation μ = f (d sinθ + tx cosφ)/(d cosθ + tz cosφ) (docs/math.md §4.5).
TEST(Heading1d, MuWithTranslationMatchesTheClosedForm) {
  const double theta = 0.1, phi = 0.3, d = 6.0;
  const Eigen::Vector2d t(0.4, -0.7);
  const auto mu = muOf(wallHomography(theta, t, phi, d), kCamera.x0);
  ASSERT_TRUE(mu.isOk());
  EXPECT_NEAR(*mu, kCamera.f * (d * std::sin(theta) + t.x() * std::cos(phi)) /
                       (d * std::cos(theta) + t.y() * std::cos(phi)),
              1e-9);
}

// Complete motion with the true scale (d2/d1 known) contains the true motion (docs/math.md §4.7).
TEST(Heading1d, CompleteMotionWithKnownDepthRatio) {
  const double theta = 0.2, phi = -0.35, d = 5.0;
  const Eigen::Vector2d t(0.6, -1.5);
  const Eigen::Vector2d n(std::sin(phi), std::cos(phi));
  Eigen::Matrix2d R;
  R << std::cos(theta), std::sin(theta), -std::sin(theta), std::cos(theta);
  const Eigen::Matrix2d Hc = R + t * n.transpose() / d;
  const double ratio = Hc.determinant();  // = d2/d1
  const auto motion = completeMotion1d(-0.7 * wallHomography(theta, t, phi, d), kCamera,
                                       referenceXs(), ratio);
  ASSERT_TRUE(motion.isOk()) << motion.status().toString();
  ASSERT_EQ(motion->size(), 2u);
  int matched = 0;
  for (const auto& m : *motion) {
    if (std::abs(m.theta - theta) < 1e-9) {
      EXPECT_LT((m.translation_over_distance - t / d).norm(), 1e-9);
      EXPECT_LT((m.normal - n).norm(), 1e-9);
      ++matched;
    }
  }
  EXPECT_EQ(matched, 1);
  // Without the ratio (det = 1) the heading is off when advancing towards the wall (§4.7).
  const auto approximate = completeMotion1d(wallHomography(theta, t, phi, d), kCamera,
                                            referenceXs());
  ASSERT_TRUE(approximate.isOk());
  double best = 1e9;
  for (const auto& m : *approximate) best = std::min(best, std::abs(m.theta - theta));
  EXPECT_GT(best, 1e-3);
}

// The projection helper agrees with the homography of the wall the lines lie on.
TEST(Heading1d, SyntheticLinesFollowTheWallHomography) {
  const double phi = 0.3, d = 5.0;
  const Eigen::Vector2d n(std::sin(phi), std::cos(phi));
  const PlanarPose pose(0.4, 0.8, 0.12);  // camera 2 in frame 1
  // t of docs/math.md §4.1 (X2 = R X1 + t): t = −R C.
  Eigen::Matrix2d R;
  R << std::cos(pose.theta), std::sin(pose.theta), -std::sin(pose.theta), std::cos(pose.theta);
  const Eigen::Vector2d t = -R * Eigen::Vector2d(pose.x, pose.z);
  const Eigen::Matrix2d H = wallHomography(pose.theta, t, phi, d);
  for (const double s : {-2.0, -0.5, 0.7, 1.5}) {
    const Eigen::Vector2d point = n * d + s * Eigen::Vector2d(n.y(), -n.x());
    const auto x1 = projectVerticalLine(kCamera, PlanarPose(), point, 1000.0);
    const auto x2 = projectVerticalLine(kCamera, pose, point, 1000.0);
    ASSERT_TRUE(x1 && x2);
    EXPECT_NEAR(transferResidual1d(H, {*x1, *x2}), 0.0, 1e-9);
  }
}

TEST(Heading1d, PlaneHomographyPredictsTheMuOfProjectedLines) {
  // The μ a camera measures against a reference keyframe, predicted from its pose and the
  // keyframe's wall (what the μ-mode filter compares with the measurement): lines on the wall
  // projected into both cameras, the 1D homography fitted to them, μ read off the centred fit.
  const double phi = -0.25, d = 3.0;
  const Eigen::Vector2d n(std::sin(phi), std::cos(phi));
  for (const PlanarPose& pose : {PlanarPose(0.0, 0.0, 0.1), PlanarPose(0.3, 0.5, -0.05),
                                 PlanarPose(-0.2, 1.2, 0.08)}) {
    std::vector<LineCorrespondence> lines;
    for (double s = -2.5; s <= 2.5; s += 0.25) {
      const Eigen::Vector2d point = n * d + s * Eigen::Vector2d(n.y(), -n.x());
      const auto x1 = projectVerticalLine(kCamera, PlanarPose(), point, 1000.0);
      const auto x2 = projectVerticalLine(kCamera, pose, point, 1000.0);
      if (x1 && x2) lines.push_back({*x1, *x2});
    }
    ASSERT_GE(lines.size(), 6u);
    const auto fitted = estimateHomography1dDlt(lines);
    ASSERT_TRUE(fitted.isOk());
    const auto measured = muOf(*fitted, kCamera.x0);
    const auto predicted = predictedMu(pose, n, d, kCamera.f);
    ASSERT_TRUE(measured.isOk() && predicted.isOk());
    EXPECT_NEAR(*predicted, *measured, 1e-6);
    // Lateral translation over-rotates (docs/math.md §4.5): μ is not f tanθ once the camera moved.
    if (pose.x != 0.0) {
      EXPECT_GT(std::abs(*predicted - kCamera.f * std::tan(pose.theta)), 10.0);
    }
  }
  EXPECT_EQ(predictedMu(PlanarPose(), Eigen::Vector2d(1.0, 1.0), d, kCamera.f).status().code(),
            StatusCode::kInvalidInput);
  EXPECT_EQ(predictedMu(PlanarPose(), n, 0.0, kCamera.f).status().code(), StatusCode::kInvalidInput);
  // Behind the wall: the wall is not in front of the current camera.
  EXPECT_EQ(predictedMu(PlanarPose(0.0, 4.0, 0.0), Eigen::Vector2d(0.0, 1.0), d, kCamera.f).status().code(),
            StatusCode::kDegenerate);
}

TEST(Heading1d, BadInput) {
  const Eigen::Matrix2d H = wallHomography(0.1, Eigen::Vector2d::Zero(), 0.0, 5.0);
  EXPECT_EQ(headingFromMu(H, LineCamera{std::nan(""), 320.0}).status().code(),
            StatusCode::kInvalidInput);
  EXPECT_EQ(headingFromT(H, LineCamera{0.0, 320.0}).status().code(), StatusCode::kInvalidInput);
  Eigen::Matrix2d nan_h = H;
  nan_h(0, 1) = std::nan("");
  EXPECT_EQ(muOf(nan_h, 320.0).status().code(), StatusCode::kNotFinite);
  Eigen::Matrix2d reflection;
  reflection << -1.0, 0.0, 0.0, 1.0;
  EXPECT_EQ(headingMagnitudeFromEigenvalues(reflection).status().code(), StatusCode::kDegenerate);
  EXPECT_EQ(completeMotion1d(H, kCamera, {}).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(completeMotion1d(H, kCamera, referenceXs(), -1.0).status().code(),
            StatusCode::kInvalidInput);
  Eigen::Matrix2d zero_h22;
  zero_h22 << 1.0, 2.0, 1.0, -kCamera.x0;  // centred h22 = h21 x0 + h22 = 0
  EXPECT_EQ(muOf(zero_h22, kCamera.x0).status().code(), StatusCode::kDegenerate);
}

TEST(Heading1d, FocalFromMuCalibration) {
  std::vector<std::pair<double, double>> samples;
  for (int k = -5; k <= 5; ++k) {
    const double theta = 0.03 * k;
    samples.emplace_back(theta, 612.5 * std::tan(theta));
  }
  const auto fit = fitFocalFromMu(samples);
  ASSERT_TRUE(fit.isOk());
  EXPECT_NEAR(fit->f, 612.5, 1e-9);
  EXPECT_NEAR(fit->rms_residual_px, 0.0, 1e-9);
  EXPECT_EQ(fit->samples, 10);
  EXPECT_EQ(fitFocalFromMu({{0.0, 1.0}}).status().code(), StatusCode::kTooFewPoints);
  EXPECT_EQ(fitFocalFromMu({{0.1, -50.0}}).status().code(), StatusCode::kDegenerate);
  EXPECT_EQ(fitFocalFromMu({{std::nan(""), 1.0}}).status().code(), StatusCode::kInvalidInput);
}
