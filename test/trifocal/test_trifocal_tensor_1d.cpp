#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "homography_teach_repeat/eval/synthetic_bearing_scene.h"
#include "homography_teach_repeat/trifocal/trifocal_motion.h"
#include "homography_teach_repeat/trifocal/trifocal_tensor_1d.h"

using namespace homography_teach_repeat;

namespace {

// Distance between two tensors up to scale and sign.
double tensorDistance(const TrifocalTensor1d& a, const TrifocalTensor1d& b) {
  const TrifocalTensor1d x = a / a.norm(), y = b / b.norm();
  return std::min((x - y).cwiseAbs().maxCoeff(), (x + y).cwiseAbs().maxCoeff());
}

// A random general configuration of docs/math.md §5 (omnidirectional bearings: landmarks anywhere).
struct Configuration {
  TrifocalMotion motion;
  std::vector<Eigen::Vector2d> landmarks;
  std::vector<BearingTriplet> triplets;
};

Configuration randomConfiguration(std::mt19937& rng, int landmarks = 40) {
  std::uniform_real_distribution<double> angle(-0.8, 0.8), shift(-2.0, 2.0), x(-8.0, 8.0), z(3.0, 15.0);
  Configuration c;
  c.motion.theta_second = angle(rng);
  c.motion.theta_third = angle(rng);
  c.motion.t_second = Eigen::Vector2d(shift(rng), shift(rng));
  c.motion.t_third = Eigen::Vector2d(shift(rng), shift(rng));
  for (int n = 0; n < landmarks; ++n) {
    const Eigen::Vector2d p(x(rng), z(rng));
    c.landmarks.push_back(p);
    c.triplets.push_back({projectBearing(c.motion, p, 1), projectBearing(c.motion, p, 2), projectBearing(c.motion, p, 3)});
  }
  return c;
}

std::vector<BearingTriplet> firstN(const std::vector<BearingTriplet>& t, std::size_t n) {
  return std::vector<BearingTriplet>(t.begin(), t.begin() + static_cast<std::ptrdiff_t>(n));
}

}  // namespace

// Eq. 2 with the minors; eq. 6 for the calibrated tensor (docs/math.md §5.2).
TEST(TrifocalTensor1d, MinorsSatisfyTheTrilinearAndCalibrationConstraints) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 50; ++trial) {
    const Configuration c = randomConfiguration(rng);
    const TrifocalTensor1d T = tensorFromMotion(c.motion);
    for (const auto& t : c.triplets) EXPECT_NEAR(trilinearResidual(T, t), 0.0, 1e-12);
    EXPECT_LT(calibrationResidual(T / T.norm()).cwiseAbs().maxCoeff(), 1e-12);
  }
}

// TT7 from 7 triplets, TT5 from 5, TT4 from a wall (3 triplets) and 1 off it: the true tensor.
TEST(TrifocalTensor1d, MinimalEstimatorsAreExact) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> along(-6.0, 6.0), wall_angle(-0.6, 0.6), wall_distance(8.0, 20.0);
  for (int trial = 0; trial < 50; ++trial) {
    const Configuration c = randomConfiguration(rng);
    const TrifocalTensor1d truth = tensorFromMotion(c.motion);
    const auto tt7 = estimateTT7(firstN(c.triplets, 7));
    ASSERT_TRUE(tt7.isOk()) << tt7.status().toString();
    EXPECT_LT(tensorDistance(*tt7, truth), 1e-8);
    const auto tt5 = estimateTT5(firstN(c.triplets, 5));
    ASSERT_TRUE(tt5.isOk()) << tt5.status().toString();
    EXPECT_LT(tensorDistance(*tt5, truth), 1e-8);
    // A wall n·x = d with three landmarks on it.
    const double phi = wall_angle(rng), d = wall_distance(rng);
    const Eigen::Vector2d normal(std::sin(phi), std::cos(phi)), direction(normal.y(), -normal.x());
    std::vector<BearingTriplet> wall;
    for (int n = 0; n < 3; ++n) {
      const Eigen::Vector2d p = d * normal + along(rng) * direction;
      wall.push_back({projectBearing(c.motion, p, 1), projectBearing(c.motion, p, 2), projectBearing(c.motion, p, 3)});
    }
    const auto tt4 = estimateTT4(wall, firstN(c.triplets, 1));
    ASSERT_TRUE(tt4.isOk()) << tt4.status().toString();
    EXPECT_LT(tensorDistance(*tt4, truth), 1e-7);
  }
}

