// evaluate_sequence: teach and repeat offline over recorded data, scored against its ground truth
// (docs/evaluation.md, "Recorded sequences"). The same TeachSession and RepeatPipeline the nodes
// run (sequence_evaluation.h).
//
//   evaluate_sequence (--kitti DIR | --strecha DIR | --bag BAG [--repeat-bag BAG]) --out DIR [options]
//
// Sources: the KITTI odometry layout; a Strecha set of any number of views; a rosbag (images +
// camera_info, odometry, the tf of the camera mount, optionally a ground-truth odometry topic),
// teach and repeat from two bags or two time ranges of one (--teach-time / --repeat-time).
// Which frames are taught: --keyframes policy (the teach node's distance/angle policy over the
// teach frames), stride (every --stride-th), list (--teach-frames). With one recording, the
// frames not taught are repeated (--repeat-frames narrows them). Writes DIR/sequence.json and,
// through plot_evaluation, DIR/sequence_top.png, DIR/sequence_error.png, DIR/sequence_nees.png.
// Exit 2 on bad input (with a message naming it), 0 otherwise.
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <sstream>

#include "homography_teach_repeat/common/command_line.h"
#include "homography_teach_repeat/common/process_memory.h"
#include "homography_teach_repeat/eval/plots.h"
#include "homography_teach_repeat/eval/recorded_sequence.h"
#include "homography_teach_repeat/eval/sequence_evaluation.h"
#ifdef HTR_WITH_ROSBAG
#include "homography_teach_repeat/eval/bag_sequence.h"
#endif

using namespace homography_teach_repeat;

