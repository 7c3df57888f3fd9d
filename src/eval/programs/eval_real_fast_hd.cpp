// eval_real_fast_hd: the teach/repeat pipeline on real photographs of a wall with ground-truth
// cameras (Strecha fountain-P11, ../shared/realdata; never copied into the repository).
//
//   rosrun homography_teach_repeat eval_real_fast_hd --data DIR [--json F] [--scale 0.25]
//          [--feature sift] [--max-features 4000] [--sigma 0.5] [--references 0,2,4]
//          [--repeats 1,3]
//
// Any Strecha set (fountain_dataset.h). By default the even views are the taught references and
// the odd ones the repeat images; --references / --repeats choose others (each a
// comma-separated list of view indices; references in the order driven). Pipeline:
//  1. gravity alignment: every camera is rotated (in pixel space, p' = K Q K⁻¹ p) to a level
//     virtual camera whose y axis is the mean "down" of the sequence. This is the role of the
//     camera mount / IMU of a robot; only the tilt of each camera is taken from the ground
//     truth (its heading and position are not);
//  2. features (SIFT by default) on images downscaled by --scale (robot-like resolution), ratio +
//     mutual matching, robust homography per consecutive pair of references;
//  3. plane estimation along the references (docs/math.md §2; the β ≈ 0 tie of the first pair is
//     broken by the third view); the only metric ground truth used is the distance of the wall
//     from image 0 (the user-given scale), measured here by triangulating the first pair's wall
//     inliers with the ground-truth cameras and fitting a plane;
//  4. each repeat image against the references before and after it (by index): the one giving
//     most inliers is used; pose (Fast-HD + 3-DoF refinement) and covariance.
// Errors against the ground-truth pose of the level repeat camera in the level reference frame
// (x, z; the small height differences of the real cameras are ignored, as a planar robot would).
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <vector>

#include "homography_teach_repeat/common/command_line.h"
#include "homography_teach_repeat/eval/fountain_dataset.h"
#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/features/feature_matcher.h"
#include "homography_teach_repeat/fast_hd/plane_estimation.h"
#include "homography_teach_repeat/fast_hd/planar_pose_estimator.h"
#include "homography_teach_repeat/homography/homography.h"
#include "homography_teach_repeat/homography/robust_homography.h"

using namespace homography_teach_repeat;

namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

PointMatches rectifiedMatches(const eval::FountainView& a, const ImageFeatures& fa,
                              const eval::FountainView& b, const ImageFeatures& fb,
                              const MatchOptions& options, PointMatches* raw) {
  const auto dmatches = matchFeatures(fa, fb, options);
  if (!dmatches) return {};
  *raw = toPointMatches(fa, fb, *dmatches);
  PointMatches rectified = *raw;
  for (auto& m : rectified) {
    m.reference = (a.rectification * m.reference.homogeneous()).hnormalized();
    m.current = (b.rectification * m.current.homogeneous()).hnormalized();
  }
  return rectified;
}

}  // namespace

