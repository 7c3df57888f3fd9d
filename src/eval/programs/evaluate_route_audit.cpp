// evaluate_route_audit: does the route audit predict the repeat's spread? For every keyframe of a
// route taught in a simulator world, the audit's predicted covariance of a Fast-HD fix `--offset`
// to the right of the keyframe (teach_repeat/route_audit.h) against the measured one: `--samples`
// images rendered near that pose (WorldRenderer, with the simulator's pixel noise and blur), each
// localized against the keyframe by the repeat's localizer (fast_hd, that keyframe only, no
// tracking), the errors taken against each image's true pose in the keyframe's base frame (x along,
// y across, yaw). Each image is taken at the probe moved by a uniform draw within ±`--jitter` [m]
// along and across and ±`--jitter-yaw` [rad], as the repeat's robot passes a keyframe never twice
// at one spot: images of one spot differ only by the renderer's grey-level noise, which moves the
// keypoints by ~0.03 px, so their errors are one draw of the place's error repeated, not a spread
// (`--jitter 0 --jitter-yaw 0` measures that). Per keyframe and axis, three comparisons
// (docs/route_audit.md):
//  - the error: predicted σ against the measured RMS error (bias included), their ratio;
//  - the spread from fix to fix: the part of the prediction that differs between fixes at the
//    keyframe (KeyframeAudit::predicted_fix_to_fix_covariance, the current image's pixel noise)
//    against the fixes' standard deviation about their linear trend in the offsets (what the fixes
//    share, the plane's error and the keyframe image's noise, changes smoothly with the pose);
//  - the bias: the fixes' mean error over the σ of the shared part (plus the spread's part of a
//    mean): one draw of a standard normal per keyframe and axis if the model is right, so judged
//    over the route (the fraction within 2 σ, the mean of z²).
// Over the route: the fraction of ratios within a factor of 2 and the correlation of the logs
// across keyframes. Where the spread comes from: each fix re-solved from its inliers with their
// current pixels put at their true positions plus a part of their measured error: the current
// image's part (the error less its keyframe keypoint's mean over the keyframe's fixes), the same
// part shuffled among the inliers (its spatial pattern broken, its size kept), and the keyframe
// keypoints' part alone (their mean): the spread of each against the same prediction. The
// inliers' errors grouped by keyframe keypoint also give the share of a match's error that is the
// keyframe keypoint's own (1/2 for iid noise in both images).
//   evaluate_route_audit --world W.yaml --route DIR --out DIR [--offset 0.3] [--samples 20 (>= 6)]
//                        [--pixel-sigma 0.30] [--jitter 0.05] [--jitter-yaw 0.035] [--noise 2.0] [--blur 0.5] [--camera-height 0.6] [--seed 1]
//                        [--images rendered|warped] [--inliers-out FILE] [--supersampling 1] [--texture-filtering 1]
// `--supersampling K` renders each pixel as the mean of K x K behind the lens's blur (RenderOptions::
// supersampling: band-limited, as a real camera; 1: one sample per pixel, which aliases a far wall);
// `--texture-filtering 1` (the simulator's default) band-limits each pixel by its footprint on the texture
// (RenderOptions::texture_filtering); 0 with --supersampling 1: one point of the scene per pixel.
// How smooth each fix's current-image errors are: an affine field of the image fitted to them
// explains 3/n of their variance if they are independent (`current_part_affine`, its share over
// that and how much its coefficients vary from fix to fix). `--images warped` localizes the
// keyframe's own image moved by its plane's homography to each fix's pose instead of a rendered one
// (the detector's answer to a change of view alone; the rendered images are still drawn, so a seed
// gives the same poses). `--inliers-out` writes every fix's inliers with their true positions (CSV),
// `--features-out` every keyframe plane feature per fix that its wall shows: where, the view's stretch of it, kept.
// The simulator knows where every inlier truly is: each keyframe pixel's ray meets a wall, which
// projects into the image's camera. The RMS of the inliers' distance from there (per coordinate,
// pooled over the route) is printed and written; `--pixel-sigma measure` makes it / √2 the
// prediction's pixel noise (both pixels of a match are noisy: the noise the fixes had, measured from
// the geometry, not from their pose errors).
// Writes OUT/route_audit_spread.json and OUT/route_audit_spread.png.
#include <Eigen/Dense>
#include <nlohmann/json.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <numeric>
#include <optional>
#include <set>
#include <vector>

#include "homography_teach_repeat/common/command_line.h"
#include "homography_teach_repeat/eval/plots.h"
#include "homography_teach_repeat/fast_hd/planar_pose_estimator.h"
#include "homography_teach_repeat/geometry/scene_plane.h"
#include "homography_teach_repeat/sim/planar_world.h"
#include "homography_teach_repeat/sim/world_renderer.h"
#include "homography_teach_repeat/teach_repeat/keyframe_store.h"
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

