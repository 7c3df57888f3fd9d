// eval_real_mu: heading change between consecutive photographs of fountain-P11 (real wall, ground
// truth cameras; ../shared/realdata, never copied into the repository) from μ and from the
// complete-motion algorithm on vertical lines, against the ground-truth yaw.
//
//   rosrun homography_teach_repeat eval_real_mu --data DIR [--json F] [--scale 0.25]
//
// Each image is gravity aligned first (warped by K Q K⁻¹ to a level virtual camera: vertical
// lines are then vertical in the image), then vertical lines are extracted, matched and the 1D
// homography is estimated by LMedS. These images are 1.4-1.8 m apart at ~4-9 m from the wall, so
// translation is not small: μ measures f (d sinθ + tx cosφ)/(d cosθ + tz cosφ) (docs/math.md §4.5), not
// f tanθ. The program reports, per pair, the heading from μ, the error against the ground truth,
// and the part of it predicted by that formula from the ground-truth translation and the wall
// (fitted to ground-truth-triangulated points): "coupling_deg" = atan(μ_exact/f) − θ.
#include <nlohmann/json.hpp>

#include <cmath>
#include <iomanip>
#include <iostream>

#include "homography_teach_repeat/common/command_line.h"
#include "homography_teach_repeat/eval/fountain_dataset.h"
#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/features/feature_matcher.h"
#include "homography_teach_repeat/mu/heading_1d.h"
#include "homography_teach_repeat/mu/homography_1d.h"
#include "homography_teach_repeat/homography/robust_homography.h"
#include "homography_teach_repeat/features/vertical_line_matcher.h"
#include "homography_teach_repeat/features/vertical_lines.h"

using namespace homography_teach_repeat;

namespace {
constexpr double kRadToDeg = 180.0 / M_PI;
}

