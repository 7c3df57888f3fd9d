// The route audit on the synthetic wall route: what it predicts, and that it names what is missing.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "homography_teach_repeat/teach_repeat/keyframe_store.h"
#include "homography_teach_repeat/teach_repeat/route_audit.h"
#include "support/synthetic_route_test.h"

using namespace homography_teach_repeat;

namespace {

class RouteAuditTest : public test_support::SyntheticRouteTest {};

double positionSigma(const KeyframeAudit& a) {
  return std::sqrt(std::max((*a.predicted_covariance)(0, 0), (*a.predicted_covariance)(1, 1)));
}

// A copy of `route` in a new temporary directory (named after `name`), to change a keyframe's files.
std::string copyRouteDirectory(const Route& route, const char* name) {
  const std::string copy = test_support::makeTemporaryDirectory(name);
  std::filesystem::copy(route.directory, copy, std::filesystem::copy_options::recursive |
                                                   std::filesystem::copy_options::overwrite_existing);
  return copy;
}

// Pixels across the image, and two views of them for the stretch tests: a similarity (rotated by
// 0.3 rad, scaled by 0.9, shifted), which stretches nothing, and a wall turned away (perspective).
const std::vector<Eigen::Vector2d> kStretchProbePixels = {{100.0, 50.0}, {320.0, 240.0}, {600.0, 400.0}};

Eigen::Matrix3d rotatedScaledShifted() {
  Eigen::Matrix3d similarity;
  similarity << 0.9 * std::cos(0.3), -0.9 * std::sin(0.3), 12.0, 0.9 * std::sin(0.3), 0.9 * std::cos(0.3), -7.0, 0.0, 0.0, 1.0;
  return similarity;
}

Eigen::Matrix3d wallTurnedAway() {
  Eigen::Matrix3d perspective;
  perspective << 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.001, 0.0, 1.0;
  return perspective;
}

}  // namespace

TEST_F(RouteAuditTest, AWellTexturedWallGivesEveryKeyframeAPredictedFixAndNoAlias) {
  RouteAuditOptions options;
  const auto audit = auditRoute(route(), options);
  ASSERT_TRUE(audit.isOk()) << audit.status().toString();
  ASSERT_EQ(audit->keyframes.size(), route().keyframes.size());
  for (const KeyframeAudit& a : audit->keyframes) {
    EXPECT_TRUE(a.has_plane);
    EXPECT_GT(a.features, 0);
    EXPECT_GT(a.plane_features, options.min_plane_features) << a.keyframe;
    EXPECT_GT(a.lines, 0);
    ASSERT_TRUE(a.predicted_covariance) << a.keyframe << ": " << a.prediction_problem;
    // Hundreds of exact wall features at 0.5 px: millimetres and hundredths of a degree.
    EXPECT_GT(positionSigma(a), 0.0);
    EXPECT_LT(positionSigma(a), 0.02) << a.keyframe;
    EXPECT_LT(std::sqrt((*a.predicted_covariance)(2, 2)), 0.005) << a.keyframe;
    EXPECT_GT(a.neighbour_inliers, options.repeat.min_inliers);
    // Keyframes further along the same wall match it, but give the pose the teach run had.
    EXPECT_EQ(a.alias_keyframe, -1) << a.keyframe << " looks like " << a.alias_keyframe;
    EXPECT_TRUE(a.fast_hd_weaknesses.empty()) << a.keyframe << ": " << a.fast_hd_weaknesses.front();
  }
  EXPECT_EQ(audit->weak_for_fast_hd, 0);
}

