// evaluate_learning: does a route that learned from one repeat run localize more frames than the
// route taught once, where the world changed after the teach run (docs/route_format.md,
// "Experiences")? Without ROS, on the simulator's renderer and the repeat's pipeline:
//   1. a learning run: images rendered along the taught path (`--learn-offset` m to the left of
//      it) in the changed world (`--variant`, `--light`), localized by the repeat pipeline on the
//      taught route; an ExperienceRecorder keeps, per keyframe whose taught view was weak, the frame
//      nearest to it, and adds them to a copy of the route (OUT/learned_route);
//   2. a test run along another line (`--test-offset` m) and with other pixel noise, repeated on
//      the taught route and on the learned one: the frames with a visual fix (a pose from a
//      keyframe's taught view or one of its experiences, not the temporary reference) are counted.
// The poses of both runs are the true ones (odometry without drift): what is measured is whether
// vision recognizes the place, not the filter.
//   evaluate_learning --world W.yaml --route DIR --out DIR [--variant 1] [--light 0.8] [--mode hybrid]
//                     [--step 0.1] [--learn-offset 0.05] [--test-offset -0.05] [--noise 2.0]
//                     [--blur 0.5] [--camera-height 0.6] [--seed 1] [--plots 0|1]
// Writes OUT/learning.json {"frames", "localized_taught_once", "localized_learned",
// "experiences_added", "experience_fix_error" / "taught_fix_error" {median_m, max_m, frames} (the
// learned route's fixes against the true poses), "per_frame": [{"s_m", "taught_once", "learned",
// "experience"}], ...} and
// OUT/learning.png. Exit code 1 on bad input (a file, a variant no wall has).
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <vector>

#include "homography_teach_repeat/common/command_line.h"
#include "homography_teach_repeat/eval/plots.h"
#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/sim/planar_world.h"
#include "homography_teach_repeat/sim/world_renderer.h"
#include "homography_teach_repeat/teach_repeat/experience_learning.h"
#include "homography_teach_repeat/teach_repeat/repeat_pipeline.h"
#include "homography_teach_repeat/teach_repeat/teach_session.h"

using namespace homography_teach_repeat;

namespace {

// Base poses along the taught keyframes, at most `step` metres and 0.1 rad apart, each moved
// `offset` metres to its left.
std::vector<Pose2D> pathThrough(const std::vector<RouteKeyframe>& keyframes, double step, double offset) {
  std::vector<Pose2D> poses;
  for (std::size_t k = 0; k + 1 < keyframes.size(); ++k) {
    const Pose2D& a = keyframes[k].pose;
    const Pose2D& b = keyframes[k + 1].pose;
    const double turn = wrapToPi(b.yaw - a.yaw);
    const int n = std::max(1, static_cast<int>(std::ceil(std::max(std::hypot(b.x - a.x, b.y - a.y) / step,
                                                                 std::abs(turn) / 0.1))));
    for (int i = 0; i < n; ++i) {
      const double f = static_cast<double>(i) / n;
      const Pose2D p(a.x + f * (b.x - a.x), a.y + f * (b.y - a.y), wrapToPi(a.yaw + f * turn));
      poses.push_back(p.compose(Pose2D(0.0, offset, 0.0)));
    }
  }
  poses.push_back(keyframes.back().pose.compose(Pose2D(0.0, offset, 0.0)));
  return poses;
}

struct Pass {
  std::vector<int> experience;  // per frame: -1 no visual fix, 0 the taught view, k > 0 experience k
  std::vector<double> error;    // per frame: the fix's position error [m] (NaN without a fix)
  int localized() const {
    return static_cast<int>(std::count_if(experience.begin(), experience.end(), [](int e) { return e >= 0; }));
  }
};

// Median and largest of the errors of the frames whose fix came from an experience (or, with
// `taught`, from a taught view); null without such frames.
nlohmann::json errorsOf(const Pass& pass, bool taught) {
  std::vector<double> errors;
  for (std::size_t i = 0; i < pass.error.size(); ++i) {
    if (pass.experience[i] < 0 || (pass.experience[i] == 0) != taught) continue;
    errors.push_back(pass.error[i]);
  }
  if (errors.empty()) return nullptr;
  std::sort(errors.begin(), errors.end());
  return {{"median_m", errors[errors.size() / 2]}, {"max_m", errors.back()}, {"frames", errors.size()}};
}

// One run of the pipeline over `poses` (true odometry), images rendered with `rng`; `recorder`
// (optional) observes every frame.
Pass run(const Route& route, const RepeatPipelineOptions& options, const PlanarWorld& world,
         const WorldRenderer& renderer, double gain, const std::vector<Pose2D>& poses, cv::RNG& rng,
         ExperienceRecorder* recorder) {
  auto pipeline = RepeatPipeline::create(route, options);
  if (!pipeline) throw std::runtime_error(pipeline.status().message());
  const Pose2D& m = route.info.camera_mount;
  const PinholeCamera camera(route.info.camera);
  Pass pass;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const double stamp = 1.0 + 0.1 * static_cast<double>(i);
    (void)pipeline->addOdometry(stamp, poses[i]);
    const cv::Mat image = renderer.render(world, poses[i].compose(Pose2D(m.x, m.y, m.yaw)), gain, rng);
    const RepeatFrameResult result = pipeline->processFrame(stamp, image, camera);
    const bool fix = result.status.isOk() && result.estimate && result.estimate->has_pose && !result.estimate->degraded;
    pass.experience.push_back(fix ? result.estimate->experience : -1);
    pass.error.push_back(fix ? std::hypot(result.estimate->base_pose.x - poses[i].x, result.estimate->base_pose.y - poses[i].y)
                             : std::nan(""));
    if (recorder) {
      if (const auto observation = observationOf(stamp, image, result)) recorder->observe(*observation);
    }
  }
  return pass;
}

}  // namespace