// The corrected transfer (docs/math.md §5.4) predicts each view's bearing from the other two.
TEST(TrifocalTensor1d, TransferPredictsEveryView) {
  std::mt19937 rng(5);
  const Configuration c = randomConfiguration(rng);
  const TrifocalTensor1d T = -3.1 * tensorFromMotion(c.motion);  // any scale and sign
  for (const auto& t : c.triplets) {
    for (int view = 1; view <= 3; ++view) EXPECT_LT(transferAngleError(T, t, view), 1e-9);
    EXPECT_LT(transferError(T, t), 1e-9);
  }
  // A wrong match is seen: the third bearing turned by 0.05 rad.
  BearingTriplet wrong = c.triplets[0];
  wrong.third = bearingFromAngle(bearingAngle(wrong.third) + 0.05);
  EXPECT_GT(transferAngleError(T, wrong, 3), 0.04);
  EXPECT_GT(transferError(T, wrong), 0.01);
  // The trigonometry-free test agrees with the angle.
  std::mt19937 noise_rng(1);
  std::normal_distribution<double> noise(0.0, 0.01);
  for (const auto& t : c.triplets) {
    BearingTriplet noisy{bearingFromAngle(bearingAngle(t.first) + noise(noise_rng)),
                         bearingFromAngle(bearingAngle(t.second) + noise(noise_rng)),
                         -2.0 * bearingFromAngle(bearingAngle(t.third) + noise(noise_rng))};  // any scale, sign
    for (const double threshold : {0.003, 0.01, 0.03}) {
      EXPECT_EQ(transferErrorBelow(T, noisy, threshold), transferError(T, noisy) < threshold);
    }
  }
  EXPECT_FALSE(transferErrorBelow(T, BearingTriplet{Bearing(NAN, 1), wrong.second, wrong.third}, 0.1));
}

// Eq. 4: the tensor of pixel "bearings" (x, 1), calibrated, is the calibrated tensor; only the
// calibrated one satisfies eq. 6.
TEST(TrifocalTensor1d, CalibrationTransformOfEquation4) {
  const LineCamera1d camera;
  std::mt19937 rng(6);
  const TrifocalMotion motion = movementB();
  const BearingScene scene = randomBearingScene(motion, camera, 30, BearingSceneOptions{}, rng);
  ASSERT_EQ(scene.triplets.size(), 30U);
  std::vector<BearingTriplet> pixel;
  for (const auto& t : scene.triplets) {
    auto toPixel = [&](const Bearing& u) {
      return Bearing(camera.focal_px * u(0) / u(1) + camera.principal_px, 1.0);
    };
    pixel.push_back({toPixel(t.first), toPixel(t.second), toPixel(t.third)});
  }
  const auto pixel_tensor = estimateTT7(pixel);
  ASSERT_TRUE(pixel_tensor.isOk()) << pixel_tensor.status().toString();
  const TrifocalTensor1d Tp = *pixel_tensor;
  EXPECT_GT(calibrationResidual(Tp / Tp.norm()).cwiseAbs().maxCoeff(), 1e-3);
  const TrifocalTensor1d Tc = calibrateTensor(Tp, camera.focal_px, camera.principal_px);
  EXPECT_LT(tensorDistance(Tc, tensorFromMotion(motion)), 1e-6);
  EXPECT_LT(calibrationResidual(Tc / Tc.norm()).cwiseAbs().maxCoeff(), 1e-6);
}

// With noise, TT5 (eq. 6 enforced) is closer to the truth than TT7 on average (paper 003 §V).
TEST(TrifocalTensor1d, TT5BeatsTT7UnderNoise) {
  const LineCamera1d camera;
  std::mt19937 rng(7);
  double tt5_error = 0.0, tt7_error = 0.0;
  for (int trial = 0; trial < 100; ++trial) {
    BearingSceneOptions options;
    options.noise_px = 1.0;
    const TrifocalMotion motion = trial % 2 ? movementA() : movementB();
    const BearingScene scene = randomBearingScene(motion, camera, 30, options, rng);
    const auto tt5 = estimateTT5(scene.triplets);
    const auto tt7 = estimateTT7(scene.triplets);
    ASSERT_TRUE(tt5.isOk() && tt7.isOk());
    tt5_error += tensorDistance(*tt5, tensorFromMotion(motion));
    tt7_error += tensorDistance(*tt7, tensorFromMotion(motion));
  }
  EXPECT_LT(tt5_error, tt7_error);
}

