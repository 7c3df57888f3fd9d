// evaluate_route_audit: does the route audit predict the repeat's spread? For every keyframe of a
// route taught in a simulator world, the audit's predicted covariance of a Fast-HD fix `--offset`
// to the right of the keyframe (teach_repeat/route_audit.h) against the measured one: `--samples`
// images rendered at that pose (WorldRenderer, with the simulator's pixel noise and blur, a new
// noise draw each), each localized against the keyframe by the repeat's localizer (fast_hd, that
// keyframe only, no tracking), the errors taken against the true pose in the keyframe's base frame
// (x along, y across, yaw). Per keyframe and axis: predicted σ and measured RMS error (bias
// included), their ratio; over the route: the fraction of ratios within a factor of 2 and the
// correlation of log σ_predicted with log RMS_measured across keyframes (docs/route_audit.md).
//   evaluate_route_audit --world W.yaml --route DIR --out DIR [--offset 0.3] [--samples 20]
//                        [--pixel-sigma 0.5] [--noise 2.0] [--blur 0.5] [--camera-height 0.6] [--seed 1]
// `--pixel-sigma measure`: the pixel noise of the prediction is the simulator's own, measured first:
// each keyframe's view rendered twice with independent noise, features matched between the two, and
// σ_px = 1.4826 · MAD of the matched keypoints' displacement / √2 (per coordinate, both pooled).
// Writes OUT/route_audit_spread.json and OUT/route_audit_spread.png.
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <vector>

#include "homography_teach_repeat/common/command_line.h"
#include "homography_teach_repeat/eval/plots.h"
#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/features/feature_matcher.h"
#include "homography_teach_repeat/sim/planar_world.h"
#include "homography_teach_repeat/sim/world_renderer.h"
#include "homography_teach_repeat/teach_repeat/repeat_localizer.h"
#include "homography_teach_repeat/teach_repeat/route_audit.h"

using namespace homography_teach_repeat;

namespace {

const char* const kAxes[3] = {"along_m", "across_m", "heading_rad"};

// Pearson correlation of two equally long samples (NaN for fewer than 3).
double correlation(const std::vector<double>& a, const std::vector<double>& b) {
  const std::size_t n = a.size();
  if (n < 3) return NAN;
  double ma = 0.0, mb = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    ma += a[i] / n;
    mb += b[i] / n;
  }
  double sab = 0.0, saa = 0.0, sbb = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  return sab / std::sqrt(saa * sbb);
}

// Pixel noise of the rendered images as the feature detector sees it: the same view rendered twice
// with independent noise, the displacement of the matched keypoints (robust std over all views).
double measurePixelSigma(const PlanarWorld& world, const WorldRenderer& renderer, const std::vector<Pose2D>& camera_poses,
                         FeatureType type, cv::RNG& rng) {
  FeatureExtractor extractor(FeatureOptions{type, 1500});
  std::vector<double> displacements;
  for (const Pose2D& pose : camera_poses) {
    const auto a = extractor.extract(renderer.render(world, pose, 1.0, rng));
    const auto b = extractor.extract(renderer.render(world, pose, 1.0, rng));
    if (!a || !b) continue;
    const auto matches = matchFeatures(*a, *b, MatchOptions());
    if (!matches) continue;
    for (const PointMatch& m : toPointMatches(*a, *b, *matches)) {
      const Eigen::Vector2d d = m.current - m.reference;
      if (d.norm() > 3.0) continue;  // a wrong match, not noise
      displacements.push_back(d.x());
      displacements.push_back(d.y());
    }
  }
  if (displacements.size() < 20) throw std::runtime_error("too few keypoints to measure the pixel noise");
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  const double centre = median(displacements);
  std::vector<double> deviations;
  for (const double d : displacements) deviations.push_back(std::abs(d - centre));
  return 1.4826 * median(deviations) / std::sqrt(2.0);
}

}  // namespace

