#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "homography_teach_repeat/eval/synthetic_bearing_scene.h"
#include "homography_teach_repeat/trifocal/trifocal_motion.h"
#include "homography_teach_repeat/trifocal/trifocal_ransac.h"

using namespace homography_teach_repeat;

namespace {

struct Counts {
  int inliers_found = 0;    // true matches among the inliers
  int outliers_kept = 0;    // wrong matches among the inliers
};

// The triplets the final tensor accepts (transfer error below the RANSAC threshold).
std::vector<int> accepted(const TrifocalRansacResult& result, const std::vector<BearingTriplet>& triplets,
                          double threshold = TrifocalRansacOptions().max_transfer_error) {
  std::vector<int> indices;
  for (std::size_t n = 0; n < triplets.size(); ++n) {
    if (transferError(result.tensor, triplets[n]) < threshold) indices.push_back(static_cast<int>(n));
  }
  return indices;
}

Counts count(const std::vector<int>& inliers, const std::vector<int>& wrong) {
  Counts c;
  for (const int k : inliers) {
    if (std::binary_search(wrong.begin(), wrong.end(), k)) {
      ++c.outliers_kept;
    } else {
      ++c.inliers_found;
    }
  }
  return c;
}

// Rotation error of the candidate of the closed form nearest the truth (what an odometry prior
// would pick; the disambiguation is tested in test_trifocal_motion).
double rotationError(const TrifocalTensor1d& T, const std::vector<BearingTriplet>& inliers, const TrifocalMotion& truth) {
  const auto candidates = motionCandidates(T, inliers);
  if (!candidates) return INFINITY;
  double best = INFINITY;
  for (const auto& c : *candidates) {
    best = std::min(best, std::max(std::abs(std::remainder(c.motion.theta_second - truth.theta_second, 2 * M_PI)),
                                   std::abs(std::remainder(c.motion.theta_third - truth.theta_third, 2 * M_PI))));
  }
  return best;
}

std::vector<BearingTriplet> pick(const std::vector<BearingTriplet>& t, const std::vector<int>& indices) {
  std::vector<BearingTriplet> out;
  for (const int k : indices) out.push_back(t[static_cast<std::size_t>(k)]);
  return out;
}

}  // namespace

// docs/math.md §5.8 and paper 003 §IV: 40 % outliers, P = 0.99.
TEST(TrifocalRansac, IterationCountsOfThePaper) {
  EXPECT_EQ(ransacIterations(0.6, 7, 0.99, 100000), 163);
  EXPECT_EQ(ransacIterations(0.6, 5, 0.99, 100000), 57);
  EXPECT_EQ(ransacIterations(0.6, 3, 0.99, 100000), 19);
  EXPECT_EQ(ransacIterations(0.6, 1, 0.99, 100000), 6);
  EXPECT_EQ(ransacIterations(0.0, 5, 0.99, 321), 321);
  EXPECT_EQ(ransacIterations(1.0, 5, 0.99, 321), 1);
}

// 50 triplets, 40 % wrong matches, 0.5 px noise: the good ones and the motion are kept. MovA for
// both estimators; MovB (forward motion, little parallax: good matches near the epipole exceed the
// 3 mrad transfer threshold, paper 003 Fig. 3 and eval_trifocal) with TT5 and looser bounds.
TEST(TrifocalRansac, RejectsWrongMatches) {
  const LineCamera1d camera;
  struct Case {
    TrifocalMethod method;
    TrifocalMotion motion;
    int min_found;        // of 30
    double max_rotation;  // [rad]
  };
  const Case cases[] = {{TrifocalMethod::kTT5, movementA(), 27, 0.01},
                        {TrifocalMethod::kTT7, movementA(), 22, 0.08},
                        {TrifocalMethod::kTT5, movementB(), 20, 0.05}};
  for (const Case& k : cases) {
    std::mt19937 rng(21);
    for (int trial = 0; trial < 10; ++trial) {
      BearingSceneOptions scene_options;
      scene_options.noise_px = 0.5;
      BearingScene scene = randomBearingScene(k.motion, camera, 50, scene_options, rng);
      const std::vector<int> wrong = corruptTriplets(scene.triplets, 0.4, camera, rng);
      TrifocalRansacOptions options;
      options.method = k.method;
      options.seed = static_cast<unsigned>(trial + 1);
      const auto result = estimateTrifocalRansac(scene.triplets, options);
      ASSERT_TRUE(result.isOk()) << toString(k.method) << ": " << result.status().toString();
      const Counts c = count(accepted(*result, scene.triplets), wrong);
      EXPECT_GE(c.inliers_found, k.min_found) << toString(k.method) << " trial " << trial;
      EXPECT_LE(c.outliers_kept, 2) << toString(k.method) << " trial " << trial;
      EXPECT_LT(rotationError(result->tensor, pick(scene.triplets, result->inliers), k.motion), k.max_rotation)
          << toString(k.method) << " trial " << trial;
      EXPECT_GT(result->iterations, 0);
      EXPECT_LE(result->iterations, options.max_iterations);
      EXPECT_EQ(result->consistent, static_cast<int>(accepted(*result, scene.triplets).size()));
      EXPECT_LE(static_cast<int>(result->inliers.size()), result->consistent);
    }
  }
}