// With a dominant wall and forward motion (MovB, Fig. 4's scene: 20 matches on a wall 20 units
// ahead, 10 off it, 1 px), TT4 is not worse than TT5 in rotation (paper 003 §V). It needs the plane
// rows weighted by their propagated noise: with unit weights TT4 was 10-20 % worse here.
TEST(TrifocalTensor1d, TT4IsNotWorseThanTT5WithADominantPlaneInForwardMotion) {
  const LineCamera1d camera;
  std::mt19937 rng(8);
  const TrifocalMotion motion = movementB();
  // The smaller rotation error of the two closed-form candidates (the prior's choice in eval_trifocal).
  auto rotationError = [&](const Expected<TrifocalTensor1d>& T, const std::vector<BearingTriplet>& triplets) {
    EXPECT_TRUE(T.isOk());
    const auto candidates = motionCandidates(*T, triplets);
    EXPECT_TRUE(candidates.isOk());
    double best = INFINITY;
    for (const auto& c : *candidates) {
      best = std::min(best, std::pow(c.motion.theta_second - motion.theta_second, 2) +
                                std::pow(c.motion.theta_third - motion.theta_third, 2));
    }
    return best;
  };
  double tt4_squared = 0.0, tt5_squared = 0.0;
  const int runs = 300;
  for (int run = 0; run < runs; ++run) {
    BearingSceneOptions options;
    options.noise_px = 1.0;
    const BearingScene wall = planeBearingScene(motion, camera, 20, 20.0, options, rng);
    const BearingScene off = randomBearingScene(motion, camera, 10, options, rng);
    std::vector<BearingTriplet> all = wall.triplets;
    all.insert(all.end(), off.triplets.begin(), off.triplets.end());
    tt4_squared += rotationError(estimateTT4(wall.triplets, off.triplets), all);
    tt5_squared += rotationError(estimateTT5(all), all);
  }
  const double tt4_rms = std::sqrt(tt4_squared / (2 * runs)), tt5_rms = std::sqrt(tt5_squared / (2 * runs));
  EXPECT_LE(tt4_rms, tt5_rms) << "RMS rotation error TT4 " << tt4_rms * 180.0 / M_PI << " deg, TT5 "
                              << tt5_rms * 180.0 / M_PI << " deg";
  std::printf("RMS rotation error at 1 px, MovB, dominant plane: TT4 %.3f deg, TT5 %.3f deg\n",
              tt4_rms * 180.0 / M_PI, tt5_rms * 180.0 / M_PI);
}

TEST(TrifocalTensor1d, TooFewTriplets) {
  std::mt19937 rng(8);
  const Configuration c = randomConfiguration(rng, 6);
  EXPECT_EQ(estimateTT7(c.triplets).status().code(), StatusCode::kTooFewPoints);
  EXPECT_EQ(estimateTT5(firstN(c.triplets, 4)).status().code(), StatusCode::kTooFewPoints);
  EXPECT_EQ(estimateTT4(firstN(c.triplets, 3), {}).status().code(), StatusCode::kTooFewPoints);
  EXPECT_EQ(estimateTT4(firstN(c.triplets, 2), firstN(c.triplets, 1)).status().code(), StatusCode::kTooFewPoints);
  EXPECT_EQ(estimateBearingHomography({Bearing(0, 1), Bearing(0.1, 1)}, {Bearing(0, 1), Bearing(0.1, 1)}).status().code(),
            StatusCode::kTooFewPoints);
}

TEST(TrifocalTensor1d, NonFiniteBearingsAreRefused) {
  std::mt19937 rng(9);
  Configuration c = randomConfiguration(rng, 10);
  c.triplets[3].second = Bearing(NAN, 1.0);
  EXPECT_EQ(estimateTT7(c.triplets).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(estimateTT5(c.triplets).status().code(), StatusCode::kInvalidInput);
  c.triplets[3].second = Bearing(0.0, 0.0);
  EXPECT_EQ(estimateTT5(c.triplets).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(estimateTT4(firstN(c.triplets, 3), {c.triplets[3]}).status().code(), StatusCode::kInvalidInput);
  EXPECT_TRUE(std::isinf(transferError(tensorFromMotion(c.motion), c.triplets[3])));
}

// Identical views (no baseline): every bearing equal in the three views; the null space has four
// dimensions.
TEST(TrifocalTensor1d, IdenticalViewsAreDegenerate) {
  std::mt19937 rng(10);
  Configuration c = randomConfiguration(rng, 30);
  for (auto& t : c.triplets) t.second = t.third = t.first;
  const auto tt7 = estimateTT7(c.triplets);
  EXPECT_EQ(tt7.status().code(), StatusCode::kDegenerate) << tt7.status().toString();
  EXPECT_EQ(estimateTT5(c.triplets).status().code(), StatusCode::kDegenerate);
  // Pure rotation (coincident centres): degenerate as well.
  for (auto& t : c.triplets) {
    t.second = bearingFromAngle(bearingAngle(t.first) - 0.2);
    t.third = bearingFromAngle(bearingAngle(t.first) + 0.1);
  }
  EXPECT_EQ(estimateTT7(c.triplets).status().code(), StatusCode::kDegenerate);
  EXPECT_EQ(estimateTT5(c.triplets).status().code(), StatusCode::kDegenerate);
  // All landmarks on one bearing of a 1D homography: three equal pairs.
  EXPECT_EQ(estimateBearingHomography({Bearing(0, 1), Bearing(0, 1), Bearing(0, 1)},
                                      {Bearing(0.1, 1), Bearing(0.1, 1), Bearing(0.1, 1)})
                .status()
                .code(),
            StatusCode::kDegenerate);
}