int main(int argc, char** argv) {
  cli::Arguments args("evaluate_route_audit",
                      {{"world", ""}, {"route", ""}, {"out", ""}, {"offset", "0.3"}, {"samples", "20"},
                       {"pixel-sigma", "0.5"}, {"noise", "2.0"}, {"blur", "0.5"}, {"camera-height", "0.6"}, {"seed", "1"},
                       {"plots", "1"}},
                      "--world W.yaml --route DIR --out DIR [--offset M] [--samples N] [--pixel-sigma PX|measure]\n"
                      "  [--noise GREY] [--blur PX] [--camera-height M] (the simulator's camera) [--seed S] [--plots 0|1]");
  args.parse(argc, argv);
  for (const char* required : {"world", "route", "out"}) {
    if (args.text(required).empty()) args.fail(std::string("--") + required + " is required");
  }
  const int samples = static_cast<int>(args.integer("samples"));
  if (samples < 2) args.fail("--samples must be >= 2");
  try {
    const auto world = loadPlanarWorld(args.text("world"));
    if (!world) throw std::runtime_error(world.status().message());
    const auto route = loadRoute(args.text("route"));
    if (!route) throw std::runtime_error(route.status().message());
    RenderOptions render;
    render.camera_height = args.number("camera-height");
    render.noise_sigma = args.number("noise");
    render.blur_sigma = args.number("blur");
    const PinholeCamera camera(route->info.camera);
    const WorldRenderer renderer(camera, render);
    const Pose2D& m = route->info.camera_mount;
    const CameraMount mount(m.x, m.y, m.yaw);
    cv::RNG rng(static_cast<std::uint64_t>(args.integer("seed")));
    RouteAuditOptions audit_options;
    audit_options.probe_offset_m = args.number("offset");
    audit_options.aliasing = false;
    const bool measure_pixel_sigma = args.text("pixel-sigma") == "measure";
    if (measure_pixel_sigma) {
      std::vector<Pose2D> views;
      for (const auto& k : route->keyframes) views.push_back(k.pose.compose(Pose2D(m.x, m.y, m.yaw)));
      audit_options.repeat.pose.pixel_sigma_px = measurePixelSigma(*world, renderer, views, route->info.feature_type, rng);
      std::printf("pixel noise of the rendered images, measured: %.3f px\n", audit_options.repeat.pose.pixel_sigma_px);
    } else {
      audit_options.repeat.pose.pixel_sigma_px = args.number("pixel-sigma");
    }
    const auto audit = auditRoute(*route, audit_options);
    if (!audit) throw std::runtime_error(audit.status().message());

    RepeatOptions repeat = audit_options.repeat;
    repeat.mode = RepeatMode::kFastHd;
    repeat.require_planes = false;
    repeat.neighbour_search = 0;
    repeat.max_degraded_frames = 0;
    repeat.max_tracked_frames = 0;
    auto localizer = RepeatLocalizer::create(*route, repeat);
    if (!localizer) throw std::runtime_error(localizer.status().message());
    // The robot whose camera is `offset` to the right of the keyframe's (as the audit's probe).
    const Pose2D probe = mount.cameraToBase(PlanarPose(audit_options.probe_offset_m, 0.0, 0.0));

    nlohmann::json document;
    document["kind"] = "route_audit_spread";
    document["world"] = args.text("world");
    document["route"] = route->directory;
    document["setup"] = {{"offset_m", audit_options.probe_offset_m}, {"samples", samples},
                         {"pixel_sigma", audit_options.repeat.pose.pixel_sigma_px},
                         {"pixel_sigma_measured", measure_pixel_sigma}, {"noise", render.noise_sigma},
                         {"blur", render.blur_sigma}, {"camera_height_m", render.camera_height}};
    std::vector<double> log_predicted[3], log_measured[3];
    int within = 0, compared = 0;
    std::printf("%4s %8s %8s | %22s | %22s | %s\n", "kf", "x [m]", "y [m]", "predicted sigma", "measured rms",
                "ratio measured/predicted (along, across, heading)");
    for (const KeyframeAudit& a : audit->keyframes) {
      nlohmann::json k = {{"keyframe", a.keyframe}, {"pose", {a.pose.x, a.pose.y, a.pose.yaw}}};
      if (!a.predicted_covariance) {
        k["problem"] = a.prediction_problem.empty() ? "no prediction" : a.prediction_problem;
        document["keyframes"].push_back(k);
        continue;
      }
      const Pose2D truth = a.pose.compose(probe);  // the route frame is the world's (teach odometry exact)
      const Pose2D camera_pose = truth.compose(Pose2D(m.x, m.y, m.yaw));
      Eigen::Vector3d second_moment = Eigen::Vector3d::Zero();
      int localized = 0;
      std::string failure;
      for (int s = 0; s < samples; ++s) {
        const cv::Mat image = renderer.render(*world, camera_pose, 1.0, rng);
        localizer->setTrackedKeyframe(a.keyframe);
        const auto estimate = localizer->localize(image);
        if (!estimate || !estimate->has_pose || estimate->keyframe != a.keyframe) {
          if (!estimate) failure = estimate.status().message();
          continue;
        }
        // The error in the keyframe's base frame, as the prediction's covariance.
        const Pose2D measured = a.pose.inverse().compose(estimate->base_pose);
        const Pose2D expected = a.pose.inverse().compose(truth);
        const Eigen::Vector3d e(measured.x - expected.x, measured.y - expected.y, wrapToPi(measured.yaw - expected.yaw));
        second_moment += e.cwiseProduct(e);
        ++localized;
      }
      k["localized"] = localized;
      if (localized < 2) {
        k["problem"] = "localized " + std::to_string(localized) + " of " + std::to_string(samples) + ": " + failure;
        document["keyframes"].push_back(k);
        std::printf("%4d %8.2f %8.2f | not localized: %s\n", a.keyframe, a.pose.x, a.pose.y, failure.c_str());
        continue;
      }
      const Eigen::Vector3d rms = (second_moment / localized).cwiseSqrt();
      const Eigen::Vector3d sigma = a.predicted_covariance->diagonal().cwiseSqrt();
      nlohmann::json predicted, measured_rms, ratio;
      for (int i = 0; i < 3; ++i) {
        predicted[kAxes[i]] = sigma(i);
        measured_rms[kAxes[i]] = rms(i);
        const double r = rms(i) / sigma(i);
        ratio[kAxes[i]] = r;
        ++compared;
        within += r >= 0.5 && r <= 2.0 ? 1 : 0;
        log_predicted[i].push_back(std::log(sigma(i)));
        log_measured[i].push_back(std::log(rms(i)));
      }
      k["predicted_sigma"] = predicted;
      k["measured_rms"] = measured_rms;
      k["ratio"] = ratio;
      document["keyframes"].push_back(k);
      std::printf("%4d %8.2f %8.2f | %6.4f %6.4f %8.5f | %6.4f %6.4f %8.5f | %.2f %.2f %.2f\n", a.keyframe, a.pose.x,
                  a.pose.y, sigma(0), sigma(1), sigma(2), rms(0), rms(1), rms(2), rms(0) / sigma(0),
                  rms(1) / sigma(1), rms(2) / sigma(2));
    }
    nlohmann::json summary = {{"keyframes", audit->keyframes.size()}, {"ratios_compared", compared},
                              {"ratios_within_factor_2", within},
                              {"fraction_within_factor_2", compared > 0 ? static_cast<double>(within) / compared : NAN}};
    for (int i = 0; i < 3; ++i) summary[std::string("log_correlation_") + kAxes[i]] = correlation(log_predicted[i], log_measured[i]);
    document["summary"] = summary;
    std::printf("%d of %d ratios within a factor of 2; correlation of log sigma predicted vs measured: along %.2f, "
                "across %.2f, heading %.2f\n",
                within, compared, summary["log_correlation_along_m"].get<double>(),
                summary["log_correlation_across_m"].get<double>(), summary["log_correlation_heading_rad"].get<double>());
    const std::filesystem::path out = args.text("out");
    std::filesystem::create_directories(out);
    const std::string json_path = (out / "route_audit_spread.json").string();
    std::ofstream(json_path) << document.dump(1) << "\n";
    if (args.integer("plots") != 0 && eval::drawPlots(json_path, "evaluate_route_audit") != 0) return 1;
  } catch (const std::exception& e) {
    std::cerr << "evaluate_route_audit: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