namespace {

// "A:B" -> [A, B] (either side may be empty: open).
std::pair<double, double> rangeOf(const cli::Arguments& args, const std::string& key) {
  const std::string& text = args.text(key);
  if (text.empty()) return {-std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  const auto colon = text.find(':');
  if (colon == std::string::npos) args.fail("--" + key + " needs FROM:TO, got '" + text + "'");
  auto side = [&](const std::string& part, double fallback) {
    if (part.empty()) return fallback;
    try {
      std::size_t used = 0;
      const double value = std::stod(part, &used);
      if (used != part.size()) throw std::invalid_argument(part);
      return value;
    } catch (const std::exception&) {
      args.fail("--" + key + ": '" + part + "' is not a number");
    }
  };
  return {side(text.substr(0, colon), -std::numeric_limits<double>::infinity()),
          side(text.substr(colon + 1), std::numeric_limits<double>::infinity())};
}

std::vector<int> framesIn(const eval::RecordedSequence& sequence, std::pair<double, double> range, bool by_index) {
  std::vector<int> frames;
  for (int i = 0; i < static_cast<int>(sequence.stamps.size()); ++i) {
    const double key = by_index ? i : sequence.stamps[static_cast<std::size_t>(i)] - sequence.stamps.front();
    if (key >= range.first && key <= range.second) frames.push_back(i);
  }
  return frames;
}


// A JSON number with `digits` decimals, "null" for null.
std::string formatted(const nlohmann::json& value, int digits) {
  if (!value.is_number()) return "null";
  std::ostringstream text;
  text << std::fixed << std::setprecision(digits) << value.get<double>();
  return text.str();
}

// A JSON fraction as a percentage with one decimal ("no NEES" for null).
std::string percent(const nlohmann::json& fraction) {
  return fraction.is_number() ? formatted(100.0 * fraction.get<double>(), 1) + " %" : "no NEES";
}

// The program's arguments with the repeat's own defaults (repeat_node's and config/repeat_node.yaml's):
// a flag only changes them.
cli::Arguments sequenceArguments() {
  const RepeatOptions repeat_defaults;
  return cli::Arguments(
      "evaluate_sequence",
      {{"kitti", ""}, {"strecha", ""}, {"bag", ""}, {"repeat-bag", ""}, {"out", ""},
       {"mode", toString(kDefaultRepeatMode)}, {"level", "gravity"}, {"scale", "1.0"},
       {"keyframes", "policy"}, {"keyframe-distance", "2.0"}, {"keyframe-angle", "0.35"}, {"stride", "4"},
       {"teach-frames", ""}, {"repeat-frames", ""}, {"teach-range", ""}, {"repeat-range", ""},
       {"teach-time", ""}, {"repeat-time", ""},
       {"feature", "sift"}, {"max-features", std::to_string(repeat_defaults.max_features)}, {"first-plane-distance", "0"},
       {"teach-odometry", "truth"}, {"scale-error", "0.02"}, {"heading-bias", "0.02"},
       {"distance-noise", "0.01"}, {"heading-noise", "0.002"}, {"seed", "1"},
       {"image-topic", "/camera/image_raw"}, {"camera-info-topic", ""}, {"odom-topic", "/odom"},
       {"truth-topic", ""}, {"base-frame", "base_link"}, {"plots", "1"},
       {"pixel-sigma", std::to_string(repeat_defaults.pose.pixel_sigma_px)},
       {"match-residual-gain", std::to_string(repeat_defaults.match_residual_gain)},
       {"pixel-noise-per-keyframe", repeat_defaults.pixel_noise_per_keyframe ? "1" : "0"},
       {"pixel-noise-per-fix", repeat_defaults.pixel_noise_per_fix ? "1" : "0"},
       {"plane-normal-sigma", std::to_string(repeat_defaults.pose.plane_normal_sigma_rad)},
       {"plane-distance-sigma", std::to_string(repeat_defaults.pose.plane_distance_sigma)},
       {"tilt-sigma", std::to_string(repeat_defaults.pose.tilt_sigma_rad)},
       {"measured-tilt-gain", std::to_string(repeat_defaults.measured_tilt_gain)},
       {"heading-sigma", std::to_string(repeat_defaults.pose.heading_sigma_rad)},
       {"common-shift-sigma", std::to_string(repeat_defaults.pose.common_shift_sigma_px)}, {"teach-tilt", "auto"},
       {"max-plane-residual", std::to_string(repeat_defaults.max_plane_residual_px)},
       {"plane-sigma-from-neighbours", std::to_string(repeat_defaults.plane_sigma_from_neighbours ? 1 : 0)},
       {"max-tracked-frames", std::to_string(repeat_defaults.max_tracked_frames)},
       {"background-detection", std::to_string(repeat_defaults.background_detection ? 1 : 0)},
       {"mu-line-landmarks", std::to_string(repeat_defaults.mu_line_landmarks ? 1 : 0)},
       {"line-min-length", std::to_string(repeat_defaults.lines.min_length_px)}, {"shift-heading", "1"},
       {"hybrid-fuse-both", RepeatPipelineOptions().hybrid_fuse_both ? "1" : "0"}},
      "(--kitti DIR | --strecha DIR | --bag BAG [--repeat-bag BAG]) --out DIR\n"
      "  [--mode hybrid|fast_hd|mu|classic] [--level gravity|mount|none] [--scale S]\n"
      "  [--keyframes policy|stride|list] [--keyframe-distance M] [--keyframe-angle RAD] [--stride N]\n"
      "  [--teach-frames I,J,..] [--repeat-frames I,J,..] [--teach-range A:B] [--repeat-range A:B] (indices)\n"
      "  [--teach-time A:B] [--repeat-time A:B] (bag: seconds from its first image)\n"
      "  [--feature sift|orb|akaze|surf] [--max-features N] [--first-plane-distance M (0: planes from odometry)]\n"
      "  [--teach-odometry truth|recorded] [--scale-error E] [--heading-bias RAD/M] [--distance-noise M/sqrt(M)]\n"
      "  [--heading-noise RAD/sqrt(M)] [--seed S] (odometry synthesized where the data has none)\n"
      "  [--image-topic T] [--camera-info-topic T] [--odom-topic T] [--truth-topic T] [--base-frame F] (bag)\n"
      "  [--match-residual-gain G] (the covariance's pixel sigma: G x the teach run's match residual; 0: --pixel-sigma)\n"
      "  [--pixel-noise-per-keyframe 0|1] (each keyframe's pixel sigma scaled by its own pairs' residual)\n"
      "  [--pixel-noise-per-fix 0|1] (each fix's pixel sigma from its own inliers' residual)\n"
      "  [--pixel-sigma PX] [--plane-normal-sigma RAD] [--plane-distance-sigma FRACTION] [--plane-sigma-from-neighbours 0|1] (repeat covariance)\n"
      "  [--max-tracked-frames N] (frames followed by optical flow between detections; 0 for sparse views such as Strecha)\n"
      "  [--background-detection 0|1] (the features of a tracked frame detected on a worker thread meanwhile)\n"
      "  [--measured-tilt-gain G] (the tilt nuisance's prior sigma: G x the teach run's measured tilt; 0: --tilt-sigma)\n"
      "  [--tilt-sigma RAD] (the current camera's tilt as a nuisance in the refinement, e.g. with --level mount)\n"
      "  [--max-plane-residual PX] (RMS of the matches about the keyframe plane's homography above which a keyframe is refused)\n"
      "  [--teach-tilt auto|1|0] (each keyframe pair's relative pitch and roll estimated with its plane; auto: where\n"
      "   the pairs' measured relative tilt exceeds 0.003 rad, teach_node's estimate_keyframe_tilt)\n"
      "  [--heading-sigma RAD] [--common-shift-sigma PX] (a heading error many matches do not average away, added to the covariance)\n"
      "  [--mu-line-landmarks 0|1] (mu: each keyframe line triangulated with its own depth, a fix from every line)\n"
      "  [--line-min-length PX] (shortest vertical line kept, teach and repeat; 0: 5.2 % of the image height)\n"
      "  [--shift-heading 0|1] (hybrid: the seasonal heading fix where no other fix, RepeatPipelineOptions)\n"
      "  [--hybrid-fuse-both 0|1] (hybrid: the mu fix also beside an accepted Fast-HD pose)\n"
      "  [--plots 0|1]");
}

}  // namespace

int main(int argc, char** argv) {
  keepFreedMemoryForReuse();  // as repeat_node: the frame times are the node's
  cli::Arguments args = sequenceArguments();
  args.parse(argc, argv);
  const std::string out = args.text("out");
  if (out.empty()) args.fail("--out DIR is required");
  const int sources = !args.text("kitti").empty() + !args.text("strecha").empty() + !args.text("bag").empty();
  if (sources != 1) args.fail("exactly one of --kitti, --strecha, --bag is required");
  if (!args.text("repeat-bag").empty() && args.text("bag").empty()) args.fail("--repeat-bag needs --bag");

  eval::SequenceEvaluationOptions options;
  try {
    options.repeat.localization.mode = repeatModeFromString(args.text("mode"));
    options.level = eval::levelSourceFromString(args.text("level"));
    options.teach.features.type = featureTypeFromString(args.text("feature"));
  } catch (const std::invalid_argument& e) {
    args.fail(e.what());
  }
  const std::string teach_tilt = args.text("teach-tilt");
  if (teach_tilt != "auto" && teach_tilt != "0" && teach_tilt != "1") args.fail("--teach-tilt must be auto, 0 or 1");
  options.teach.keyframe_tilt = keyframeTiltFromString(teach_tilt == "auto" ? "auto" : teach_tilt == "1" ? "true" : "false");
  options.image_scale = args.number("scale");
  options.teach.features.max_features = args.integer("max-features");
  options.repeat.localization.max_features = args.integer("max-features");
  options.teach.first_plane_distance = args.number("first-plane-distance");
  options.teach.planes_from_odometry = !(options.teach.first_plane_distance > 0.0);
  options.repeat.localization.max_plane_residual_px = args.number("max-plane-residual");
  options.teach.keyframes.distance = args.number("keyframe-distance");
  options.teach.keyframes.angle = args.number("keyframe-angle");
  options.repeat.localization.pose.pixel_sigma_px = args.number("pixel-sigma");
  options.repeat.localization.match_residual_gain = args.number("match-residual-gain");
  options.repeat.localization.pixel_noise_per_keyframe = args.integer("pixel-noise-per-keyframe") != 0;
  options.repeat.localization.pixel_noise_per_fix = args.integer("pixel-noise-per-fix") != 0;
  options.repeat.localization.pose.plane_normal_sigma_rad = args.number("plane-normal-sigma");
  options.repeat.localization.pose.plane_distance_sigma = args.number("plane-distance-sigma");
  options.repeat.localization.pose.tilt_sigma_rad = args.number("tilt-sigma");
  options.repeat.localization.measured_tilt_gain = args.number("measured-tilt-gain");
  options.repeat.localization.pose.heading_sigma_rad = args.number("heading-sigma");
  options.repeat.localization.pose.common_shift_sigma_px = args.number("common-shift-sigma");
  options.repeat.localization.plane_sigma_from_neighbours = args.integer("plane-sigma-from-neighbours") != 0;
  options.repeat.localization.max_tracked_frames = args.integer("max-tracked-frames");
  options.repeat.localization.background_detection = args.integer("background-detection") != 0;
  options.repeat.shift_heading = args.integer("shift-heading") != 0;
  options.repeat.hybrid_fuse_both = args.integer("hybrid-fuse-both") != 0;
  options.repeat.localization.mu_line_landmarks = args.integer("mu-line-landmarks") != 0;
  options.teach.lines.min_length_px = args.integer("line-min-length");
  options.repeat.localization.lines.min_length_px = args.integer("line-min-length");
  options.teach.route_directory = out + "/route";
  options.teach.overwrite = true;
  const std::string teach_odometry = args.text("teach-odometry");
  if (teach_odometry != "truth" && teach_odometry != "recorded") {
    args.fail("--teach-odometry must be truth or recorded, got '" + teach_odometry + "'");
  }
  options.teach_on_ground_truth = teach_odometry == "truth";
  options.synthesized_odometry.scale_error = args.number("scale-error");
  options.synthesized_odometry.heading_bias_per_metre = args.number("heading-bias");
  options.synthesized_odometry.distance_noise = args.number("distance-noise");
  options.synthesized_odometry.heading_noise = args.number("heading-noise");
  options.seed = static_cast<std::uint64_t>(args.integer("seed"));
  try {
    options.validate();
  } catch (const std::invalid_argument& e) {
    args.fail(e.what());
  }

  // The recordings.
  std::optional<eval::RecordedSequence> teach, repeat;
  auto take = [&](Expected<eval::RecordedSequence> read) {
    if (!read) args.fail(read.status().message());
    return std::move(*read);
  };
  if (!args.text("kitti").empty()) teach = take(eval::readKittiSequence(args.text("kitti")));
  if (!args.text("strecha").empty()) teach = take(eval::readStrechaSequence(args.text("strecha")));
  if (!args.text("bag").empty()) {
#ifdef HTR_WITH_ROSBAG
    eval::BagTopics topics;
    topics.image = args.text("image-topic");
    topics.camera_info = args.text("camera-info-topic");
    topics.odometry = args.text("odom-topic");
    topics.ground_truth = args.text("truth-topic");
    topics.base_frame = args.text("base-frame");
    teach = take(eval::readBagSequence(args.text("bag"), topics));
    if (!args.text("repeat-bag").empty()) repeat = take(eval::readBagSequence(args.text("repeat-bag"), topics));
#else
    args.fail("this build has no rosbag support");
#endif
  }
  const eval::RecordedSequence& teach_sequence = *teach;
  const eval::RecordedSequence& repeat_sequence = repeat ? *repeat : *teach;
  const bool one_recording = !repeat;
  const bool by_time = !args.text("bag").empty();

  // Frames.
  eval::SequenceSelection selection;
  const int teach_size = static_cast<int>(teach_sequence.stamps.size());
  std::vector<int> teach_candidates = framesIn(teach_sequence, rangeOf(args, by_time ? "teach-time" : "teach-range"), !by_time);
  const std::string keyframes = args.text("keyframes");
  if (keyframes == "policy") {
    selection.teach_frames = teach_candidates;
  } else if (keyframes == "stride") {
    const int stride = args.integer("stride");
    if (stride < 1) args.fail("--stride must be >= 1");
    for (std::size_t i = 0; i < teach_candidates.size(); i += static_cast<std::size_t>(stride)) {
      selection.teach_frames.push_back(teach_candidates[i]);
    }
    options.teach_every_offered_frame = true;
  } else if (keyframes == "list") {
    selection.teach_frames = args.indices("teach-frames", teach_size, {});
    if (selection.teach_frames.empty()) args.fail("--keyframes list needs --teach-frames");
    options.teach_every_offered_frame = true;
  } else {
    args.fail("--keyframes must be policy, stride or list, got '" + keyframes + "'");
  }
  // With one recording, the frames taught are not repeated (with the policy, the teach session
  // decides which they are).
  const int repeat_size = static_cast<int>(repeat_sequence.stamps.size());
  selection.repeat_frames =
      args.text("repeat-frames").empty()
          ? framesIn(repeat_sequence, rangeOf(args, by_time ? "repeat-time" : "repeat-range"), !by_time)
          : args.indices("repeat-frames", repeat_size, {});
  selection.skip_taught_frames = one_recording;

  std::error_code created;
  std::filesystem::create_directories(out, created);
  if (created) args.fail("cannot create '" + out + "': " + created.message());
  auto evaluation = eval::evaluateSequence(teach_sequence, repeat_sequence, selection, options);
  if (!evaluation) args.fail(evaluation.status().toString());
  nlohmann::json document = eval::toJson(*evaluation);
  document["source"] = {{"teach", teach_sequence.description}, {"repeat", repeat_sequence.description},
                        {"camera_mount", teach_sequence.mount_source}};
  const RepeatOptions used = withMeasuredNoise(options.repeat.localization, evaluation->route);
  document["setup"] = {{"mode", args.text("mode")}, {"level", args.text("level")}, {"scale", options.image_scale},
                       {"keyframes", keyframes}, {"keyframe_distance_m", options.teach.keyframes.distance},
                       {"pixel_sigma_px", used.pose.pixel_sigma_px},
                       {"pixel_sigma_fallback_px", options.repeat.localization.pose.pixel_sigma_px},
                       {"match_residual_gain", options.repeat.localization.match_residual_gain},
                       {"pixel_noise_per_keyframe", options.repeat.localization.pixel_noise_per_keyframe},
                       {"pixel_noise_per_fix", options.repeat.localization.pixel_noise_per_fix},
                       {"match_residual_px", routeMatchResidual(evaluation->route).value_or(0.0)},
                       {"plane_normal_sigma_rad", options.repeat.localization.pose.plane_normal_sigma_rad},
                       {"plane_distance_sigma", options.repeat.localization.pose.plane_distance_sigma},
                       {"tilt_sigma", used.pose.tilt_sigma_rad},
                       {"tilt_sigma_fallback", options.repeat.localization.pose.tilt_sigma_rad},
                       {"measured_tilt_gain", options.repeat.localization.measured_tilt_gain},
                       {"measured_tilt_rad", routeTiltSigma(evaluation->route).value_or(0.0)},
                       {"heading_sigma", options.repeat.localization.pose.heading_sigma_rad},
                       {"common_shift_sigma_px", options.repeat.localization.pose.common_shift_sigma_px},
                       {"mu_line_landmarks", options.repeat.localization.mu_line_landmarks},
                       {"line_min_length_px", options.teach.lines.min_length_px},
                       {"teach_tilt", toString(options.teach.keyframe_tilt)},
                       {"teach_tilt_estimated", evaluation->planes.keyframe_tilt_estimated},
                       {"max_plane_residual_px", options.repeat.localization.max_plane_residual_px},
                       {"plane_sigma_from_neighbours", options.repeat.localization.plane_sigma_from_neighbours},
                       {"max_tracked_frames", options.repeat.localization.max_tracked_frames},
                       {"shift_heading", options.repeat.shift_heading},
                       {"hybrid_fuse_both", options.repeat.hybrid_fuse_both},
                       {"feature", args.text("feature")}, {"max_features", options.teach.features.max_features},
                       {"planes", options.teach.planes_from_odometry ? "from odometry" : "first plane distance"},
                       {"command", [&] {
                          std::string command;
                          for (int i = 0; i < argc; ++i) command += (i ? " " : "") + std::string(argv[i]);
                          return command;
                        }()}};
  const std::string json_path = out + "/sequence.json";
  {
    std::ofstream file(json_path);
    file << document.dump(1) << "\n";
    if (!file) args.fail("cannot write '" + json_path + "'");
  }
  const auto& s = document["summary"];
  std::cout << "evaluate_sequence: " << s["localized"] << " of " << s["frames"] << " frames localized; "
            << evaluation->odometry_note << "\n";
  if (options.teach.planes_from_odometry) {
    std::cout << "  teach: " << describeKeyframeTilt(evaluation->planes, options.teach.keyframe_tilt) << "\n";
  }
  std::string segment_nees, segment_beyond;
  for (const auto& segment : document["segments"]) {
    std::cout << "  " << segment["name"].get<std::string>() << " (frames " << segment["first_frame"] << "-"
              << segment["last_frame"] << "): " << segment["localized"] << "/" << segment["frames"]
              << " localized, median " << formatted(segment["position_error_median_m"], 3) << " m, p95 "
              << formatted(segment["position_error_p95_m"], 3) << " m, heading median "
              << formatted(segment["heading_error_median_deg"], 3) << " deg, NEES mean "
              << formatted(segment["nees_mean"], 1) << " (" << percent(segment["nees_fraction_beyond_95"])
              << " beyond the 95 % bound)\n";
    segment_nees += (segment_nees.empty() ? "" : ",") + formatted(segment["nees_mean"], 1);
    segment_beyond += (segment_beyond.empty() ? "" : ",") + formatted(segment["nees_fraction_beyond_95"], 2);
  }
  for (const auto& u : evaluation->unreadable_frames) {
    std::cerr << "evaluate_sequence: " << u.phase << " frame " << u.frame << " skipped: " << u.reason << "\n";
  }
  if (!evaluation->unreadable_frames.empty()) {
    std::cout << "  skipped " << evaluation->unreadable_frames.size() << " frame(s) whose image could not be read\n";
  }
  std::cout << "  failures: " << s["failures"].dump() << "; time per frame median "
            << formatted(s["time_per_frame_median_ms"], 1) << " ms\nwrote " << json_path << "\n";
  // One line per run for a log to be searched (grep '^evaluate_sequence summary:'); "null": none.
  std::cout << "evaluate_sequence summary: mode=" << args.text("mode") << " localized=" << s["localized"] << "/"
            << s["frames"] << " position_median_m=" << formatted(s["position_error_median_m"], 4)
            << " heading_median_deg=" << formatted(s["heading_error_median_deg"], 3)
            << " nees_mean=" << formatted(s["nees_mean"], 2)
            << " nees_beyond_95=" << formatted(s["nees_fraction_beyond_95"], 3)
            << " segment_nees_mean=" << segment_nees << " segment_nees_beyond_95=" << segment_beyond
            << " frame_ms_median=" << formatted(s["time_per_frame_median_ms"], 1) << "\n";
  if (args.integer("plots") != 0) eval::drawPlots(json_path, "evaluate_sequence");
  return 0;
}
