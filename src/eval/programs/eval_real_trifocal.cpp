// eval_real_trifocal: three-view localization with the 1D trifocal tensor on real photographs
// (paper 003 §V.B): every triplet of consecutive images of fountain-P11 (../shared/realdata,
// never copied into the repository), bearings from the x coordinate of matched SIFT keypoints
// after gravity alignment (fountain_dataset.h: a level virtual camera per image), robust TT5
// (or --method TT7/TT4), the closed-form motion with the candidate chosen by an odometry prior,
// scored against the ground-truth cameras.
//
//   rosrun homography_teach_repeat eval_real_trifocal --data DIR [--json F] [--scale 0.25]
//       [--method TT5] [--threshold 0.003]
//
// The odometry prior is simulated from the ground truth with a 10 % scale error and 2° heading
// offsets (what wheel odometry gives over 1-4 m); it picks one of the two candidates of the closed
// form and sets the metric scale, nothing else. A triplet match is "wrong" when its bearings
// disagree with the ground-truth tensor by more than --wrong-threshold [rad] of transfer error;
// "wrong_rejected" is the fraction of those RANSAC left out.
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>

#include "homography_teach_repeat/common/command_line.h"
#include "homography_teach_repeat/eval/fountain_dataset.h"
#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/features/feature_matcher.h"
#include "homography_teach_repeat/eval/synthetic_bearing_scene.h"
#include "homography_teach_repeat/trifocal/trifocal_motion.h"
#include "homography_teach_repeat/trifocal/trifocal_ransac.h"
#include "homography_teach_repeat/trifocal/trifocal_localizer.h"
#include "homography_teach_repeat/trifocal/trifocal_tensor_1d.h"

using namespace homography_teach_repeat;

namespace {

constexpr double kDeg = 180.0 / M_PI;

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

double angleBetween(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return std::acos(std::clamp(a.dot(b) / (a.norm() * b.norm()), -1.0, 1.0));
}

}  // namespace