// TT4: a dominant wall (20 triplets at Z = 20), 10 off it, plus 20 wrong matches.
TEST(TrifocalRansac, TT4FindsThePlaneThenTheTensor) {
  const LineCamera1d camera;
  std::mt19937 rng(22);
  for (int trial = 0; trial < 10; ++trial) {
    const TrifocalMotion truth = trial % 2 ? movementA() : movementB();
    BearingSceneOptions scene_options;
    scene_options.noise_px = 0.5;
    BearingScene scene = planeBearingScene(truth, camera, 20, 20.0, scene_options, rng);
    const BearingScene off = randomBearingScene(truth, camera, 10, scene_options, rng);
    scene.triplets.insert(scene.triplets.end(), off.triplets.begin(), off.triplets.end());
    BearingScene wrong_scene = randomBearingScene(truth, camera, 20, scene_options, rng);
    const std::vector<int> corrupted = corruptTriplets(wrong_scene.triplets, 1.0, camera, rng);
    ASSERT_EQ(corrupted.size(), 20U);
    scene.triplets.insert(scene.triplets.end(), wrong_scene.triplets.begin(), wrong_scene.triplets.end());
    std::vector<int> wrong(20);
    for (int k = 0; k < 20; ++k) wrong[static_cast<std::size_t>(k)] = 30 + k;
    TrifocalRansacOptions options;
    options.method = TrifocalMethod::kTT4;
    options.seed = static_cast<unsigned>(trial + 1);
    const auto result = estimateTrifocalRansac(scene.triplets, options);
    ASSERT_TRUE(result.isOk()) << result.status().toString();
    EXPECT_GE(result->plane_inliers.size(), 18U) << trial;
    const Counts c = count(accepted(*result, scene.triplets), wrong);
    EXPECT_GE(c.inliers_found, trial % 2 ? 27 : 20) << trial;  // MovA : MovB
    EXPECT_LE(c.outliers_kept, 2) << trial;
    EXPECT_LT(rotationError(result->tensor, pick(scene.triplets, result->inliers), truth), trial % 2 ? 0.03 : 0.05)
        << trial;
    EXPECT_GT(result->plane_iterations, 0);
    EXPECT_GT(result->iterations, result->plane_iterations);
  }
}

// Every triplet on one wall: one homography explains everything, the tensor is undetermined.
TEST(TrifocalRansac, TT4OnASinglePlaneIsDegenerate) {
  const LineCamera1d camera;
  std::mt19937 rng(23);
  const BearingScene scene = planeBearingScene(movementB(), camera, 30, 20.0, BearingSceneOptions{}, rng);
  TrifocalRansacOptions options;
  options.method = TrifocalMethod::kTT4;
  EXPECT_EQ(estimateTrifocalRansac(scene.triplets, options).status().code(), StatusCode::kDegenerate);
}

TEST(TrifocalRansac, BadInput) {
  const LineCamera1d camera;
  std::mt19937 rng(24);
  BearingScene scene = randomBearingScene(movementA(), camera, 6, BearingSceneOptions{}, rng);
  TrifocalRansacOptions options;
  options.method = TrifocalMethod::kTT7;
  EXPECT_EQ(estimateTrifocalRansac(scene.triplets, options).status().code(), StatusCode::kTooFewPoints);
  options.method = TrifocalMethod::kTT5;
  scene.triplets[2].third = Bearing(INFINITY, 1.0);
  EXPECT_EQ(estimateTrifocalRansac(scene.triplets, options).status().code(), StatusCode::kInvalidInput);
  scene.triplets[2].third = Bearing(0.0, 1.0);
  options.confidence = 1.0;
  EXPECT_EQ(estimateTrifocalRansac(scene.triplets, options).status().code(), StatusCode::kInvalidInput);
  EXPECT_THROW(trifocalMethodFromString("TT6"), std::invalid_argument);
  EXPECT_EQ(trifocalMethodFromString("TT4"), TrifocalMethod::kTT4);
  // Nothing consistent: random bearings in every view.
  std::vector<BearingTriplet> noise;
  std::uniform_real_distribution<double> column(0.0, 1024.0);
  for (int k = 0; k < 40; ++k) {
    noise.push_back({camera.bearing(column(rng)), camera.bearing(column(rng)), camera.bearing(column(rng))});
  }
  TrifocalRansacOptions strict;
  strict.method = TrifocalMethod::kTT7;
  strict.max_transfer_error = 1e-6;
  strict.max_iterations = 200;
  EXPECT_EQ(estimateTrifocalRansac(noise, strict).status().code(), StatusCode::kNoConsensus);
}

// The same seed gives the same result.
TEST(TrifocalRansac, Deterministic) {
  const LineCamera1d camera;
  std::mt19937 rng(25);
  BearingSceneOptions scene_options;
  scene_options.noise_px = 0.5;
  BearingScene scene = randomBearingScene(movementB(), camera, 50, scene_options, rng);
  corruptTriplets(scene.triplets, 0.3, camera, rng);
  const auto a = estimateTrifocalRansac(scene.triplets);
  const auto b = estimateTrifocalRansac(scene.triplets);
  ASSERT_TRUE(a.isOk() && b.isOk());
  EXPECT_EQ(a->inliers, b->inliers);
  EXPECT_EQ(a->iterations, b->iterations);
}