// The prediction is the repeat's own covariance model: twice the pixel noise, twice the sigma;
// the pixel noise is the route's measured one times match_residual_gain (docs/math.md §3.9), or
// with a gain of 0 the configured one.
TEST_F(RouteAuditTest, ThePredictedSigmaFollowsTheRepeatsPixelNoise) {
  ASSERT_TRUE(routeMatchResidual(route()).has_value());  // the teach run measured it
  RouteAuditOptions options;
  options.aliasing = false;
  options.repeat.pose.refine = false;  // the closed form's covariance is linear in the pixel sigma
  options.repeat.plane_sigma_from_neighbours = false;  // and nothing else in it (docs/math.md §3.10)
  options.repeat.match_residual_gain = 0.0;
  const auto once = auditRoute(route(), options);
  options.repeat.pose.pixel_sigma_px *= 2.0;
  const auto twice = auditRoute(route(), options);
  options.repeat.match_residual_gain = 1.5;
  const auto measured = auditRoute(route(), options);
  options.repeat.match_residual_gain = 3.0;
  const auto measured_twice = auditRoute(route(), options);
  ASSERT_TRUE(once.isOk() && twice.isOk() && measured.isOk() && measured_twice.isOk());
  for (std::size_t k = 0; k < once->keyframes.size(); ++k) {
    ASSERT_TRUE(once->keyframes[k].predicted_covariance && twice->keyframes[k].predicted_covariance);
    EXPECT_NEAR(positionSigma(twice->keyframes[k]) / positionSigma(once->keyframes[k]), 2.0, 0.05) << k;
    ASSERT_TRUE(measured->keyframes[k].predicted_covariance && measured_twice->keyframes[k].predicted_covariance);
    EXPECT_NEAR(positionSigma(measured_twice->keyframes[k]) / positionSigma(measured->keyframes[k]), 2.0, 0.05) << k;
  }
}

// Each keyframe's pixel noise is the repeat's (keyframePixelNoiseScale, docs/route_audit.md): the
// teach pairs' residuals, as the route stores them. With the pairs 1 -> 2 and 2 -> 3 measured 3
// times noisier, keyframe 2 (both its pairs) gets the largest scale, above keyframes 1 and 3 (one
// pair each), and a larger predicted σ; with repeat.pixel_noise_per_keyframe off every scale is 1.
TEST_F(RouteAuditTest, AKeyframeWithNoisierMatchesIsPredictedNoisier) {
  RouteAuditOptions options;
  options.aliasing = false;
  options.repeat.plane_sigma_from_neighbours = false;  // the pixel noise alone in the prediction
  const auto plain = auditRoute(route(), options);
  ASSERT_TRUE(plain.isOk()) << plain.status().toString();
  for (const KeyframeAudit& a : plain->keyframes) {
    EXPECT_GT(a.pixel_noise_scale, 0.6) << a.keyframe;
    EXPECT_LT(a.pixel_noise_scale, 1.6) << a.keyframe;
  }

  Route noisy = route();
  ASSERT_GE(noisy.keyframes.size(), 5u);
  for (const std::size_t pair : {1u, 2u}) {
    ASSERT_TRUE(noisy.keyframes[pair].match_residual) << pair;
    noisy.keyframes[pair].match_residual->rms_px *= 3.0;
  }
  const auto audited = auditRoute(noisy, options);
  ASSERT_TRUE(audited.isOk()) << audited.status().toString();
  const auto& k = audited->keyframes;
  EXPECT_GT(k[2].pixel_noise_scale, 1.3 * plain->keyframes[2].pixel_noise_scale);
  EXPECT_GT(k[2].pixel_noise_scale, k[1].pixel_noise_scale);
  EXPECT_GT(k[2].pixel_noise_scale, k[3].pixel_noise_scale);
  ASSERT_TRUE(k[2].predicted_covariance && plain->keyframes[2].predicted_covariance);
  EXPECT_GT(positionSigma(k[2]), 1.3 * positionSigma(plain->keyframes[2]));
  // The same scale as the repeat's store gives that keyframe.
  EXPECT_EQ(k[2].pixel_noise_scale, keyframePixelNoiseScale(noisy, 2, routeMatchResidual(noisy)));

  options.repeat.pixel_noise_per_keyframe = false;
  const auto configured = auditRoute(noisy, options);
  ASSERT_TRUE(configured.isOk()) << configured.status().toString();
  for (const KeyframeAudit& a : configured->keyframes) EXPECT_EQ(a.pixel_noise_scale, 1.0) << a.keyframe;
}