int main(int argc, char** argv) {
  cli::Arguments args("eval_real_trifocal",
                       {{"data", ""}, {"json", ""}, {"scale", "0.25"}, {"method", "TT5"}, {"threshold", "0.003"},
                        {"wrong-threshold", "0.01"}, {"seed", "1"}, {"refine", "1"}},
                       "--data DIR [--json F] [--scale S] [--method TT7|TT5|TT4] [--threshold RAD] "
                       "[--wrong-threshold RAD] [--seed S] [--refine 0|1 (bundle adjustment)]");
  args.parse(argc, argv);
  if (args.text("data").empty()) args.fail("--data DIR (fountain-P11 folder) is required");
  const double scale = args.number("scale");
  if (!(scale > 0.0 && scale <= 1.0)) args.fail("--scale must be in (0, 1]");
  TrifocalRansacOptions ransac;
  try {
    ransac.method = trifocalMethodFromString(args.text("method"));
  } catch (const std::invalid_argument& e) {
    args.fail(e.what());
  }
  ransac.max_transfer_error = args.number("threshold");
  ransac.seed = static_cast<unsigned>(args.integer("seed"));
  const double wrong_threshold = args.number("wrong-threshold");
  const eval::FountainSequence sequence(args.text("data"), scale, args);
  const auto& views = sequence.views();
  const CameraCalibration& calibration = sequence.calibration();

  // SIFT keypoints of every image and their bearings in the level camera.
  FeatureOptions feature_options;
  feature_options.max_features = 4000;
  FeatureExtractor sift(feature_options);
  std::vector<ImageFeatures> features;
  std::vector<std::vector<Bearing>> bearings;
  for (const auto& v : views) {
    auto f = sift.extract(v.image);
    if (!f) args.fail("features: " + f.status().toString());
    std::vector<Bearing> b;
    for (const auto& k : f->keypoints) {
      const Eigen::Vector3d level = v.rectification * Eigen::Vector3d(k.pt.x, k.pt.y, 1.0);
      b.push_back(bearingFromPixel(level.x() / level.z(), calibration.fx, calibration.cx));
    }
    features.push_back(std::move(*f));
    bearings.push_back(std::move(b));
  }

  nlohmann::json per_triplet = nlohmann::json::array();
  std::vector<double> rotation_errors, direction_errors;
  int wrong_total = 0, wrong_rejected = 0;
  std::cout << std::fixed << std::setprecision(3);
  for (int i = 0; i + 2 < static_cast<int>(views.size()); ++i) {
    const int j = i + 1, k = i + 2;
    nlohmann::json entry{{"views", {i, j, k}}};
    // Matches i -> j chained with j -> k.
    const auto matches = matchThreeViews(features[i], features[j], features[k], MatchOptions());
    if (!matches) {
      entry["status"] = matches.status().toString();
      per_triplet.push_back(entry);
      continue;
    }
    std::vector<BearingTriplet> triplets;
    for (const auto& m : *matches) {
      triplets.push_back({bearings[i][static_cast<std::size_t>(m.first)], bearings[j][static_cast<std::size_t>(m.second)],
                          bearings[k][static_cast<std::size_t>(m.third)]});
    }
    // Ground truth in the level frame of view i.
    const PlanarPose second = sequence.relativePose(i, j);
    const PlanarPose third = sequence.relativePose(i, k);
    const TrifocalMotion truth = motionFromCentres(Eigen::Vector2d(second.x, second.z), second.theta,
                                                   Eigen::Vector2d(third.x, third.z), third.theta);
    const TrifocalTensor1d truth_tensor = tensorFromMotion(truth);
    std::vector<int> wrong;
    for (std::size_t n = 0; n < triplets.size(); ++n) {
      if (transferError(truth_tensor, triplets[n]) > wrong_threshold) wrong.push_back(static_cast<int>(n));
    }
    entry["triplets"] = triplets.size();
    entry["wrong_by_ground_truth"] = wrong.size();
    entry["theta_true_deg"] = {second.theta * kDeg, third.theta * kDeg};
    const auto result = estimateTrifocalRansac(triplets, ransac);
    if (!result) {
      entry["status"] = result.status().toString();
      per_triplet.push_back(entry);
      std::cout << "triplet " << i << "-" << j << "-" << k << ": " << result.status().toString() << "\n";
      continue;
    }
    int rejected = 0;
    for (const int w : wrong) rejected += std::binary_search(result->inliers.begin(), result->inliers.end(), w) ? 0 : 1;
    wrong_total += static_cast<int>(wrong.size());
    wrong_rejected += rejected;
    std::vector<BearingTriplet> inliers;
    for (const int n : result->inliers) inliers.push_back(triplets[static_cast<std::size_t>(n)]);
    TrifocalMotionPrior prior;  // simulated odometry: 10 % scale error, 2° heading offsets
    prior.centre_second = 1.1 * truth.centreSecond();
    prior.centre_third = 1.1 * truth.centreThird();
    prior.theta_second = truth.theta_second + 2.0 / kDeg;
    prior.theta_third = truth.theta_third - 2.0 / kDeg;
    TrifocalMotionOptions motion_options;
    motion_options.refine = args.integer("refine") != 0;
    const auto motion = estimateTrifocalMotion(result->tensor, inliers, prior, motion_options);
    entry["inliers"] = result->inliers.size();
    entry["iterations"] = result->iterations;
    entry["wrong_rejected"] = rejected;
    if (!motion) {
      entry["status"] = motion.status().toString();
      per_triplet.push_back(entry);
      std::cout << "triplet " << i << "-" << j << "-" << k << ": " << motion.status().toString() << "\n";
      continue;
    }
    const TrifocalMotion& m = motion->motion;
    const double r2 = std::abs(std::remainder(m.theta_second - truth.theta_second, 2 * M_PI)) * kDeg;
    const double r3 = std::abs(std::remainder(m.theta_third - truth.theta_third, 2 * M_PI)) * kDeg;
    const double d2 = angleBetween(m.t_second, truth.t_second) * kDeg;
    const double d3 = angleBetween(m.t_third, truth.t_third) * kDeg;
    rotation_errors.insert(rotation_errors.end(), {r2, r3});
    direction_errors.insert(direction_errors.end(), {d2, d3});
    entry["status"] = "ok";
    entry["theta_deg"] = {m.theta_second * kDeg, m.theta_third * kDeg};
    entry["rotation_err_deg"] = {r2, r3};
    entry["translation_dir_err_deg"] = {d2, d3};
    entry["in_front"] = motion->in_front;
    per_triplet.push_back(entry);
    std::cout << "triplet " << i << "-" << j << "-" << k << ": " << triplets.size() << " triplets ("
              << wrong.size() << " wrong by ground truth, " << rejected << " rejected), " << result->inliers.size()
              << " inliers; rotation err " << r2 << " / " << r3 << " deg, direction err " << d2 << " / " << d3
              << " deg\n";
  }
  nlohmann::json document{{"per_triplet", per_triplet},
                          {"method", toString(ransac.method)},
                          {"threshold_rad", ransac.max_transfer_error},
                          {"refine", args.integer("refine") != 0},
                          {"scale", scale},
                          {"median_rotation_err_deg", median(rotation_errors)},
                          {"median_translation_dir_err_deg", median(direction_errors)},
                          {"wrong_matches", wrong_total},
                          {"wrong_rejected_fraction",
                           wrong_total > 0 ? static_cast<double>(wrong_rejected) / wrong_total : NAN}};
  std::cout << "median rotation error " << median(rotation_errors) << " deg, median translation-direction error "
            << median(direction_errors) << " deg, wrong matches rejected " << wrong_rejected << " / " << wrong_total
            << "\n";
  args.writeJson(document);
  return 0;
}