// Where a keyframe pixel truly is in another camera of the same world: its ray from the keyframe's
// camera to the first wall it meets, projected into the other camera (level cameras, as the
// renderer's). None when the ray meets no wall, the floor or the ceiling, or falls behind the other
// camera.
std::optional<Eigen::Vector2d> trueTransfer(const PlanarWorld& world, const PinholeCamera& camera, double camera_height,
                                            const Pose2D& from, const Pose2D& to, const Eigen::Vector2d& pixel) {
  // Optical frame: x right, y down, z forward; the ray's parameter t is the depth along the axis.
  const Eigen::Vector2d normalized = camera.pixelToNormalized(cv::Point2d(pixel.x(), pixel.y()));
  const Eigen::Vector2d origin(from.x, from.y);
  const Eigen::Vector2d direction = Pose2D(0.0, 0.0, from.yaw).transformPoint(Eigen::Vector2d(1.0, -normalized.x()));
  const auto hit = castRay(world, origin, direction);
  if (!hit) return std::nullopt;
  const double drop = normalized.y() * hit->range;  // how far below the camera the wall point is [m]
  const double height = camera_height - drop;
  if (height < 0.0 || height > world.walls[static_cast<std::size_t>(hit->wall)].height) return std::nullopt;
  const Eigen::Vector2d in_to = to.inverse().transformPoint(origin + hit->range * direction);  // (forward, left)
  const cv::Point2d projected = camera.project(Eigen::Vector3d(-in_to.y(), drop, in_to.x()));
  if (!std::isfinite(projected.x)) return std::nullopt;
  return Eigen::Vector2d(projected.x, projected.y);
}

// The spread of a keyframe's fixes: per axis the standard deviation of the errors about their
// least-squares plane in the images' offsets from the probe (1, along, across, yaw; RSS / (n − 4)).
// What a fix there shares with every other, the keyframe plane's error and the keyframe image's
// own noise, is a bias that changes smoothly with where the image was taken (the plane's error
// moves a pose in proportion to its distance from the keyframe: ±17 % over ±5 cm at 0.3 m); the
// fit takes that out and leaves what differs from image to image (docs/route_audit.md).
constexpr int kMinSpreadSamples = 6;
Eigen::Vector3d spreadAboutTrend(const std::vector<Eigen::Vector3d>& offsets, const std::vector<Eigen::Vector3d>& errors) {
  const auto n = static_cast<Eigen::Index>(errors.size());
  Eigen::MatrixXd design(n, 4);
  Eigen::MatrixXd observed(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    design.row(i) << 1.0, offsets[static_cast<std::size_t>(i)].transpose();
    observed.row(i) = errors[static_cast<std::size_t>(i)].transpose();
  }
  const Eigen::MatrixXd fitted = design * design.colPivHouseholderQr().solve(observed);
  return ((observed - fitted).colwise().squaredNorm().transpose() / static_cast<double>(n - 4)).cwiseSqrt();
}

// A pose's error (along, across, yaw) against the true one, both in the keyframe's base frame.
Eigen::Vector3d poseError(const Pose2D& measured, const Pose2D& expected) {
  return {measured.x - expected.x, measured.y - expected.y, wrapToPi(measured.yaw - expected.yaw)};
}

// One inlier of a fix: the match and where its keyframe pixel truly is in the fix's image.
struct InlierTruth {
  PointMatch match;
  Eigen::Vector2d truly;
};

// The parts of a fix's match errors it is re-solved with (the header's "where the spread comes from").
enum ErrorPart { kCurrentPart, kCurrentPartShuffled, kKeyframePart, kErrorParts };
const char* const kErrorPartNames[kErrorParts] = {"current_part", "current_part_shuffled", "keyframe_part"};

}  // namespace