int main(int argc, char** argv) {
  cli::Arguments args("evaluate_learning",
                      {{"world", ""}, {"route", ""}, {"out", ""}, {"variant", "1"}, {"light", "0.8"},
                       {"mode", "hybrid"}, {"step", "0.1"}, {"learn-offset", "0.05"}, {"test-offset", "-0.05"},
                       {"noise", "2.0"}, {"blur", "0.5"}, {"camera-height", "0.6"}, {"seed", "1"}, {"plots", "1"}},
                      "--world W.yaml --route DIR --out DIR [--variant K] [--light GAIN] [--mode hybrid|fast_hd]\n"
                      "  [--step M] [--learn-offset M] [--test-offset M] [--noise GREY] [--blur PX] [--camera-height M]\n"
                      "  [--seed S] [--plots 0|1]");
  args.parse(argc, argv);
  for (const char* required : {"world", "route", "out"}) {
    if (args.text(required).empty()) args.fail(std::string("--") + required + " is required");
  }
  try {
    const auto taught_world = loadPlanarWorld(args.text("world"));
    if (!taught_world) throw std::runtime_error(taught_world.status().message());
    const auto changed = taught_world->withAppearance(static_cast<int>(args.integer("variant")));
    if (!changed) throw std::runtime_error("--variant: " + changed.status().message());
    const double gain = args.number("light");
    if (!(gain > 0.0) || !std::isfinite(gain)) args.fail("--light must be > 0");
    const double step = args.number("step");
    if (!(step > 0.0) || !std::isfinite(step)) args.fail("--step must be > 0");
    const auto taught = loadRoute(args.text("route"));
    if (!taught) throw std::runtime_error(taught.status().message());
    if (taught->keyframes.size() < 2) throw std::runtime_error("the route needs at least 2 keyframes");

    // The learned route starts as a copy of the taught one.
    const std::filesystem::path out = args.text("out");
    const std::filesystem::path learned_directory = out / "learned_route";
    std::filesystem::remove_all(learned_directory);
    std::filesystem::create_directories(out);
    std::filesystem::copy(taught->directory, learned_directory, std::filesystem::copy_options::recursive);
    const Status migrated = migrateRoute(learned_directory.string());
    if (!migrated.isOk()) throw std::runtime_error(migrated.message());
    auto learned = loadRoute(learned_directory.string());
    if (!learned) throw std::runtime_error(learned.status().message());

    RepeatPipelineOptions options;
    options.localization.mode = repeatModeFromString(args.text("mode"));
    // The simulator's exact camera: no common image shift (config/sim_repeat_node.yaml).
    options.localization.pose.common_shift_sigma_px = 0.0;
    RenderOptions render;
    render.noise_sigma = args.number("noise");
    render.blur_sigma = args.number("blur");
    render.camera_height = args.number("camera-height");
    const WorldRenderer renderer(PinholeCamera(taught->info.camera), render);
    const std::vector<Pose2D> learn_path = pathThrough(taught->keyframes, step, args.number("learn-offset"));
    const std::vector<Pose2D> test_path = pathThrough(taught->keyframes, step, args.number("test-offset"));
    std::vector<Pose2D> keyframe_poses;
    for (const auto& k : taught->keyframes) keyframe_poses.push_back(k.pose);

    // 1. The learning run.
    ExperienceRecorder recorder(keyframe_poses, ExperienceLearningOptions());
    cv::RNG learn_rng(static_cast<std::uint64_t>(args.integer("seed")));
    const Pass learning = run(*taught, options, *changed, renderer, gain, learn_path, learn_rng, &recorder);
    FeatureExtractor extractor(FeatureOptions{taught->info.feature_type, options.localization.max_features});
    const std::optional<double> residual_taught = routeMatchResidual(*learned);
    const std::optional<double> tilt_taught = routeTiltSigma(*learned);
    const auto added = recorder.commit(*learned, extractor);
    if (!added) throw std::runtime_error(added.status().message());
    auto reloaded = loadRoute(learned_directory.string());  // as a repeat node would read it
    if (!reloaded) throw std::runtime_error(reloaded.status().message());

    // 2. The test run on both routes, with the same images.
    const std::uint64_t test_seed = static_cast<std::uint64_t>(args.integer("seed")) + 1000;
    cv::RNG once_rng(test_seed), learned_rng(test_seed);
    const Pass once = run(*taught, options, *changed, renderer, gain, test_path, once_rng, nullptr);
    const Pass after = run(*reloaded, options, *changed, renderer, gain, test_path, learned_rng, nullptr);

    nlohmann::json doc;
    doc["kind"] = "learning";
    doc["world"] = args.text("world");
    doc["route"] = taught->directory;
    doc["variant"] = args.integer("variant");
    doc["light"] = gain;
    doc["mode"] = args.text("mode");
    doc["keyframes"] = taught->keyframes.size();
    doc["frames"] = test_path.size();
    doc["learning_run_localized"] = learning.localized();
    doc["experiences_added"] = *added;
    // The route's measured noise before and after the learning run (its learned pairs, route_format.md).
    doc["match_residual_px"] = {{"taught", residual_taught.value_or(0.0)},
                                {"learned", routeMatchResidual(*reloaded).value_or(0.0)}};
    doc["tilt_sigma_rad"] = {{"taught", tilt_taught.value_or(0.0)}, {"learned", routeTiltSigma(*reloaded).value_or(0.0)}};
    int measured_pairs = 0;
    for (const auto& k : reloaded->keyframes) {
      for (const auto& e : k.experiences) measured_pairs += e.match_residual ? 1 : 0;
    }
    doc["experiences_measured"] = measured_pairs;
    doc["localized_taught_once"] = once.localized();
    doc["localized_learned"] = after.localized();
    int by_experience = 0;
    for (const int e : after.experience) by_experience += e > 0 ? 1 : 0;
    doc["localized_by_experiences"] = by_experience;
    // How right those fixes are (the test run's true poses): from the experiences, from taught views.
    doc["experience_fix_error"] = errorsOf(after, false);
    doc["taught_fix_error"] = errorsOf(after, true);
    doc["per_frame"] = nlohmann::json::array();
    double s = 0.0;
    for (std::size_t i = 0; i < test_path.size(); ++i) {
      if (i > 0) s += std::hypot(test_path[i].x - test_path[i - 1].x, test_path[i].y - test_path[i - 1].y);
      doc["per_frame"].push_back({{"s_m", s},
                                  {"x_m", test_path[i].x},
                                  {"y_m", test_path[i].y},
                                  {"taught_once", once.experience[i] >= 0},
                                  {"learned", after.experience[i] >= 0},
                                  {"experience", after.experience[i]}});
    }
    const std::string json_path = (out / "learning.json").string();
    std::ofstream(json_path) << doc.dump(2) << "\n";
    std::printf("changed appearance (variant %d, light %.2f), %s: %d of %zu frames localized by the route taught once, "
                "%d by the route that learned from one run (%d experiences added; %d frames by them)\n",
                static_cast<int>(args.integer("variant")), gain, args.text("mode").c_str(), once.localized(),
                test_path.size(), after.localized(), *added, by_experience);
    if (args.integer("plots") != 0 && eval::drawPlots(json_path, "evaluate_learning") != 0) return 1;
  } catch (const std::exception& e) {
    std::cerr << "evaluate_learning: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