TEST_F(RouteAuditTest, AKeyframeWithoutAPlaneAndTooFewLinesIsNamed) {
  Route without = route();
  without.keyframes[2].plane.reset();
  RouteAuditOptions options;
  options.aliasing = false;
  options.min_lines = 100000;  // no keyframe has that many: every one is weak for mu
  const auto audit = auditRoute(without, options);
  ASSERT_TRUE(audit.isOk()) << audit.status().toString();
  const KeyframeAudit& planeless = audit->keyframes[2];
  EXPECT_FALSE(planeless.has_plane);
  EXPECT_FALSE(planeless.predicted_covariance);
  ASSERT_FALSE(planeless.fast_hd_weaknesses.empty());
  EXPECT_NE(planeless.fast_hd_weaknesses.front().find("no plane"), std::string::npos);
  EXPECT_EQ(audit->weak_for_fast_hd, 1);
  EXPECT_EQ(audit->weak_for_mu, static_cast<int>(audit->keyframes.size()));
  EXPECT_NE(audit->keyframes[0].mu_weaknesses.front().find("min_lines"), std::string::npos);
  ASSERT_FALSE(audit->notes.empty());
  EXPECT_NE(audit->notes.front().find("not every keyframe has a plane"), std::string::npos);
}

TEST_F(RouteAuditTest, BadOptionsAndAnEmptyRouteAreRefused) {
  RouteAuditOptions options;
  options.probe_offset_m = 0.0;
  const auto bad = auditRoute(route(), options);
  EXPECT_EQ(bad.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(bad.status().message().find("probe_offset_m"), std::string::npos);
  options = RouteAuditOptions();
  options.max_alias_ratio = NAN;
  EXPECT_EQ(auditRoute(route(), options).status().code(), StatusCode::kInvalidInput);
  Route empty = route();
  empty.keyframes.clear();
  EXPECT_EQ(auditRoute(empty, RouteAuditOptions()).status().code(), StatusCode::kInvalidInput);
}

// A keyframe whose plane its neighbours disagree with (keyframe 2's plane put 30 % further away):
// the disagreement is reported, but enters the prediction only where it enters the repeat's own
// covariance (`plane_sigma_from_neighbours`, docs/route_audit.md).
TEST_F(RouteAuditTest, ThePlanesDisagreementEntersThePredictionOnlyWhereTheRepeatUsesIt) {
  Route disagreeing = route();
  ASSERT_TRUE(disagreeing.keyframes[2].plane);
  disagreeing.keyframes[2].plane->distance *= 1.3;
  RouteAuditOptions options;
  options.aliasing = false;
  options.repeat.plane_sigma_from_neighbours = false;
  options.repeat.pose.common_shift_sigma_px = 0.0;  // the pixel noise alone
  const auto without = auditRoute(disagreeing, options);
  options.repeat.plane_sigma_from_neighbours = true;
  const auto with = auditRoute(disagreeing, options);
  ASSERT_TRUE(without.isOk() && with.isOk());
  const KeyframeAudit& reported = without->keyframes[1];
  EXPECT_GT(reported.plane_distance_sigma, 0.1);
  ASSERT_TRUE(reported.predicted_covariance && with->keyframes[1].predicted_covariance);
  EXPECT_GT(positionSigma(with->keyframes[1]), 1.5 * positionSigma(reported));
}

// A fix matches only part of the plane features it sees; the audit expects as large a part as the
// neighbouring keyframe matched of those in its view, and the covariance of fewer matches is
// larger (1/n).
TEST_F(RouteAuditTest, ThePredictionCountsTheMatchesANeighbourFinds) {
  RouteAuditOptions options;
  options.aliasing = false;  // the neighbour is matched all the same
  options.match_stretch_decay = 0.0;  // the neighbour's part as it matched it (the stretch: below)
  const auto audit = auditRoute(route(), options);
  ASSERT_TRUE(audit.isOk()) << audit.status().toString();
  for (const KeyframeAudit& a : audit->keyframes) {
    EXPECT_GT(a.neighbour_inliers, options.repeat.min_inliers) << a.keyframe;
    EXPECT_GT(a.predicted_matches, 0) << a.keyframe;
    EXPECT_GT(a.expected_match_fraction, 0.0) << a.keyframe;
    EXPECT_LE(a.expected_match_fraction, 1.0) << a.keyframe;
    // The neighbours 0.5 m along the wall see most of its features, not all.
    EXPECT_GE(a.neighbour_plane_features_in_view, options.repeat.min_inliers) << a.keyframe;
    EXPECT_LE(a.neighbour_plane_features_in_view, a.plane_features) << a.keyframe;
    EXPECT_GE(a.expected_match_fraction,
              std::min(1.0, static_cast<double>(a.neighbour_inliers) / a.plane_features) - 1e-12) << a.keyframe;
  }
  // A keyframe its neighbour hardly matches is given no fix, with the reason.
  options.repeat.min_inliers = 100000;
  const auto starved = auditRoute(route(), options);
  ASSERT_TRUE(starved.isOk());
  EXPECT_FALSE(starved->keyframes[0].predicted_covariance);
  EXPECT_NE(starved->keyframes[0].prediction_problem.find("would match"), std::string::npos)
      << starved->keyframes[0].prediction_problem;
}

// The part a neighbour matched is taken over the keyframe's plane features in its view: with the
// neighbour's recorded heading turned 0.3 rad (its images as they were), it sees fewer of keyframe
// 0's features, and the same inliers are a larger part of them.
TEST_F(RouteAuditTest, TheNeighboursPartIsOverThePlaneFeaturesItSees) {
  RouteAuditOptions options;
  options.aliasing = false;
  options.repeat.plane_feature_tolerance_px = 0.0;  // every keyframe's features all, whatever the poses
  options.match_stretch_decay = 0.0;  // the turned view's stretch aside (below)
  const auto plain = auditRoute(route(), options);
  Route turned = route();
  turned.keyframes[1].pose.yaw += 0.3;
  const auto audited = auditRoute(turned, options);
  ASSERT_TRUE(plain.isOk() && audited.isOk());
  const KeyframeAudit& before = plain->keyframes[0];
  const KeyframeAudit& after = audited->keyframes[0];
  EXPECT_EQ(after.neighbour_inliers, before.neighbour_inliers);
  EXPECT_LT(after.neighbour_plane_features_in_view, before.neighbour_plane_features_in_view);
  EXPECT_GT(after.expected_match_fraction, before.expected_match_fraction);
  EXPECT_NEAR(after.expected_match_fraction,
              std::min(1.0, static_cast<double>(after.neighbour_inliers) / after.neighbour_plane_features_in_view), 1e-12);
}

// A neighbour whose camera stood where the keyframe's did (a turn in place) sees the same picture
// re-projected and does not say what a view from elsewhere matches: with keyframe 1 recorded where
// keyframe 0 was, keyframe 0 (whose only neighbour it is) takes the route's median part instead.
TEST_F(RouteAuditTest, ANeighbourTurnedInPlaceDoesNotCountTheRoutesPartDoes) {
  RouteAuditOptions options;
  options.aliasing = false;
  options.match_stretch_decay = 0.0;  // each part as matched, so the median is of the fractions reported
  Route turned = route();
  ASSERT_GE(turned.keyframes.size(), 4u);
  turned.keyframes[1].pose = turned.keyframes[0].pose;
  turned.keyframes[1].pose.yaw += 0.2;
  const auto audit = auditRoute(turned, options);
  ASSERT_TRUE(audit.isOk()) << audit.status().toString();
  const KeyframeAudit& first = audit->keyframes[0];
  EXPECT_EQ(first.neighbour_match_fraction, -1.0);
  EXPECT_EQ(first.neighbour_plane_features_in_view, -1);
  std::vector<double> parts;
  for (const KeyframeAudit& a : audit->keyframes) {
    if (a.neighbour_match_fraction >= 0.0) parts.push_back(a.neighbour_match_fraction);
  }
  ASSERT_GE(parts.size(), 2u);
  std::nth_element(parts.begin(), parts.begin() + static_cast<std::ptrdiff_t>(parts.size() / 2), parts.end());
  EXPECT_NEAR(first.expected_match_fraction, std::min(1.0, parts[parts.size() / 2]), 1e-12);
  // Further along, the neighbours stood elsewhere and count.
  EXPECT_GE(audit->keyframes[3].neighbour_match_fraction, 0.0);
}

// Of a predicted fix, the current image's pixel noise differs from one fix to the next at a
// keyframe (predicted_fix_to_fix_covariance), and of the keyframe image's own noise the part over
// the keypoints two fixes do not both match; the plane's error is the same in every fix there. So
// the plane's disagreement with its neighbours leaves the fix-to-fix part as it is, and without it
// the shared part, the keyframe image's noise over every plane feature in view, is about half of
// the pixel noise's with every feature matched (0.3 m beside a keyframe facing its wall, both
// images' pixels weigh about the same).
TEST_F(RouteAuditTest, TheFixToFixPartIsTheCurrentImagesNoiseAndTheKeyframesNotMatchedInCommon) {
  Route disagreeing = route();
  ASSERT_TRUE(disagreeing.keyframes[2].plane);
  disagreeing.keyframes[2].plane->distance *= 1.3;
  RouteAuditOptions options;
  options.aliasing = false;
  options.repeat.plane_sigma_from_neighbours = false;
  options.repeat.pose.common_shift_sigma_px = 0.0;  // the pixel noise alone
  const auto without = auditRoute(disagreeing, options);
  options.repeat.plane_sigma_from_neighbours = true;
  const auto with = auditRoute(disagreeing, options);
  ASSERT_TRUE(without.isOk() && with.isOk());
  for (const auto* audit : {&*without, &*with}) {
    for (const KeyframeAudit& a : audit->keyframes) {
      ASSERT_TRUE(a.predicted_covariance && a.predicted_fix_to_fix_covariance) << a.keyframe;
      const Eigen::Matrix3d shared = *a.predicted_covariance - *a.predicted_fix_to_fix_covariance;
      EXPECT_GT(a.predicted_fix_to_fix_covariance->eigenvalues().real().minCoeff(), 0.0) << a.keyframe;
      EXPECT_GE(shared.eigenvalues().real().minCoeff(), -1e-15) << a.keyframe;
    }
  }
  const KeyframeAudit& plain = without->keyframes[1];
  const KeyframeAudit& charged = with->keyframes[1];
  EXPECT_GT(positionSigma(charged), 1.5 * positionSigma(plain));
  EXPECT_LT((*charged.predicted_fix_to_fix_covariance - *plain.predicted_fix_to_fix_covariance).norm(),
            1e-9 * plain.predicted_fix_to_fix_covariance->norm());
  // Without the plane's term the rest is pixel noise and the heading floor (none here).
  ASSERT_EQ(options.repeat.pose.heading_sigma_rad, 0.0);
  ASSERT_EQ(options.repeat.pose.common_shift_sigma_px, 0.0);
  const double p = plain.expected_match_fraction;
  for (int k = 0; k < 3; ++k) {
    const double shared = (*plain.predicted_covariance)(k, k) - (*plain.predicted_fix_to_fix_covariance)(k, k);
    const double all_matched = p * (*plain.predicted_covariance)(k, k);
    EXPECT_GT(shared / all_matched, 0.3) << k;
    EXPECT_LT(shared / all_matched, 0.7) << k;
  }
}

// The keyframe image's noise that every fix shares is its keypoints' over every plane feature in
// view, whatever part a fix matches: a keyframe its neighbour matches less (keyframe 0, whose only
// neighbour, keyframe 1, lost every other feature) keeps its shared part and is given a larger
// fix-to-fix part (docs/math.md §3.4).
TEST_F(RouteAuditTest, TheSharedPartDoesNotDependOnThePartMatched) {
  RouteAuditOptions options;
  options.aliasing = false;
  // The pixel noise alone: the thinned neighbour's fix would change keyframe 0's measured fix error.
  options.repeat.plane_sigma_from_neighbours = false;
  options.repeat.plane_feature_tolerance_px = 0.0;  // keyframe 0's features all, whatever its neighbour
  const auto plain = auditRoute(route(), options);
  ASSERT_TRUE(plain.isOk()) << plain.status().toString();

  const std::string copy = copyRouteDirectory(route(), "htr_thinned_neighbour_route");
  auto thinned = loadRoute(copy);
  ASSERT_TRUE(thinned.isOk()) << thinned.status().toString();
  auto features = loadKeyframeFeatures(*thinned, 1);
  ASSERT_TRUE(features.isOk()) << features.status().toString();
  ImageFeatures every_other;
  every_other.type = features->type;
  for (std::size_t i = 0; i < features->keypoints.size(); i += 2) {
    every_other.keypoints.push_back(features->keypoints[i]);
    every_other.descriptors.push_back(features->descriptors.row(static_cast<int>(i)));
  }
  ASSERT_TRUE(writeKeyframeFeatures(*thinned, 1, every_other).isOk());
  const auto audited = auditRoute(*thinned, options);
  ASSERT_TRUE(audited.isOk()) << audited.status().toString();
  const KeyframeAudit& before = plain->keyframes[0];
  const KeyframeAudit& after = audited->keyframes[0];
  ASSERT_TRUE(before.predicted_covariance && after.predicted_covariance);
  ASSERT_EQ(before.predicted_matches, after.predicted_matches);  // keyframe 0's own features
  EXPECT_LT(after.expected_match_fraction, 0.8 * before.expected_match_fraction);
  const Eigen::Matrix3d shared_before = *before.predicted_covariance - *before.predicted_fix_to_fix_covariance;
  const Eigen::Matrix3d shared_after = *after.predicted_covariance - *after.predicted_fix_to_fix_covariance;
  EXPECT_LT((shared_after - shared_before).norm(), 1e-6 * shared_before.norm());
  for (int k = 0; k < 3; ++k) {
    EXPECT_GT((*after.predicted_fix_to_fix_covariance)(k, k), (*before.predicted_fix_to_fix_covariance)(k, k)) << k;
  }
  std::filesystem::remove_all(copy);
}

// A view that maps the keyframe by a similarity stretches nothing (1); one that stretches a
// keypoint's patch 1.2 times across gives 1 + gain · 0.2 there; the scale is the RMS over the
// pixels, and a perspective homography stretches its pixels differently.
TEST(MatchStretchNoiseScale, GrowsWithTheStretchOfTheLocalMap) {
  const std::vector<Eigen::Vector2d>& pixels = kStretchProbePixels;
  const Eigen::Matrix3d similarity = rotatedScaledShifted();
  EXPECT_NEAR(matchStretchNoiseScale(similarity, pixels, 2.0), 1.0, 1e-12);
  const Eigen::Matrix3d stretched = Eigen::Vector3d(1.2, 1.0, 1.0).asDiagonal();
  EXPECT_NEAR(matchStretchNoiseScale(stretched, pixels, 2.0), 1.4, 1e-12);
  EXPECT_NEAR(matchStretchNoiseScale(stretched, pixels, 0.5), 1.1, 1e-12);
  EXPECT_EQ(matchStretchNoiseScale(stretched, pixels, 0.0), 1.0);
  EXPECT_EQ(matchStretchNoiseScale(stretched, {}, 2.0), 1.0);
  // A wall turned away: the local map at each pixel is the homography's Jacobian there.
  const Eigen::Matrix3d perspective = wallTurnedAway();
  double squares = 0.0;
  for (const Eigen::Vector2d& x : pixels) {
    const double w = 1.0 + 0.001 * x.x();
    // d/dx of (x, y) / w: [[1/w², 0], [-0.001 y / w², 1/w]]; its singular values' ratio, numerically.
    Eigen::Matrix2d local;
    local << 1.0 / (w * w), 0.0, -0.001 * x.y() / (w * w), 1.0 / w;
    const Eigen::Vector2d s = Eigen::JacobiSVD<Eigen::Matrix2d>(local).singularValues();
    const double noise = 1.0 + 2.0 * (s(0) / s(1) - 1.0);
    squares += noise * noise / 3.0;
  }
  EXPECT_NEAR(matchStretchNoiseScale(perspective, pixels, 2.0), std::sqrt(squares), 1e-9);
  EXPECT_GT(matchStretchNoiseScale(perspective, pixels, 2.0), 1.5);
}

// A view that stretches nothing leaves a feature's chance to match as it is (1); one that
// stretches its patch 1.2 times makes it exp(−decay · 0.2); the scale is the mean over the pixels.
TEST(MatchChanceScale, FallsWithTheStretchOfTheLocalMap) {
  const std::vector<Eigen::Vector2d>& pixels = kStretchProbePixels;
  const Eigen::Matrix3d similarity = rotatedScaledShifted();
  EXPECT_NEAR(matchChanceScale(similarity, pixels, 1.8), 1.0, 1e-12);
  const Eigen::Matrix3d stretched = Eigen::Vector3d(1.0, 1.2, 1.0).asDiagonal();
  EXPECT_NEAR(matchChanceScale(stretched, pixels, 1.8), std::exp(-1.8 * 0.2), 1e-12);
  EXPECT_EQ(matchChanceScale(stretched, pixels, 0.0), 1.0);
  EXPECT_EQ(matchChanceScale(stretched, {}, 1.8), 1.0);
  const Eigen::Matrix3d perspective = wallTurnedAway();
  double mean = 0.0;
  for (const Eigen::Vector2d& x : pixels) mean += std::exp(-1.8 * (*localStretch(perspective, x) - 1.0)) / 3.0;
  EXPECT_NEAR(matchChanceScale(perspective, pixels, 1.8), mean, 1e-12);
  EXPECT_LT(matchChanceScale(perspective, pixels, 1.8), 0.8);
}

// A probe further to the side sees the wall more obliquely than the neighbours along it did, so it
// is expected to match a smaller part of what it sees: the neighbour's part times how much rarer a
// match is at the probe's stretch than at the neighbour's (match_stretch_scale). Decay 0: the
// neighbour's part as it is; a decay outside [0, 10] is refused naming it.
TEST_F(RouteAuditTest, AProbeThatStretchesTheFeaturesMoreIsExpectedToMatchLess) {
  RouteAuditOptions options;
  options.aliasing = false;
  options.match_stretch_decay = 0.0;
  const auto unmodelled = auditRoute(route(), options);
  options.match_stretch_decay = 1.8;
  const auto near = auditRoute(route(), options);
  options.probe_offset_m = 1.0;
  const auto far = auditRoute(route(), options);
  ASSERT_TRUE(unmodelled.isOk() && near.isOk() && far.isOk());
  for (std::size_t k = 0; k < near->keyframes.size(); ++k) {
    const KeyframeAudit& plain = unmodelled->keyframes[k];
    const KeyframeAudit& a = near->keyframes[k];
    const KeyframeAudit& b = far->keyframes[k];
    EXPECT_EQ(plain.match_stretch_scale, 1.0);
    EXPECT_GT(a.match_stretch_scale, 0.8) << k;  // 0.3 m beside a keyframe facing its wall: little stretch
    EXPECT_LT(b.match_stretch_scale, a.match_stretch_scale) << k;
    EXPECT_NEAR(plain.expected_match_fraction, std::min(1.0, plain.neighbour_match_fraction), 1e-12) << k;
    EXPECT_NEAR(a.expected_match_fraction, std::min(1.0, a.neighbour_match_fraction * a.match_stretch_scale), 1e-12) << k;
    EXPECT_LT(b.expected_match_fraction, a.expected_match_fraction) << k;
  }
  for (const double bad : {-0.1, 10.5, std::nan("")}) {
    options.match_stretch_decay = bad;
    const auto refused = auditRoute(route(), options);
    ASSERT_FALSE(refused.isOk());
    EXPECT_NE(refused.status().message().find("match_stretch_decay"), std::string::npos);
  }
}

// The stretch gain scales the pixel noise's part of the prediction by the square of the probe's
// stretch scale (beside a keyframe facing its wall, a little above 1); 0 leaves every scale at 1;
// a gain outside [0, 10] is refused naming it.
TEST_F(RouteAuditTest, TheProbesStretchScalesThePixelNoise) {
  RouteAuditOptions options;
  options.aliasing = false;
  options.repeat.plane_sigma_from_neighbours = false;  // no model terms: the pixel noise alone
  options.repeat.pose.common_shift_sigma_px = 0.0;
  options.stretch_noise_gain = 0.0;
  const auto plain = auditRoute(route(), options);
  options.stretch_noise_gain = 2.0;
  const auto stretched = auditRoute(route(), options);
  ASSERT_TRUE(plain.isOk() && stretched.isOk());
  for (std::size_t k = 0; k < plain->keyframes.size(); ++k) {
    const KeyframeAudit& a = plain->keyframes[k];
    const KeyframeAudit& b = stretched->keyframes[k];
    EXPECT_EQ(a.stretch_noise_scale, 1.0);
    EXPECT_GT(b.stretch_noise_scale, 1.0) << k;
    EXPECT_LT(b.stretch_noise_scale, 1.5) << k;
    ASSERT_TRUE(a.predicted_covariance && b.predicted_covariance);
    // No model terms: the whole prediction is pixel noise, and it scales as σ².
    EXPECT_NEAR((*b.predicted_covariance)(0, 0) / (*a.predicted_covariance)(0, 0),
                b.stretch_noise_scale * b.stretch_noise_scale, 1e-3) << k;
  }
  for (const double bad : {-0.1, 10.5, std::nan("")}) {
    options.stretch_noise_gain = bad;
    const auto refused = auditRoute(route(), options);
    ASSERT_FALSE(refused.isOk());
    EXPECT_NE(refused.status().message().find("stretch_noise_gain"), std::string::npos);
  }
}

// The prediction carries what the repeat's covariance carries (docs/math.md §3.10): on the wall,
// whose keyframes' planes agree, each keyframe's neighbours' fixes are measured and reported, and
// the fix beside it (0.3 m off: d² = 0.09) is predicted with 0.09 times that measurement in place of
// the plane's term; with plane_sigma_from_neighbours off it is still measured and reported (as the
// planes' σ are) but not in the prediction.
TEST_F(RouteAuditTest, TheNeighboursFixErrorEntersThePrediction) {
  RouteAuditOptions options;
  options.aliasing = false;
  options.repeat.pose.common_shift_sigma_px = 0.0;
  const auto measured = auditRoute(route(), options);
  options.repeat.plane_sigma_from_neighbours = false;
  const auto plain = auditRoute(route(), options);
  ASSERT_TRUE(measured.isOk() && plain.isOk());
  for (std::size_t k = 0; k < measured->keyframes.size(); ++k) {
    const KeyframeAudit& a = measured->keyframes[k];
    const KeyframeAudit& b = plain->keyframes[k];
    ASSERT_TRUE(a.neighbour_fix_error_per_m) << k;
    EXPECT_TRUE(b.neighbour_fix_error_per_m) << k;
    ASSERT_TRUE(a.predicted_covariance && b.predicted_covariance) << k;
    const Eigen::Matrix3d added = *a.predicted_covariance - *b.predicted_covariance;
    const Eigen::Vector3d& per_m = *a.neighbour_fix_error_per_m;
    // Position: the mount turns the camera's (x, z) into the base's (x, y); the trace stays.
    const double expected = 0.09 * (per_m.x() * per_m.x() + per_m.y() * per_m.y());
    const double position_added = added.topLeftCorner<2, 2>().trace();
    EXPECT_NEAR(position_added, expected, 0.05 * expected) << k;
    EXPECT_GE(added.eigenvalues().real().minCoeff(), -1e-12) << k;
    // The same in every fix against the keyframe: the shared part, not the fix-to-fix one.
    EXPECT_LT((*a.predicted_fix_to_fix_covariance - *b.predicted_fix_to_fix_covariance).norm(),
              1e-9 * b.predicted_fix_to_fix_covariance->norm()) << k;
  }
}