int main(int argc, char** argv) {
  cli::Arguments args("eval_real_fast_hd",
                       {{"data", ""}, {"json", ""}, {"scale", "0.25"}, {"feature", "sift"},
                        {"max-features", "4000"}, {"sigma", "0.5"}, {"references", ""},
                        {"repeats", ""}},
                       "--data DIR [--json F] [--scale S] [--feature T] [--max-features N] "
                       "[--sigma PX] [--references I,J,..] [--repeats I,J,..]");
  args.parse(argc, argv);
  const std::string dir = args.text("data");
  if (dir.empty()) args.fail("--data DIR (fountain-P11 folder) is required");
  const double scale = args.number("scale");
  if (!(scale > 0.0 && scale <= 1.0)) args.fail("--scale must be in (0, 1]");

  const eval::FountainSequence sequence(dir, scale, args);
  const auto& views = sequence.views();
  const CameraCalibration& calibration = sequence.calibration();
  const PinholeCamera camera(calibration);
  FeatureOptions feature_options;
  feature_options.type = featureTypeFromString(args.text("feature"));
  feature_options.max_features = args.integer("max-features");
  FeatureExtractor extractor(feature_options);
  std::vector<ImageFeatures> features;
  double max_tilt_deg = 0.0;
  for (const auto& v : views) {
    auto f = extractor.extract(v.image);
    if (!f) args.fail(f.status().toString());
    features.push_back(*f);
    max_tilt_deg = std::max(max_tilt_deg, v.tilt_deg);
  }

  const MatchOptions match_options;
  PlanarPoseEstimatorOptions pose_options;
  pose_options.pixel_sigma_px = args.number("sigma");
  pose_options.validate();

  // References and their consecutive homographies.
  std::vector<int> even_views, odd_views;
  for (int i = 0; i < sequence.size(); ++i) (i % 2 == 0 ? even_views : odd_views).push_back(i);
  const std::vector<int> references = args.indices("references", sequence.size(), even_views);
  const std::vector<int> repeats = args.indices("repeats", sequence.size(), odd_views);
  if (references.size() < 2) args.fail("--references: at least 2 views are needed");
  if (repeats.empty()) args.fail("--repeats: no view to repeat");
  std::vector<ReferencePair> pairs;
  PointMatches first_pair_wall;  // raw pixels of the first pair's inliers (for the scale)
  nlohmann::json pair_json = nlohmann::json::array();
  for (std::size_t k = 0; k + 1 < references.size(); ++k) {
    const int ia = references[k], ib = references[k + 1];
    PointMatches raw;
    const PointMatches matches =
        rectifiedMatches(views[ia], features[ia], views[ib], features[ib], match_options, &raw);
    const auto robust = estimateHomographyRobust(matches, pose_options.robust);
    if (!robust) {
      args.fail("reference pair " + std::to_string(references[k]) + "-" +
                std::to_string(references[k + 1]) + ": " + robust.status().toString());
    }
    ReferencePair pair;
    PointMatches inliers;
    for (const int i : robust->inliers) {
      inliers.push_back(matches[i]);
      pair.reference_pixels.push_back(matches[i].reference);
    }
    pair.H_next_from_current = *estimateHomographyDlt(inliers);
    pairs.push_back(pair);
    pair_json.push_back({{"reference", references[k]}, {"next", references[k + 1]},
                         {"matches", matches.size()}, {"inliers", robust->inliers.size()},
                         {"rms_transfer_error_px", robust->rms_transfer_error_px}});
    if (k == 0) {
      for (const int i : robust->inliers) first_pair_wall.push_back(raw[i]);
    }
  }
  // The user-given scale: the wall's distance from image 0, from ground-truth triangulation.
  const auto [wall_normal_world, wall_offset] =
      sequence.fitWall(references[0], references[1], first_pair_wall);
  const double first_plane_distance = std::abs(wall_offset - wall_normal_world.dot(views[0].gt.C));

  const auto route = estimatePlanesAlongRoute(pairs, camera, first_plane_distance);
  if (!route) args.fail("plane estimation: " + route.status().toString());

  // Plane errors against the fitted wall (diagnostic only).
  nlohmann::json planes_json = nlohmann::json::array();
  for (std::size_t k = 0; k < references.size(); ++k) {
    const eval::FountainView& v = views[references[k]];
    Eigen::Vector3d n_true = v.level.transpose() * wall_normal_world;
    double d_true = wall_offset - wall_normal_world.dot(v.gt.C);
    if (d_true < 0) {
      n_true = -n_true;
      d_true = -d_true;
    }
    const ScenePlane& p = route->planes[k];
    planes_json.push_back(
        {{"reference", references[k]},
         {"normal_err_deg", std::acos(std::clamp(p.normal.dot(n_true), -1.0, 1.0)) * kRadToDeg},
         {"distance_m", p.distance},
         {"distance_true_m", d_true}});
  }

  // Repeat images.
  nlohmann::json per_image = nlohmann::json::array();
  std::vector<double> heading_errors, position_pct;
  std::cout << "first-plane distance (user scale) " << std::setprecision(4) << first_plane_distance
            << " m; max tilt corrected " << max_tilt_deg << " deg\n";
  for (const int j : repeats) {
    int best_reference = -1;
    Expected<PlanarPoseEstimate> best = Status(StatusCode::kNoConsensus, "no reference tried");
    // The references nearest before and after view j (by index).
    std::vector<std::size_t> neighbours;
    for (std::size_t k = 0; k < references.size(); ++k) {
      if (references[k] < j && (k + 1 == references.size() || references[k + 1] >= j)) neighbours.push_back(k);
      if (references[k] > j && (k == 0 || references[k - 1] <= j)) neighbours.push_back(k);
      if (references[k] == j) neighbours.push_back(k);
    }
    for (const std::size_t k : neighbours) {
      const int r = references[k];
      PointMatches raw;
      const PointMatches matches =
          rectifiedMatches(views[r], features[r], views[j], features[j], match_options, &raw);
      auto estimate = estimatePlanarPose(matches, camera, route->planes[k], pose_options);
      if (estimate && (!best || estimate->inliers.size() > best->inliers.size())) {
        best = estimate;
        best_reference = r;
      }
    }
    if (!best) {
      per_image.push_back({{"image", j}, {"status", best.status().toString()}});
      std::cout << "image " << j << ": " << best.status().toString() << "\n";
      continue;
    }
    double height_offset = 0.0;
    const PlanarPose truth = sequence.relativePose(best_reference, j, &height_offset);
    const double heading_err = std::abs(wrapToPi(best->pose.theta - truth.theta)) * kRadToDeg;
    const double pos_err = std::hypot(best->pose.x - truth.x, best->pose.z - truth.z);
    const double baseline = std::hypot(truth.x, truth.z);
    heading_errors.push_back(heading_err);
    position_pct.push_back(100.0 * pos_err / baseline);
    per_image.push_back({{"image", j},
                         {"reference", best_reference},
                         {"inliers", best->inliers.size()},
                         {"heading_err_deg", heading_err},
                         {"pos_err_m", pos_err},
                         {"pos_err_pct", 100.0 * pos_err / baseline},
                         {"baseline_m", baseline},
                         {"height_offset_m", height_offset},
                         {"estimate", {best->pose.x, best->pose.z, best->pose.theta}},
                         {"truth", {truth.x, truth.z, truth.theta}},
                         {"fast_hd_heading_err_deg",
                          std::abs(wrapToPi(best->fast_hd_pose.theta - truth.theta)) * kRadToDeg},
                         {"fast_hd_pos_err_m", std::hypot(best->fast_hd_pose.x - truth.x,
                                                          best->fast_hd_pose.z - truth.z)},
                         {"pred_sigma_theta_deg", std::sqrt(best->covariance(2, 2)) * kRadToDeg},
                         {"pred_sigma_pos_m",
                          std::sqrt(best->covariance(0, 0) + best->covariance(1, 1))}});
    std::cout << "image " << j << " vs " << best_reference << ": heading err " << std::setprecision(3)
              << heading_err << " deg, position err " << pos_err << " m of " << baseline
              << " m (" << 100.0 * pos_err / baseline << "%), " << best->inliers.size()
              << " inliers\n";
  }
  auto median = [](std::vector<double> v) {
    if (v.empty()) return std::nan("");
    std::sort(v.begin(), v.end());
    return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
  };
  nlohmann::json document{{"per_image", per_image},
                          {"median_heading_err_deg", median(heading_errors)},
                          {"median_pos_err_pct", median(position_pct)},
                          {"reference_pairs", pair_json},
                          {"planes", planes_json},
                          {"first_plane_distance_m", first_plane_distance},
                          {"setup", {{"scale", scale}, {"feature", args.text("feature")},
                                     {"image", {calibration.width, calibration.height}},
                                     {"sigma_px", pose_options.pixel_sigma_px}}}};
  std::cout << "median heading error " << document["median_heading_err_deg"].get<double>()
            << " deg, median position error " << document["median_pos_err_pct"].get<double>()
            << " %\n";
  args.writeJson(document);
  return 0;
}