int main(int argc, char** argv) {
  cli::Arguments args("eval_real_mu", {{"data", ""}, {"json", ""}, {"scale", "0.25"}},
                       "--data DIR [--json F] [--scale S]");
  args.parse(argc, argv);
  if (args.text("data").empty()) args.fail("--data DIR (fountain-P11 folder) is required");
  const double scale = args.number("scale");
  if (!(scale > 0.0 && scale <= 1.0)) args.fail("--scale must be in (0, 1]");
  const eval::FountainSequence sequence(args.text("data"), scale, args);
  const auto& views = sequence.views();
  const CameraCalibration& calibration = sequence.calibration();
  const LineCamera line_camera{calibration.fx, calibration.cx};

  // Gravity-aligned images and their vertical lines.
  VerticalLineExtractor extractor;
  std::vector<std::vector<VerticalLine>> lines;
  const PinholeCamera camera(calibration);
  for (const auto& v : views) {
    cv::Mat level;
    cv::Matx33d map;
    for (int r = 0; r < 3; ++r) for (int c = 0; c < 3; ++c) map(r, c) = v.rectification(r, c);
    cv::warpPerspective(v.image, level, map, v.image.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    auto extracted = extractor.extract(level, &camera);
    if (!extracted) args.fail(extracted.status().toString());
    lines.push_back(*extracted);
  }

  // The wall (for the coupling prediction only): SIFT matches of images 0-1, dominant homography
  // inliers triangulated with the ground-truth cameras.
  FeatureOptions feature_options;
  feature_options.max_features = 4000;
  FeatureExtractor sift(feature_options);
  const auto f0 = sift.extract(views[0].image);
  const auto f1 = sift.extract(views[1].image);
  const PointMatches raw = toPointMatches(*f0, *f1, *matchFeatures(*f0, *f1, MatchOptions()));
  const auto wall_h = estimateHomographyRobust(raw, RobustHomographyOptions());
  if (!wall_h) args.fail("wall homography: " + wall_h.status().toString());
  PointMatches wall_matches;
  for (const int i : wall_h->inliers) wall_matches.push_back(raw[i]);
  const auto [wall_normal, wall_offset] = sequence.fitWall(0, 1, wall_matches);

  nlohmann::json pairs = nlohmann::json::array();
  std::vector<double> mu_errors, ca_errors, residual_errors;
  std::cout << std::fixed << std::setprecision(3);
  for (int i = 0; i + 1 < sequence.size(); ++i) {
    const int j = i + 1;
    const PlanarPose truth = sequence.relativePose(i, j);
    nlohmann::json pair{{"pair", {i, j}}, {"theta_true_deg", truth.theta * kRadToDeg},
                        {"baseline_m", std::hypot(truth.x, truth.z)}};
    const auto matches = matchVerticalLines(lines[i], lines[j]);
    std::vector<LineCorrespondence> correspondences;
    for (const auto& m : *matches) {
      correspondences.push_back({lines[i][m.reference].x, lines[j][m.current].x});
    }
    pair["lines"] = {lines[i].size(), lines[j].size()};
    pair["line_matches"] = correspondences.size();
    const auto h = estimateHomography1dLmeds(correspondences);
    if (!h) {
      pair["status"] = h.status().toString();
      pairs.push_back(pair);
      std::cout << "pair " << i << "-" << j << ": " << h.status().toString() << "\n";
      continue;
    }
    const double mu_theta = *headingFromMu(h->H, line_camera);
    std::vector<double> reference_xs;
    for (const int k : h->inliers) reference_xs.push_back(correspondences[k].reference_x);
    const auto complete = completeMotion1d(h->H, line_camera, reference_xs);
    // Exact μ from the ground truth (docs/math.md §4.4-4.5): Hc = R + t nᵀ/d in the level frame of i.
    const eval::FountainView& a = views[i];
    Eigen::Vector3d n3 = a.level.transpose() * wall_normal;
    double d = wall_offset - wall_normal.dot(a.gt.C);
    if (d < 0.0) {
      n3 = -n3;
      d = -d;
    }
    const Eigen::Vector2d n = Eigen::Vector2d(n3.x(), n3.z()).normalized();
    Eigen::Matrix2d R;
    R << std::cos(truth.theta), std::sin(truth.theta), -std::sin(truth.theta), std::cos(truth.theta);
    const Eigen::Vector2d t = -R * Eigen::Vector2d(truth.x, truth.z);
    const Eigen::Matrix2d Hc = R + t * n.transpose() / d;
    const double coupled_theta = std::atan(Hc(0, 1) / Hc(1, 1));
    const double mu_error = (mu_theta - truth.theta) * kRadToDeg;
    const double coupling = (coupled_theta - truth.theta) * kRadToDeg;
    mu_errors.push_back(std::abs(mu_error));
    residual_errors.push_back(std::abs(mu_error - coupling));
    pair["inliers"] = h->inliers.size();
    pair["mu_theta_deg"] = mu_theta * kRadToDeg;
    pair["mu_err_deg"] = mu_error;
    pair["coupling_deg"] = coupling;
    pair["mu_err_minus_coupling_deg"] = mu_error - coupling;
    pair["wall_distance_m"] = d;
    if (complete) {
      // Both solutions are reported; the error is that of the one closer to the truth.
      double best = 1e9;
      nlohmann::json solutions = nlohmann::json::array();
      for (const auto& m : *complete) {
        solutions.push_back(m.theta * kRadToDeg);
        if (std::abs(m.theta - truth.theta) < std::abs(best)) best = m.theta - truth.theta;
      }
      pair["ca_theta_deg"] = solutions;
      pair["ca_err_deg"] = best * kRadToDeg;
      ca_errors.push_back(std::abs(best) * kRadToDeg);
    } else {
      pair["ca_status"] = complete.status().toString();
    }
    pairs.push_back(pair);
    std::cout << "pair " << i << "-" << j << ": true " << truth.theta * kRadToDeg << " deg, mu "
              << mu_theta * kRadToDeg << " (err " << mu_error << ", predicted coupling " << coupling
              << "), complete motion err " << (complete ? pair["ca_err_deg"].get<double>() : NAN)
              << ", " << h->inliers.size() << "/" << correspondences.size() << " lines\n";
  }
  auto mean = [](const std::vector<double>& v) {
    double s = 0.0;
    for (double x : v) s += x;
    return v.empty() ? std::nan("") : s / v.size();
  };
  nlohmann::json document{{"per_pair", pairs},
                          {"mean_abs_mu_err_deg", mean(mu_errors)},
                          {"mean_abs_ca_err_deg", mean(ca_errors)},
                          {"mean_abs_mu_err_minus_coupling_deg", mean(residual_errors)},
                          {"setup", {{"scale", scale},
                                     {"image", {calibration.width, calibration.height}}}}};
  std::cout << "mean |mu error| " << mean(mu_errors) << " deg; after removing the predicted "
            << "translation coupling " << mean(residual_errors) << " deg; complete motion "
            << mean(ca_errors) << " deg\n";
  args.writeJson(document);
  return 0;
}