int main(int argc, char** argv) {
  const RepeatOptions repeat_defaults;
  cli::Arguments args("evaluate_route_audit",
                      {{"world", ""}, {"route", ""}, {"out", ""}, {"offset", "0.3"}, {"samples", "20"},
                       {"pixel-sigma", "0.30"}, {"jitter", "0.05"}, {"jitter-yaw", "0.035"}, {"noise", "2.0"}, {"blur", "0.5"}, {"camera-height", "0.6"}, {"seed", "1"},
                       {"plane-sigma-from-neighbours", "1"}, {"pixel-noise-per-keyframe", repeat_defaults.pixel_noise_per_keyframe ? "1" : "0"}, {"stretch-noise-gain", "2"}, {"match-stretch-decay", "1.8"}, {"plots", "1"},
                       {"images", "rendered"}, {"inliers-out", ""}, {"features-out", ""}, {"supersampling", "1"}, {"texture-filtering", "1"}},
                      "--world W.yaml --route DIR --out DIR [--offset M] [--samples N] [--pixel-sigma PX|measure]\n"
                      "  [--jitter M] [--jitter-yaw RAD] (each image this far around the probe, uniformly)\n"
                      "  [--noise GREY] [--blur PX] [--camera-height M] [--supersampling K | --texture-filtering 0|1] (the simulator's camera; K > 1 replaces the filtering) [--seed S]\n"
                      "  [--plane-sigma-from-neighbours 0|1] (the prediction's plane terms, as repeat_node's)\n"
                      "  [--pixel-noise-per-keyframe 0|1] (each keyframe's pixel sigma scaled by its teach pairs' residual, as the repeat's)\n"
                      "  [--stretch-noise-gain K] (a match's noise 1 + K (stretch - 1) where the view stretches it; 0: off) [--plots 0|1]\n"
                      "  [--match-stretch-decay L] (a match's chance exp(-L (stretch - 1)) where the view stretches it; 0: off)\n"
                      "  [--images rendered|warped] (warped: the keyframe's own image moved by its plane's homography)\n"
                      "  [--inliers-out FILE] (every fix's inliers and their true positions, CSV)\n"
                      "  [--features-out FILE] (every fix's keyframe plane features: true position, stretch, matched; CSV)");
  args.parse(argc, argv);
  for (const char* required : {"world", "route", "out"}) {
    if (args.text(required).empty()) args.fail(std::string("--") + required + " is required");
  }
  const int samples = static_cast<int>(args.integer("samples"));
  if (samples < kMinSpreadSamples) {
    args.fail("--samples must be >= " + std::to_string(kMinSpreadSamples) + " (the spread is taken about a fit of 4 numbers)");
  }
  const bool warped_images = args.text("images") == "warped";
  if (!warped_images && args.text("images") != "rendered") args.fail("--images must be rendered or warped");
  const double jitter = args.number("jitter");
  const double jitter_yaw = args.number("jitter-yaw");
  if (!(jitter >= 0.0) || !(jitter_yaw >= 0.0)) args.fail("--jitter and --jitter-yaw must be >= 0");
  try {
    const auto world = loadPlanarWorld(args.text("world"));
    if (!world) throw std::runtime_error(world.status().message());
    const auto route = loadRoute(args.text("route"));
    if (!route) throw std::runtime_error(route.status().message());
    RenderOptions render;
    render.camera_height = args.number("camera-height");
    render.noise_sigma = args.number("noise");
    render.blur_sigma = args.number("blur");
    render.supersampling = static_cast<int>(args.integer("supersampling"));
    render.texture_filtering = render.supersampling == 1 && args.integer("texture-filtering") != 0;
    const PinholeCamera camera(route->info.camera);
    const WorldRenderer renderer(camera, render);
    const Pose2D& m = route->info.camera_mount;
    const CameraMount mount(m.x, m.y, m.yaw);
    cv::RNG rng(static_cast<std::uint64_t>(args.integer("seed")));
    cv::RNG shuffle_rng(static_cast<std::uint64_t>(args.integer("seed")) + 1);  // apart, so `rng` draws the images it drew
    RouteAuditOptions audit_options;
    audit_options.probe_offset_m = args.number("offset");
    audit_options.aliasing = false;
    audit_options.repeat.plane_sigma_from_neighbours = args.integer("plane-sigma-from-neighbours") != 0;
    // The simulator's exact camera: no common image shift (config/sim_repeat_node.yaml).
    audit_options.repeat.pose.common_shift_sigma_px = 0.0;
    audit_options.repeat.match_residual_gain = 0.0;  // the pixel σ is --pixel-sigma's
    audit_options.repeat.pixel_noise_per_keyframe = args.integer("pixel-noise-per-keyframe") != 0;
    audit_options.stretch_noise_gain = args.number("stretch-noise-gain");
    audit_options.match_stretch_decay = args.number("match-stretch-decay");
    const bool measure_pixel_sigma = args.text("pixel-sigma") == "measure";
    if (warped_images && camera.hasDistortion()) {
      throw std::runtime_error("--images warped needs a camera without distortion (the warp is the pinhole's homography)");
    }
    std::ofstream inliers_out;
    if (!args.text("inliers-out").empty()) {
      inliers_out.open(args.text("inliers-out"));
      if (!inliers_out) throw std::runtime_error("cannot write " + args.text("inliers-out"));
      inliers_out << std::setprecision(10) << "keyframe,fix,reference_u,reference_v,current_u,current_v,true_u,true_v,offset_along_m,"
                     "offset_across_m,offset_yaw_rad\n";
    }
    std::ofstream features_out;
    if (!args.text("features-out").empty()) {
      if (camera.hasDistortion()) throw std::runtime_error("--features-out needs a camera without distortion");
      features_out.open(args.text("features-out"));
      if (!features_out) throw std::runtime_error("cannot write " + args.text("features-out"));
      features_out << std::setprecision(10) << "keyframe,fix,reference_u,reference_v,size,true_u,true_v,stretch,inlier\n";
    }
    if (measure_pixel_sigma && camera.hasDistortion()) {
      throw std::runtime_error("--pixel-sigma measure needs a camera without distortion (the true transfer is the pinhole's)");
    }

    RepeatOptions repeat = audit_options.repeat;
    repeat.mode = RepeatMode::kFastHd;
    repeat.require_planes = false;
    repeat.neighbour_search = 0;
    repeat.max_degraded_frames = 0;
    repeat.max_tracked_frames = 0;
    auto localizer = RepeatLocalizer::create(*route, repeat);
    if (!localizer) throw std::runtime_error(localizer.status().message());
    std::optional<KeyframeStore> plane_features;  // what the localizer matches (--features-out)
    if (features_out.is_open()) {
      auto store = KeyframeStore::load(*route, repeat);
      if (!store) throw std::runtime_error(store.status().message());
      plane_features.emplace(std::move(*store));
    }
    // The robot whose camera is `offset` to the right of the keyframe's (as the audit's probe).
    const Pose2D probe = mount.cameraToBase(PlanarPose(audit_options.probe_offset_m, 0.0, 0.0));

    // The fixes: every keyframe with a plane, `samples` images around its probe.
    struct Fixes {
      Eigen::Vector3d second_moment = Eigen::Vector3d::Zero();  // of the error (along, across, yaw)
      // Per localized image: where it was taken relative to the probe (along, across, yaw) and its error.
      std::vector<Eigen::Vector3d> offsets, errors;
      std::vector<int> inliers_per_fix;
      std::vector<Pose2D> truths;  // where each image was taken, in the keyframe's base frame
      std::vector<std::vector<InlierTruth>> inlier_truths;  // per fix, its inliers whose true position is known
      // Per part, the offsets and errors of the fixes re-solved with it (ErrorPart).
      std::vector<Eigen::Vector3d> part_offsets[kErrorParts], part_errors[kErrorParts];
      // Per fix re-solved: an affine field of the image fitted to its current-image part, the share
      // of that part's variance it explains, and its six coefficients [px at the image's edge].
      std::vector<double> affine_shares, affine_shares_if_independent;
      std::vector<Eigen::Matrix<double, 6, 1>> affine_coefficients;
      int localized = 0;
      // The inliers' true error (each match's current pixel against where its keyframe pixel truly
      // is): the pixel noise the fixes actually had.
      double match_error_squares = 0.0;
      long match_coordinates = 0;
      // The same errors grouped by the keyframe keypoint they start from (its pixel): how much of
      // a match's error is that keypoint's own, the same in every fix, and how much the image's.
      std::map<std::pair<double, double>, std::vector<Eigen::Vector2d>> errors_by_keypoint;
      std::string failure;
    };
    std::vector<Fixes> fixes(route->keyframes.size());
    for (std::size_t index = 0; index < route->keyframes.size(); ++index) {
      const RouteKeyframe& keyframe = route->keyframes[index];
      if (!keyframe.plane) continue;
      Fixes& f = fixes[index];
      const Pose2D probe_pose = keyframe.pose.compose(probe);  // the route frame is the world's (teach odometry exact)
      const Pose2D keyframe_camera = keyframe.pose.compose(Pose2D(m.x, m.y, m.yaw));
      cv::Mat keyframe_image;
      if (warped_images) {
        auto loaded = loadKeyframeImage(*route, index);
        if (!loaded) throw std::runtime_error(loaded.status().message());
        keyframe_image = std::move(*loaded);
      }
      for (int s = 0; s < samples; ++s) {
        // Drawn in this order (yaw, across, along) so that a seed gives the images it gave before.
        const double yaw = rng.uniform(-jitter_yaw, jitter_yaw);
        const double across = rng.uniform(-jitter, jitter);
        const Pose2D offset(rng.uniform(-jitter, jitter), across, yaw);
        const Pose2D truth = probe_pose.compose(offset);
        const Pose2D camera_pose = truth.compose(Pose2D(m.x, m.y, m.yaw));
        // Rendered in either case: the draws of its noise keep the next offsets those of the rendered run.
        cv::Mat image = renderer.render(*world, camera_pose, 1.0, rng);
        if (warped_images) {
          // The keyframe's image as its plane's homography moves it to this camera: the same
          // picture seen from elsewhere (what the detector does with a change of view alone).
          const PlanarPose relative = mount.baseToCamera(keyframe.pose.inverse().compose(truth));
          cv::Mat H;
          cv::eigen2cv(Eigen::Matrix3d(planeInducedHomography(camera, relative, *keyframe.plane)), H);
          cv::warpPerspective(keyframe_image, image, H, keyframe_image.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                              cv::Scalar(world->floor_colour[0], world->floor_colour[1], world->floor_colour[2]));
        }
        localizer->setTrackedKeyframe(static_cast<int>(index));
        const auto estimate = localizer->localize(image);
        if (!estimate || !estimate->has_pose || estimate->keyframe != static_cast<int>(index)) {
          if (!estimate) f.failure = estimate.status().message();
          continue;
        }
        // The error in the keyframe's base frame, as the prediction's covariance.
        const Pose2D measured = keyframe.pose.inverse().compose(estimate->base_pose);
        const Pose2D expected = keyframe.pose.inverse().compose(truth);
        const Eigen::Vector3d e = poseError(measured, expected);
        f.second_moment += e.cwiseProduct(e);
        f.offsets.emplace_back(offset.x, offset.y, offset.yaw);
        f.errors.push_back(e);
        f.inliers_per_fix.push_back(estimate->inliers);
        f.truths.push_back(expected);
        f.inlier_truths.emplace_back();
        ++f.localized;
        if (camera.hasDistortion()) continue;
        if (features_out.is_open()) {
          // Which of the keyframe's plane features this camera truly sees, how much its view
          // stretches each (through the keyframe's plane), and whether the fix kept it.
          std::set<std::pair<double, double>> kept;
          for (const PointMatch& match : estimate->inlier_matches) kept.insert({match.reference.x(), match.reference.y()});
          const Eigen::Matrix3d H = planeInducedHomography(
              camera, mount.baseToCamera(keyframe.pose.inverse().compose(truth)), *keyframe.plane);
          for (const cv::KeyPoint& keypoint : plane_features->at(static_cast<int>(index)).features.keypoints) {
            const Eigen::Vector2d pixel(keypoint.pt.x, keypoint.pt.y);
            const auto truly = trueTransfer(*world, camera, render.camera_height, keyframe_camera, camera_pose, pixel);
            if (!truly) continue;  // hidden, or off its wall
            features_out << index << ',' << f.localized - 1 << ',' << pixel.x() << ',' << pixel.y() << ',' << keypoint.size
                         << ',' << truly->x() << ',' << truly->y() << ',' << localStretch(H, pixel).value_or(NAN) << ','
                         << kept.count({pixel.x(), pixel.y()}) << '\n';
          }
        }
        for (const PointMatch& match : estimate->inlier_matches) {
          const auto truly = trueTransfer(*world, camera, render.camera_height, keyframe_camera, camera_pose, match.reference);
          if (truly) f.inlier_truths.back().push_back({match, *truly});
        }
      }
      for (std::size_t fix = 0; fix < f.inlier_truths.size() && inliers_out.is_open(); ++fix) {
        for (const InlierTruth& inlier : f.inlier_truths[fix]) {
          inliers_out << index << ',' << fix << ',' << inlier.match.reference.x() << ',' << inlier.match.reference.y()
                      << ',' << inlier.match.current.x() << ',' << inlier.match.current.y() << ',' << inlier.truly.x()
                      << ',' << inlier.truly.y() << ',' << f.offsets[fix].x() << ',' << f.offsets[fix].y() << ','
                      << f.offsets[fix].z() << '\n';
        }
      }
      for (const std::vector<InlierTruth>& fix : f.inlier_truths) {
        for (const InlierTruth& inlier : fix) {
          const Eigen::Vector2d error = inlier.match.current - inlier.truly;
          f.match_error_squares += error.squaredNorm();
          f.match_coordinates += 2;
          f.errors_by_keypoint[{inlier.match.reference.x(), inlier.match.reference.y()}].push_back(error);
        }
      }
      // Where the spread comes from: each fix re-solved from its inliers at their true positions
      // plus a part of their errors. A keyframe keypoint's own error is its errors' mean over the
      // fixes that matched it (kept where two or more did).
      std::map<std::pair<double, double>, Eigen::Vector2d> keypoint_error;
      for (const auto& [pixel, errors] : f.errors_by_keypoint) {
        if (errors.size() < 2) continue;
        Eigen::Vector2d mean = Eigen::Vector2d::Zero();
        for (const Eigen::Vector2d& e : errors) mean += e / static_cast<double>(errors.size());
        keypoint_error[pixel] = mean;
      }
      for (std::size_t fix = 0; fix < f.inlier_truths.size(); ++fix) {
        PointMatches kept;
        std::vector<Eigen::Vector2d> truly, current_part, keyframe_part;
        for (const InlierTruth& inlier : f.inlier_truths[fix]) {
          const auto own = keypoint_error.find({inlier.match.reference.x(), inlier.match.reference.y()});
          if (own == keypoint_error.end()) continue;
          kept.push_back(inlier.match);
          truly.push_back(inlier.truly);
          keyframe_part.push_back(own->second);
          current_part.push_back(inlier.match.current - inlier.truly - own->second);
        }
        // How smooth the current image's part is: an affine field of the image position (x and y
        // scaled to ±1 at the image's edges) fitted to it explains 3/n of its variance per
        // coordinate if the errors are independent, more where they move together.
        if (current_part.size() > 6) {
          const auto rows = static_cast<Eigen::Index>(current_part.size());
          Eigen::MatrixXd A(rows, 3), E(rows, 2);
          for (Eigen::Index i = 0; i < rows; ++i) {
            const Eigen::Vector2d& at = truly[static_cast<std::size_t>(i)];
            A.row(i) << 1.0, (at.x() - camera.cx()) / camera.cx(), (at.y() - camera.cy()) / camera.cy();
            E.row(i) = current_part[static_cast<std::size_t>(i)].transpose();
          }
          const Eigen::MatrixXd coefficients = A.colPivHouseholderQr().solve(E);  // 3 x 2
          const double total = E.squaredNorm();
          if (total > 0.0) {
            f.affine_shares.push_back((A * coefficients).squaredNorm() / total);
            f.affine_shares_if_independent.push_back(3.0 / static_cast<double>(rows));
            f.affine_coefficients.push_back(Eigen::Map<const Eigen::Matrix<double, 6, 1>>(coefficients.data()));
          }
        }
        std::vector<Eigen::Vector2d> shuffled = current_part;
        for (std::size_t i = shuffled.size(); i > 1; --i) {
          std::swap(shuffled[i - 1], shuffled[static_cast<std::size_t>(shuffle_rng.uniform(0, static_cast<int>(i)))]);
        }
        const std::vector<Eigen::Vector2d>* parts[kErrorParts] = {&current_part, &shuffled, &keyframe_part};
        for (int part = 0; part < kErrorParts; ++part) {
          for (std::size_t i = 0; i < kept.size(); ++i) kept[i].current = truly[i] + (*parts[part])[i];
          const auto solved = estimatePlanarPoseFromInliers(kept, camera, *keyframe.plane, repeat.pose);
          if (!solved) continue;
          f.part_offsets[part].push_back(f.offsets[fix]);
          f.part_errors[part].push_back(poseError(mount.cameraToBase(solved->pose), f.truths[fix]));
        }
      }
    }
    double match_error_squares = 0.0;
    long match_coordinates = 0;
    for (const Fixes& f : fixes) {
      match_error_squares += f.match_error_squares;
      match_coordinates += f.match_coordinates;
    }
    const double inlier_error =
        match_coordinates > 0 ? std::sqrt(match_error_squares / static_cast<double>(match_coordinates)) : NAN;
    // Of the keypoints matched in at least two fixes: the variance of their errors (per coordinate)
    // and the part within each keypoint's fixes; the rest, the keypoint's own, is the share every
    // fix against the keyframe has in common (iid noise in both images: 1/2).
    double total_squares = 0.0, within_squares = 0.0;
    long total_count = 0, within_dof = 0;
    for (const Fixes& f : fixes) {
      for (const auto& [pixel, errors] : f.errors_by_keypoint) {
        if (errors.size() < 2) continue;
        Eigen::Vector2d mean = Eigen::Vector2d::Zero();
        for (const Eigen::Vector2d& e : errors) mean += e / static_cast<double>(errors.size());
        for (const Eigen::Vector2d& e : errors) {
          total_squares += e.squaredNorm();
          within_squares += (e - mean).squaredNorm();
        }
        total_count += 2 * static_cast<long>(errors.size());
        within_dof += 2 * (static_cast<long>(errors.size()) - 1);
      }
    }
    const double match_error_variance = total_count > 0 ? total_squares / static_cast<double>(total_count) : NAN;
    const double within_variance = within_dof > 0 ? within_squares / static_cast<double>(within_dof) : NAN;
    const double keyframe_share = std::clamp(1.0 - within_variance / match_error_variance, 0.0, 1.0);
    std::printf("of the match error of keypoints matched in two fixes or more (%.3f px rms), the keyframe keypoint's "
                "own share (the same in every fix): %.2f\n",
                std::sqrt(match_error_variance), keyframe_share);
    // Both pixels of a match carry the noise (docs/math.md §3.4: σ on all 4n coordinates), so the
    // error of the current pixel against the keyframe pixel's true transfer has about twice its variance.
    const double measured_pixel_sigma = inlier_error / std::sqrt(2.0);
    std::printf("the fixes' inliers: %.3f px rms per coordinate off their true position: pixel noise %.3f px\n",
                inlier_error, measured_pixel_sigma);
    if (measure_pixel_sigma) {
      if (!std::isfinite(measured_pixel_sigma)) throw std::runtime_error("no inlier to measure the pixel noise with");
      audit_options.repeat.pose.pixel_sigma_px = measured_pixel_sigma;
    } else {
      audit_options.repeat.pose.pixel_sigma_px = args.number("pixel-sigma");
    }
    const auto audit = auditRoute(*route, audit_options);
    if (!audit) throw std::runtime_error(audit.status().message());

    nlohmann::json document;
    document["kind"] = "route_audit_spread";
    document["world"] = args.text("world");
    document["route"] = route->directory;
    document["setup"] = {{"offset_m", audit_options.probe_offset_m}, {"samples", samples},
                         {"pixel_sigma", audit_options.repeat.pose.pixel_sigma_px},
                         {"pixel_sigma_measured", measure_pixel_sigma}, {"inlier_error_px", inlier_error},
                         {"keyframe_share_of_match_error", keyframe_share},
                         {"jitter_m", jitter}, {"jitter_yaw_rad", jitter_yaw}, {"noise", render.noise_sigma},
                         {"blur", render.blur_sigma}, {"camera_height_m", render.camera_height},
                         {"supersampling", render.supersampling}, {"texture_filtering", render.texture_filtering}, {"images", args.text("images")},
                         {"plane_sigma_from_neighbours", audit_options.repeat.plane_sigma_from_neighbours},
                         {"pixel_noise_per_keyframe", audit_options.repeat.pixel_noise_per_keyframe},
                         {"stretch_noise_gain", audit_options.stretch_noise_gain},
                         {"match_stretch_decay", audit_options.match_stretch_decay}};
    std::vector<double> log_predicted[3], log_measured[3], log_predicted_spread[3], log_measured_spread[3];
    int within = 0, compared = 0, spread_within = 0;  // each over `compared` ratios
    // The bias of each keyframe's fixes (their mean error) over the σ the model gives it (the shared
    // part plus the spread's part of a mean of n): one draw of a standard normal per keyframe and
    // axis if the model is right, so judged over the route (mean z², |z| < 2), not one by one.
    int bias_within_2_sigma = 0;
    int part_within[kErrorParts] = {0, 0, 0}, part_compared[kErrorParts] = {0, 0, 0};
    double bias_z_squares = 0.0;
    std::vector<std::pair<double, int>> affine_share_ratios;  // (share over the independent errors' share, keyframe)
    // The part of the plane features in view a fix was expected to match, and the part its fixes
    // matched (their mean inliers over the features the probe sees), per keyframe.
    std::vector<double> expected_parts, matched_parts;
    std::printf("%4s %8s %8s | %22s | %22s | %s\n", "kf", "x [m]", "y [m]", "predicted sigma", "measured rms",
                "ratio measured/predicted (along, across, heading) | the same of the spread from fix to fix");
    for (const KeyframeAudit& a : audit->keyframes) {
      nlohmann::json k = {{"keyframe", a.keyframe}, {"pose", {a.pose.x, a.pose.y, a.pose.yaw}},
                          {"neighbour_inliers", a.neighbour_inliers}, {"pixel_noise_scale", a.pixel_noise_scale},
                          {"stretch_noise_scale", a.stretch_noise_scale},
                          {"predicted_matches", a.predicted_matches},
                          {"expected_match_fraction", a.expected_match_fraction},
                          {"neighbour_plane_features_in_view", a.neighbour_plane_features_in_view},
                          {"neighbour_match_fraction", a.neighbour_match_fraction},
                          {"match_stretch_scale", a.match_stretch_scale}};
      const Fixes& f = fixes[static_cast<std::size_t>(a.keyframe)];
      k["localized"] = f.localized;
      if (f.localized > 0) {
        const double inliers_mean =
            static_cast<double>(std::accumulate(f.inliers_per_fix.begin(), f.inliers_per_fix.end(), 0L)) / f.localized;
        k["inliers_mean"] = inliers_mean;
        if (a.predicted_covariance && a.predicted_matches > 0) {
          expected_parts.push_back(a.expected_match_fraction);
          matched_parts.push_back(inliers_mean / a.predicted_matches);
        }
      }
      // Every fix: where its image was taken relative to the probe (along, across, yaw), its error, its inliers.
      for (std::size_t i = 0; i < f.errors.size(); ++i) {
        k["fixes"].push_back({{"offset", {f.offsets[i].x(), f.offsets[i].y(), f.offsets[i].z()}},
                              {"error", {f.errors[i].x(), f.errors[i].y(), f.errors[i].z()}},
                              {"inliers", f.inliers_per_fix[i]}});
      }
      if (f.match_coordinates > 0) {
        k["match_error_px"] = std::sqrt(f.match_error_squares / static_cast<double>(f.match_coordinates));
      }
      if (!f.affine_shares.empty()) {
        const auto count = static_cast<double>(f.affine_shares.size());
        const double share = std::accumulate(f.affine_shares.begin(), f.affine_shares.end(), 0.0) / count;
        const double independent =
            std::accumulate(f.affine_shares_if_independent.begin(), f.affine_shares_if_independent.end(), 0.0) / count;
        Eigen::Matrix<double, 6, 1> mean_coefficients = Eigen::Matrix<double, 6, 1>::Zero(), squares = mean_coefficients;
        for (const auto& c : f.affine_coefficients) mean_coefficients += c / count;
        for (const auto& c : f.affine_coefficients) squares += (c - mean_coefficients).cwiseAbs2() / count;
        k["current_part_affine"] = {{"share", share}, {"share_if_independent", independent},
                                    {"share_ratio", share / independent},
                                    {"coefficient_spread_px", squares.cwiseSqrt().mean()}};
        affine_share_ratios.emplace_back(share / independent, a.keyframe);
      }
      if (!a.predicted_covariance) {
        k["problem"] = a.prediction_problem.empty() ? "no prediction" : a.prediction_problem;
        document["keyframes"].push_back(k);
        std::printf("%4d %8.2f %8.2f | no prediction: %s (localized %d of %d)\n", a.keyframe, a.pose.x, a.pose.y,
                    k["problem"].get<std::string>().c_str(), f.localized, samples);
        continue;
      }
      if (f.localized < kMinSpreadSamples) {
        k["problem"] = "localized " + std::to_string(f.localized) + " of " + std::to_string(samples) + ": " + f.failure;
        document["keyframes"].push_back(k);
        std::printf("%4d %8.2f %8.2f | not localized: %s\n", a.keyframe, a.pose.x, a.pose.y, f.failure.c_str());
        continue;
      }
      const double n = f.localized;
      const Eigen::Vector3d rms = (f.second_moment / n).cwiseSqrt();
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (const Eigen::Vector3d& e : f.errors) mean += e / n;
      const Eigen::Vector3d spread = spreadAboutTrend(f.offsets, f.errors);
      const Eigen::Vector3d sigma = a.predicted_covariance->diagonal().cwiseSqrt();
      const Eigen::Vector3d fix_to_fix_variance = a.predicted_fix_to_fix_covariance->diagonal();
      const Eigen::Vector3d spread_sigma = fix_to_fix_variance.cwiseSqrt();
      const Eigen::Vector3d bias_sigma =
          (a.predicted_covariance->diagonal() - fix_to_fix_variance + fix_to_fix_variance / n).cwiseMax(0.0).cwiseSqrt();
      nlohmann::json predicted, measured_rms, ratio, predicted_spread, measured_spread, spread_ratio, bias, bias_z;
      for (int i = 0; i < 3; ++i) {
        predicted[kAxes[i]] = sigma(i);
        measured_rms[kAxes[i]] = rms(i);
        const double r = rms(i) / sigma(i);
        ratio[kAxes[i]] = r;
        ++compared;
        within += r >= 0.5 && r <= 2.0 ? 1 : 0;
        log_predicted[i].push_back(std::log(sigma(i)));
        log_measured[i].push_back(std::log(rms(i)));
        predicted_spread[kAxes[i]] = spread_sigma(i);
        measured_spread[kAxes[i]] = spread(i);
        const double rs = spread(i) / spread_sigma(i);
        spread_ratio[kAxes[i]] = rs;
        spread_within += rs >= 0.5 && rs <= 2.0 ? 1 : 0;
        log_predicted_spread[i].push_back(std::log(spread_sigma(i)));
        log_measured_spread[i].push_back(std::log(spread(i)));
        const double z = mean(i) / bias_sigma(i);
        bias[kAxes[i]] = mean(i);
        bias_z[kAxes[i]] = z;
        bias_within_2_sigma += std::abs(z) < 2.0 ? 1 : 0;
        bias_z_squares += z * z;
      }
      for (int part = 0; part < kErrorParts; ++part) {
        if (f.part_errors[part].size() < static_cast<std::size_t>(kMinSpreadSamples)) continue;
        const Eigen::Vector3d part_spread = spreadAboutTrend(f.part_offsets[part], f.part_errors[part]);
        for (int i = 0; i < 3; ++i) {
          const double r = part_spread(i) / spread_sigma(i);
          k["spread_ratio_by_error_part"][kErrorPartNames[part]][kAxes[i]] = r;
          ++part_compared[part];
          part_within[part] += r >= 0.5 && r <= 2.0 ? 1 : 0;
        }
      }
      k["predicted_sigma"] = predicted;
      k["measured_rms"] = measured_rms;
      k["ratio"] = ratio;
      k["predicted_spread_sigma"] = predicted_spread;
      k["measured_spread"] = measured_spread;
      k["spread_ratio"] = spread_ratio;
      k["bias"] = bias;
      k["bias_z"] = bias_z;
      document["keyframes"].push_back(k);
      std::printf("%4d %8.2f %8.2f | %6.4f %6.4f %8.5f | %6.4f %6.4f %8.5f | %.2f %.2f %.2f | %.2f %.2f %.2f\n",
                  a.keyframe, a.pose.x, a.pose.y, sigma(0), sigma(1), sigma(2), rms(0), rms(1), rms(2),
                  rms(0) / sigma(0), rms(1) / sigma(1), rms(2) / sigma(2), spread(0) / spread_sigma(0),
                  spread(1) / spread_sigma(1), spread(2) / spread_sigma(2));
    }
    nlohmann::json summary = {{"keyframes", audit->keyframes.size()}, {"ratios_compared", compared},
                              {"ratios_within_factor_2", within},
                              {"fraction_within_factor_2", compared > 0 ? static_cast<double>(within) / compared : NAN}};
    for (int i = 0; i < 3; ++i) summary[std::string("log_correlation_") + kAxes[i]] = correlation(log_predicted[i], log_measured[i]);
    summary["spread_ratios_compared"] = compared;
    summary["spread_ratios_within_factor_2"] = spread_within;
    for (int i = 0; i < 3; ++i) {
      summary[std::string("spread_log_correlation_") + kAxes[i]] = correlation(log_predicted_spread[i], log_measured_spread[i]);
    }
    summary["bias_compared"] = compared;
    summary["bias_within_2_sigma"] = bias_within_2_sigma;
    summary["bias_mean_z_squared"] = compared > 0 ? bias_z_squares / compared : NAN;
    for (int part = 0; part < kErrorParts; ++part) {
      summary["spread_by_error_part"][kErrorPartNames[part]] = {{"compared", part_compared[part]},
                                                                {"within_factor_2", part_within[part]}};
    }
    std::string smooth_keyframes;
    if (!affine_share_ratios.empty()) {
      std::vector<double> ratios;
      for (const auto& [ratio, keyframe] : affine_share_ratios) {
        ratios.push_back(ratio);
        if (ratio >= 1.5) smooth_keyframes += (smooth_keyframes.empty() ? "" : ", ") + std::to_string(keyframe);
      }
      std::nth_element(ratios.begin(), ratios.begin() + static_cast<std::ptrdiff_t>(ratios.size() / 2), ratios.end());
      summary["current_part_affine_share_ratio_median"] = ratios[ratios.size() / 2];
    }
    if (!expected_parts.empty()) {
      std::vector<double> part_ratios;
      int parts_within = 0;
      for (std::size_t i = 0; i < expected_parts.size(); ++i) {
        part_ratios.push_back(expected_parts[i] / matched_parts[i]);
        parts_within += part_ratios.back() >= 1.0 / 1.5 && part_ratios.back() <= 1.5 ? 1 : 0;
      }
      std::nth_element(part_ratios.begin(), part_ratios.begin() + static_cast<std::ptrdiff_t>(part_ratios.size() / 2),
                       part_ratios.end());
      summary["matched_part"] = {{"compared", expected_parts.size()},
                                 {"expected_over_matched_median", part_ratios[part_ratios.size() / 2]},
                                 {"within_factor_1_5", parts_within},
                                 {"correlation", correlation(expected_parts, matched_parts)}};
      std::printf("the part of the plane features in view a fix matches: expected over the fixes' a median %.2f, within "
                  "a factor of 1.5 at %d of %zu keyframes, correlation %.2f\n",
                  part_ratios[part_ratios.size() / 2], parts_within, expected_parts.size(),
                  summary["matched_part"]["correlation"].get<double>());
    }
    document["summary"] = summary;
    std::printf("%d of %d ratios within a factor of 2; correlation of log sigma predicted vs measured: along %.2f, "
                "across %.2f, heading %.2f\n",
                within, compared, summary["log_correlation_along_m"].get<double>(),
                summary["log_correlation_across_m"].get<double>(), summary["log_correlation_heading_rad"].get<double>());
    std::printf("spread (each keyframe's fixes about their trend) against the predicted fix-to-fix sigma: %d of %d within a "
                "factor of 2; log correlation along %.2f, across %.2f, heading %.2f\n",
                spread_within, compared, summary["spread_log_correlation_along_m"].get<double>(),
                summary["spread_log_correlation_across_m"].get<double>(),
                summary["spread_log_correlation_heading_rad"].get<double>());
    std::printf("the fixes re-solved from their inliers at their true positions plus the current image's part of their "
                "errors: %d of %d spreads within a factor of 2; that part shuffled among the inliers: %d of %d; the "
                "keyframe keypoints' part alone: %d of %d\n",
                part_within[kCurrentPart], part_compared[kCurrentPart], part_within[kCurrentPartShuffled],
                part_compared[kCurrentPartShuffled], part_within[kKeyframePart], part_compared[kKeyframePart]);
    if (summary.contains("current_part_affine_share_ratio_median")) {
      std::printf("the current image's part of a fix's errors: an affine field of the image explains a median %.2f times "
                  "the share it would of independent errors (1.5 times or more at keyframes %s)\n",
                  summary["current_part_affine_share_ratio_median"].get<double>(),
                  smooth_keyframes.empty() ? "none" : smooth_keyframes.c_str());
    }
    std::printf("bias (each keyframe's mean error) over its predicted sigma: %d of %d within 2 sigma, mean z^2 %.2f "
                "(a right model: 95 %%, 1)\n",
                bias_within_2_sigma, compared, summary["bias_mean_z_squared"].get<double>());
    const std::filesystem::path out = args.text("out");
    std::filesystem::create_directories(out);
    const std::string json_path = (out / "route_audit_spread.json").string();
    std::ofstream(json_path) << document.dump(1) << "\n";
    std::fflush(stdout);  // before the plotting child writes to the same stream
    if (args.integer("plots") != 0 && eval::drawPlots(json_path, "evaluate_route_audit") != 0) return 1;
  } catch (const std::exception& e) {
    std::cerr << "evaluate_route_audit: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
