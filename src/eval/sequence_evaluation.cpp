#include "homography_teach_repeat/eval/sequence_evaluation.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <set>
#include <stdexcept>

#include "homography_teach_repeat/eval/measurement.h"
#include "homography_teach_repeat/eval/pose_consistency.h"
#include "homography_teach_repeat/geometry/odometry_buffer.h"

namespace homography_teach_repeat {
namespace eval {
namespace {

Status invalid(const std::string& message) { return Status(StatusCode::kInvalidInput, message); }

// Ground truth / odometry by stamp over a whole recording (the repeat pipeline's own buffer, with
// room for all of it).
Expected<OdometryBuffer> bufferOf(const std::vector<StampedPose2D>& samples, const std::string& what) {
  OdometryBuffer buffer(std::numeric_limits<double>::max(), 1.0);
  for (const auto& s : samples) {
    const Status added = buffer.add(s.stamp, s.pose);
    if (!added.isOk()) return invalid(what + ": " + added.message());
  }
  return buffer;
}

std::vector<StampedPose2D> synthesize(const std::vector<StampedPose2D>& truth, const OdometryErrorModel& model,
                                      std::uint64_t seed) {
  SynthesizedOdometry odometry(model, seed);
  std::vector<StampedPose2D> result;
  result.reserve(truth.size());
  for (const auto& t : truth) result.push_back({t.stamp, odometry.add(t.pose)});
  return result;
}

// "turn N" / "straight N" per frame from the ground truth's turn rate (SequenceEvaluationOptions::
// turn_rate), short runs merged.
std::vector<std::string> segmentsOf(const std::vector<Pose2D>& path, const std::vector<double>& distance,
                                    double turn_rate) {
  const std::size_t n = path.size();
  std::vector<bool> turning(n, false);
  for (std::size_t i = 0; i < n; ++i) {
    std::size_t a = i, b = i;
    while (a > 0 && distance[i] - distance[a] < 3.0) --a;
    while (b + 1 < n && distance[b] - distance[i] < 3.0) ++b;
    const double length = distance[b] - distance[a];
    turning[i] = length > 0.5 && std::abs(wrapToPi(path[b].yaw - path[a].yaw)) / length > turn_rate;
  }
  // Runs, then merge those shorter than 5 m into the previous run.
  struct Run { std::size_t first, last; bool turn; };
  std::vector<Run> runs;
  for (std::size_t i = 0; i < n; ++i) {
    if (runs.empty() || runs.back().turn != turning[i]) runs.push_back({i, i, turning[i]});
    runs.back().last = i;
  }
  std::vector<Run> merged;
  for (const Run& run : runs) {
    const bool short_run = distance[run.last] - distance[run.first] < 5.0;
    if (!merged.empty() && (short_run || merged.back().turn == run.turn)) {
      merged.back().last = run.last;
    } else {
      merged.push_back(run);
    }
  }
  if (merged.size() > 1 && distance[merged.front().last] - distance[merged.front().first] < 5.0) {
    merged[1].first = 0;
    merged.erase(merged.begin());
  }
  std::vector<std::string> names(n);
  int turns = 0, straights = 0;
  for (const Run& run : merged) {
    const std::string name = run.turn ? "turn " + std::to_string(++turns) : "straight " + std::to_string(++straights);
    for (std::size_t i = run.first; i <= run.last; ++i) names[i] = name;
  }
  return names;
}

nlohmann::json summaryOf(const std::vector<const FrameOutcome*>& frames) {
  std::vector<double> position, heading, nees, times;
  std::map<std::string, int> failures;
  int localized = 0, beyond = 0;
  for (const FrameOutcome* f : frames) {
    times.push_back(f->time_ms);
    if (f->pose) ++localized;
    if (f->status != "OK") {
      // The reason without the numbers that make every message unique.
      const std::string reason = f->status.substr(0, f->status.find(':', f->status.find(':') + 1));
      ++failures[reason];
    }
    if (f->position_error) position.push_back(*f->position_error);
    if (f->heading_error) heading.push_back(*f->heading_error * 180.0 / M_PI);
    if (f->nees) {
      nees.push_back(*f->nees);
      if (*f->nees > kChiSquare3Dof95) ++beyond;
    }
  }
  double nees_mean = std::nan("");
  if (!nees.empty()) {
    nees_mean = 0.0;
    for (const double v : nees) nees_mean += v;
    nees_mean /= static_cast<double>(nees.size());
  }
  auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  return {{"frames", frames.size()},
          {"localized", localized},
          {"fraction_localized", frames.empty() ? 0.0 : static_cast<double>(localized) / static_cast<double>(frames.size())},
          {"position_error_median_m", number(percentile(position, 0.5))},
          {"position_error_p95_m", number(percentile(position, 0.95))},
          {"heading_error_median_deg", number(percentile(heading, 0.5))},
          {"heading_error_p95_deg", number(percentile(heading, 0.95))},
          {"nees_mean", number(nees_mean)},
          {"nees_median", number(percentile(nees, 0.5))},
          {"nees_fraction_beyond_95", nees.empty() ? nlohmann::json(nullptr)
                                                   : nlohmann::json(static_cast<double>(beyond) / static_cast<double>(nees.size()))},
          {"failures", failures},
          {"time_per_frame_median_ms", number(percentile(times, 0.5))},
          {"time_per_frame_mean_ms",
           number(times.empty() ? std::nan("")
                                : std::accumulate(times.begin(), times.end(), 0.0) / static_cast<double>(times.size()))}};
}

}  // namespace

LevelSource levelSourceFromString(const std::string& name) {
  if (name == "gravity") return LevelSource::kGravity;
  if (name == "mount") return LevelSource::kMount;
  if (name == "none") return LevelSource::kNone;
  throw std::invalid_argument("level '" + name + "' is not one of gravity, mount, none");
}

std::string toString(LevelSource source) {
  switch (source) {
    case LevelSource::kGravity: return "gravity";
    case LevelSource::kMount: return "mount";
    case LevelSource::kNone: return "none";
  }
  return "?";
}

void SequenceEvaluationOptions::validate() const {
  teach.validate();
  repeat.validate();
  synthesized_odometry.validate();
  if (!(image_scale > 0.0 && image_scale <= 1.0)) throw std::invalid_argument("image_scale must be in (0, 1]");
  if (!std::isfinite(turn_rate) || !(turn_rate > 0.0)) throw std::invalid_argument("turn_rate must be > 0");
}

Expected<PreparedImage> prepareImage(const SequenceImage& frame, const std::optional<Eigen::Matrix3d>& camera_to_level,
                                     double scale) {
  if (frame.image.empty()) return invalid("empty image");
  try {
    const PinholeCamera check(frame.camera);
  } catch (const std::invalid_argument& e) {
    return invalid(std::string("camera: ") + e.what());
  }
  PreparedImage out;
  out.camera = frame.camera;
  cv::Mat grey;
  if (frame.image.channels() == 3) {
    cv::cvtColor(frame.image, grey, cv::COLOR_BGR2GRAY);
  } else if (frame.image.channels() == 1 && frame.image.depth() == CV_8U) {
    grey = frame.image;
  } else {
    return invalid("image must be 8-bit grey or BGR");
  }
  const CameraCalibration& c = frame.camera;
  const cv::Matx33d K(c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
  const bool rotate = camera_to_level && !camera_to_level->isIdentity(1e-12);
  if (rotate) {
    cv::Matx33d R;
    for (int r = 0; r < 3; ++r) for (int k = 0; k < 3; ++k) R(r, k) = (*camera_to_level)(r, k);
    cv::Mat map_x, map_y;
    // The level camera keeps K; OpenCV's R maps the original camera's rays into the new one.
    const bool distorted = c.distortion_model != "none" && !c.distortion.empty();
    cv::initUndistortRectifyMap(K, distorted ? cv::Mat(c.distortion) : cv::Mat(), R, K, grey.size(), CV_32FC1, map_x,
                                map_y);
    cv::Mat level;
    cv::remap(grey, level, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    grey = level;
    out.camera.distortion_model = "none";
    out.camera.distortion.clear();
  }
  if (scale < 1.0) {
    const int width = static_cast<int>(std::lround(c.width * scale));
    const int height = static_cast<int>(std::lround(c.height * scale));
    cv::resize(grey, out.image, cv::Size(width, height), 0, 0, cv::INTER_AREA);
    out.camera.width = width;
    out.camera.height = height;
    out.camera.fx = c.fx * scale;
    out.camera.fy = c.fy * scale;
    out.camera.cx = (c.cx + 0.5) * scale - 0.5;  // pixel centres preserved
    out.camera.cy = (c.cy + 0.5) * scale - 0.5;
  } else {
    out.image = grey;  // shares the loaded frame's buffer: nothing writes to it
  }
  return out;
}

Expected<SequenceEvaluation> evaluateSequence(const RecordedSequence& teach, const RecordedSequence& repeat,
                                              const SequenceSelection& selection,
                                              const SequenceEvaluationOptions& options_in) {
  SequenceEvaluationOptions options = options_in;
  try {
    options.validate();
  } catch (const std::invalid_argument& e) {
    return invalid(e.what());
  }
  if (selection.teach_frames.size() < 2) return invalid("at least 2 teach frames are needed");
  if (selection.repeat_frames.empty()) return invalid("no repeat frame");
  for (const int i : selection.teach_frames) {
    if (i < 0 || i >= static_cast<int>(teach.stamps.size())) return invalid("teach frame " + std::to_string(i) + " is outside the sequence");
  }
  for (const int i : selection.repeat_frames) {
    if (i < 0 || i >= static_cast<int>(repeat.stamps.size())) return invalid("repeat frame " + std::to_string(i) + " is outside the sequence");
  }
  if (std::adjacent_find(selection.repeat_frames.begin(), selection.repeat_frames.end(),
                         [&](int a, int b) { return !(repeat.stamps.at(static_cast<std::size_t>(a)) < repeat.stamps.at(static_cast<std::size_t>(b))); }) !=
      selection.repeat_frames.end()) {
    return invalid("repeat frames must be in increasing time order");
  }
  if (repeat.ground_truth.empty()) return invalid("the repeat sequence has no ground truth to score against");
  if (teach.ground_truth.empty()) return invalid("the teach sequence has no ground truth (keyframes cannot be scored)");
  auto teach_truth = bufferOf(teach.ground_truth, "teach ground truth");
  if (!teach_truth) return teach_truth.status();
  auto repeat_truth = bufferOf(repeat.ground_truth, "repeat ground truth");
  if (!repeat_truth) return repeat_truth.status();

  SequenceEvaluation evaluation;
  auto odometryOf = [&](const RecordedSequence& sequence, std::uint64_t seed, std::string* note) {
    if (!sequence.odometry.empty()) {
      *note = "recorded wheel odometry";
      return sequence.odometry;
    }
    const auto& m = options.synthesized_odometry;
    *note = "synthesized from the ground truth (scale error " + std::to_string(m.scale_error) + ", heading bias " +
            std::to_string(m.heading_bias_per_metre) + " rad/m, noise " + std::to_string(m.distance_noise) +
            " m/sqrt(m) and " + std::to_string(m.heading_noise) + " rad/sqrt(m), seed " + std::to_string(seed) + ")";
    return synthesize(sequence.ground_truth, m, seed);
  };
  std::string teach_note, repeat_note;
  std::vector<StampedPose2D> teach_odometry;
  if (options.teach_on_ground_truth) {
    teach_odometry = teach.ground_truth;
    teach_note = "the ground truth";
  } else {
    teach_odometry = odometryOf(teach, options.seed + 1000, &teach_note);
  }
  const std::vector<StampedPose2D> repeat_odometry = odometryOf(repeat, options.seed, &repeat_note);
  evaluation.odometry_note = "teach odometry: " + teach_note + "; repeat odometry: " + repeat_note;
  auto teach_odometry_buffer = bufferOf(teach_odometry, "teach odometry");
  if (!teach_odometry_buffer) return teach_odometry_buffer.status();

  auto levelOf = [&](const RecordedSequence& sequence, const SequenceImage& image) -> std::optional<Eigen::Matrix3d> {
    switch (options.level) {
      case LevelSource::kGravity: return image.camera_to_level;
      case LevelSource::kMount: return sequence.mount_camera_to_level;
      case LevelSource::kNone: return std::nullopt;
    }
    return std::nullopt;
  };
  // A frame whose image cannot be read (a corrupt or truncated file or message) is skipped and
  // listed; anything else that stops a frame stops the evaluation.
  auto load = [&](const RecordedSequence& sequence, int index, const char* phase, bool* unreadable) -> Expected<PreparedImage> {
    *unreadable = false;
    auto image = sequence.load_image(index);
    if (!image) {
      *unreadable = true;
      evaluation.unreadable_frames.push_back({phase, index, image.status().message()});
      return image.status();
    }
    if (options.level == LevelSource::kGravity && !image->camera_to_level) {
      return invalid("level 'gravity' needs each frame's tilt, which this sequence does not have (use 'mount')");
    }
    return prepareImage(*image, levelOf(sequence, *image), options.image_scale);
  };

  // Teach.
  std::optional<TeachSession> session;
  if (options.teach_every_offered_frame) {
    options.teach.keyframes.distance = std::numeric_limits<double>::min();
    options.teach.keyframes.angle = std::numeric_limits<double>::min();
  }
  options.teach.plane_measurement = options.repeat.localization;  // the planes' uncertainty as this repeat would measure it
  for (const int index : selection.teach_frames) {
    bool unreadable = false;
    auto prepared = load(teach, index, "teach", &unreadable);
    if (!prepared && unreadable) continue;
    if (!prepared) return invalid("teach frame " + std::to_string(index) + ": " + prepared.status().message());
    if (!session) {
      auto started = TeachSession::start(options.teach, prepared->camera, teach.camera_mount);
      if (!started) return started.status();
      session.emplace(std::move(*started));
    }
    const double stamp = teach.stamps[static_cast<std::size_t>(index)];
    const auto odometry = teach_odometry_buffer->poseAt(stamp);
    if (!odometry) return invalid("teach frame " + std::to_string(index) + ": no odometry: " + odometry.status().message());
    const auto stored = session->offer(prepared->image, *odometry, stamp);
    if (!stored) return invalid("teach frame " + std::to_string(index) + ": " + stored.status().message());
    if (*stored) evaluation.keyframe_frames.push_back(index);
  }
  auto planes = session->finish();
  if (!planes) return planes.status();
  evaluation.planes = *planes;
  evaluation.route = session->route();
  const Route& route = evaluation.route;
  std::vector<Pose2D> keyframe_truth;
  for (const auto& keyframe : route.keyframes) {
    const auto truth = teach_truth->poseAt(keyframe.stamp);
    if (!truth) return invalid("no ground truth at keyframe " + std::to_string(keyframe.index));
    keyframe_truth.push_back(*truth);
  }

  // Repeat.
  auto pipeline = RepeatPipeline::create(route, options.repeat);
  if (!pipeline) {
    std::string why = pipeline.status().message();
    for (const auto& message : evaluation.planes.messages) why += "; teach: " + message;
    return Status(pipeline.status().code(), why);
  }
  pipeline->warmUp();  // as repeat_node at start-up (frame times)
  std::size_t next_odometry = 0;
  std::vector<Pose2D> truth_path;
  std::vector<double> distance;
  const std::set<int> taught(evaluation.keyframe_frames.begin(), evaluation.keyframe_frames.end());
  for (const int index : selection.repeat_frames) {
    if (selection.skip_taught_frames && taught.count(index) != 0) continue;
    const double stamp = repeat.stamps[static_cast<std::size_t>(index)];
    while (next_odometry < repeat_odometry.size() && repeat_odometry[next_odometry].stamp <= stamp) {
      pipeline->addOdometry(repeat_odometry[next_odometry].stamp, repeat_odometry[next_odometry].pose);
      ++next_odometry;
    }
    FrameOutcome outcome;
    outcome.frame = index;
    outcome.stamp = stamp;
    bool unreadable = false;
    auto prepared = load(repeat, index, "repeat", &unreadable);
    if (!prepared && unreadable) continue;
    if (!prepared) return invalid("repeat frame " + std::to_string(index) + ": " + prepared.status().message());
    Expected<PinholeCamera> camera = Status(StatusCode::kInvalidInput, "camera");
    try {
      camera = PinholeCamera(prepared->camera);
    } catch (const std::invalid_argument& e) {
      camera = invalid(e.what());
    }
    const auto started = std::chrono::steady_clock::now();
    const RepeatFrameResult result = pipeline->processFrame(stamp, prepared->image, camera);
    outcome.time_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count();
    outcome.status = result.status.isOk() ? "OK" : result.status.toString();
    if (result.estimate) {
      outcome.keyframe = result.estimate->keyframe;
      outcome.inliers = result.estimate->inliers;
      outcome.degraded = result.estimate->degraded;
      outcome.tracked = result.estimate->tracked;
    }
    outcome.fixes = result.fixes;
    outcome.pose = result.pose;
    outcome.covariance = result.covariance;

    const auto truth = repeat_truth->poseAt(stamp);
    if (!truth) return invalid("no ground truth at repeat frame " + std::to_string(index));
    if (!truth_path.empty()) {
      const Pose2D& last = truth_path.back();
      distance.push_back(distance.back() + std::hypot(truth->x - last.x, truth->y - last.y));
    } else {
      distance.push_back(0.0);
    }
    truth_path.push_back(*truth);
    // Scoring keyframe: the estimate's, else the nearest by ground truth.
    int k = outcome.keyframe;
    if (k < 0) {
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t j = 0; j < keyframe_truth.size(); ++j) {
        const double d = std::hypot(keyframe_truth[j].x - truth->x, keyframe_truth[j].y - truth->y);
        if (d < best) {
          best = d;
          k = static_cast<int>(j);
        }
      }
    }
    outcome.scoring_keyframe = k;
    const auto ku = static_cast<std::size_t>(k);
    outcome.truth = route.keyframes[ku].pose.compose(keyframe_truth[ku].inverse().compose(*truth));
    if (outcome.pose) {
      outcome.position_error = std::hypot(outcome.pose->x - outcome.truth->x, outcome.pose->y - outcome.truth->y);
      outcome.heading_error = std::abs(wrapToPi(outcome.pose->yaw - outcome.truth->yaw));
      if (outcome.covariance) {
        const auto nees = normalizedEstimationErrorSquared(*outcome.pose, *outcome.covariance, *outcome.truth);
        if (nees) outcome.nees = *nees;
      }
    }
    evaluation.frames.push_back(outcome);
  }
  const auto segments = segmentsOf(truth_path, distance, options.turn_rate);
  for (std::size_t i = 0; i < evaluation.frames.size(); ++i) {
    evaluation.frames[i].segment = segments[i];
    evaluation.frames[i].distance = distance[i];
  }
  return evaluation;
}

nlohmann::json toJson(const SequenceEvaluation& evaluation) {
  std::vector<const FrameOutcome*> all;
  std::map<std::string, std::vector<const FrameOutcome*>> by_segment;
  std::vector<std::string> segment_order;
  for (const auto& f : evaluation.frames) {
    all.push_back(&f);
    if (by_segment.count(f.segment) == 0) segment_order.push_back(f.segment);
    by_segment[f.segment].push_back(&f);
  }
  nlohmann::json segments = nlohmann::json::array();
  for (const auto& name : segment_order) {
    nlohmann::json s = summaryOf(by_segment[name]);
    s["name"] = name;
    s["first_frame"] = by_segment[name].front()->frame;
    s["last_frame"] = by_segment[name].back()->frame;
    segments.push_back(s);
  }
  auto pose = [](const Pose2D& p) { return nlohmann::json{p.x, p.y, p.yaw}; };
  nlohmann::json frames = nlohmann::json::array();
  for (const auto& f : evaluation.frames) {
    nlohmann::json j{{"frame", f.frame},       {"stamp", f.stamp},       {"status", f.status},
                     {"keyframe", f.keyframe}, {"inliers", f.inliers},   {"degraded", f.degraded},
                     {"tracked", f.tracked},   {"fixes", f.fixes},       {"time_ms", f.time_ms},   {"segment", f.segment},
                     {"distance_m", f.distance}, {"truth", pose(*f.truth)}, {"scoring_keyframe", f.scoring_keyframe}};
    j["pose"] = f.pose ? pose(*f.pose) : nlohmann::json(nullptr);
    if (f.covariance) {
      std::vector<double> c(f.covariance->data(), f.covariance->data() + 9);
      j["covariance"] = c;
    } else {
      j["covariance"] = nullptr;
    }
    j["position_error_m"] = f.position_error ? nlohmann::json(*f.position_error) : nlohmann::json(nullptr);
    j["heading_error_deg"] =
        f.heading_error ? nlohmann::json(*f.heading_error * 180.0 / M_PI) : nlohmann::json(nullptr);
    j["nees"] = f.nees ? nlohmann::json(*f.nees) : nlohmann::json(nullptr);
    frames.push_back(j);
  }
  nlohmann::json keyframes = nlohmann::json::array();
  for (std::size_t k = 0; k < evaluation.route.keyframes.size(); ++k) {
    const auto& kf = evaluation.route.keyframes[k];
    nlohmann::json j{{"index", kf.index}, {"frame", evaluation.keyframe_frames[k]}, {"pose", pose(kf.pose)}};
    if (kf.plane) {
      j["plane"] = {{"normal", {kf.plane->normal.x(), kf.plane->normal.y(), kf.plane->normal.z()}},
                    {"distance", kf.plane->distance}};
    } else {
      j["plane"] = nullptr;
    }
    keyframes.push_back(j);
  }
  nlohmann::json unreadable = nlohmann::json::array();
  for (const auto& u : evaluation.unreadable_frames) {
    unreadable.push_back({{"phase", u.phase}, {"frame", u.frame}, {"reason", u.reason}});
  }
  return {{"kind", "sequence_evaluation"},
          {"unreadable_frames", unreadable},
          {"summary", summaryOf(all)},
          {"segments", segments},
          {"odometry", evaluation.odometry_note},
          {"planes", {{"keyframes", evaluation.planes.keyframes},
                      {"with_plane", evaluation.planes.planes},
                      {"messages", evaluation.planes.messages}}},
          {"keyframes", keyframes},
          {"frames", frames}};
}

}  // namespace eval
}  // namespace homography_teach_repeat
