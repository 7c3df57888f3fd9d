// evaluate_demo_run: scores simulated repeat runs against the taught path by ground truth
// (scripts/demo).
//   evaluate_demo_run --world W.yaml --route DIR --bag RUN.bag [--baseline-bag ODOM.bag]
//                     [--laps N] [--mode M] --out DIR
// Writes DIR/metrics.json: {"laps", "mode", "final_pos_err_m", "final_heading_err_deg",
// "max_pos_err_m", "mean_pos_err_m", "final_path_err_m", "odometry_only_final_pos_err_m",
// "odometry_only_final_heading_err_deg", "odometry_only_max_pos_err_m", "samples",
// "controller_state", "finished", "distance_travelled_m", "route_distance_m"}. "finished": the
// controller's last state was "finished" (a robot that never left the start is 0 m from the end
// pose: the errors alone would call that a success); distance_travelled_m: along the ground truth;
// route_distance_m: laps × the taught path; straight_speed_mps: the mean ground-truth speed while
// turning slower than 0.1 rad/s, from the robot's first move to its last (stops on a straight
// count: a robot that crawls or halts there is slow); straight_speed_way_clear_mps: the same without
// the intervals in which the controller reported something in its way; min_wall_clearance_m: the closest the base
// came to a wall (with --clutter 1: or to the world's clutter); min_person_clearance_m: to a
// person's body (the `people` markers in the bag; null without). Exit code 3 when the run did not finish (metrics and
// plot are written all the same). "final": the last ground-truth sample of the run against the pose the run
// must end at (a loop: its first keyframe, where the robot started; an open route: its last);
// max/mean/final_path: distance to the polyline through the taught keyframes. And
// DIR/trajectory.json, what the top view shows (scripts/plot_evaluation draws DIR/trajectory.png):
// {"kind": "demo_trajectory", "mode", "laps", "walls": [[[x, y], [x, y]], ...], "taught_path",
// "repeated", "odometry_only", "published": [[x, y], ...] in metres (ground truth every 0.05 s),
// "published_error_m": [[t, error], ...] of the published poses against the ground truth}.
// "localization": how the repeat_node's published pose (repeat_node/pose) compares with the ground
// truth at the pose's stamp (interpolated), and whether its covariance is honest
// (pose_consistency.h): {"poses", "position_err_rms_m", "heading_err_rms_deg", "position_sigma_rms_m",
// "heading_sigma_rms_deg", "nees_mean", "nees_median", "nees_fraction_above_chi2_95",
// "unscored_poses", "integrity", "by_keyframe", "by_fix_source"}; null when the bag has no pose.
// "by_fix_source": the same scores for the frames whose fix came from features detected in the
// frame ("detected") and from the previous frame's matches followed by optical flow ("tracked":
// the heading correction's `tracked`), {"detected": {"poses", "nees_mean", "nees_median",
// "nees_fraction_above_chi2_95"} or null, "tracked": ...}; null without heading corrections. "by_keyframe": the
// same scores per keyframe the pose was fixed against (repeat_node/heading_correction of the same
// frame: reference_index), [{"keyframe", "poses", "nees_mean", "nees_fraction_above_chi2_95"}], by
// keyframe; null without heading corrections. A covariance whose mean is honest can still claim too
// little at a few keyframes and too much at the rest (docs/evaluation.md, "Simulator: closed-loop
// repeat"): the summary names the keyframes whose poses' NEES mean is above 6 over 10 or more poses.
// "integrity": whether repeat_node's ~integrity flagged (DEGRADED or LOST) the poses more than 0.3 m
// or 5° wrong ("detection") and how many right ones it flagged ("false_alarm"), with the counts; null
// without integrity reports. The route's frame (map) is taken as the world's, as for the path errors:
// the teach phase runs on drift-free odometry.
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <std_msgs/String.h>
#include <visualization_msgs/MarkerArray.h>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "homography_teach_repeat/HeadingCorrectionStamped.h"
#include "homography_teach_repeat/Integrity.h"
#include "homography_teach_repeat/common/command_line.h"
#include "homography_teach_repeat/ros/conversions.h"
#include "homography_teach_repeat/geometry/odometry_buffer.h"
#include "homography_teach_repeat/eval/path_deviation.h"
#include "homography_teach_repeat/sim/planar_world.h"
#include "homography_teach_repeat/eval/pose_consistency.h"
#include "homography_teach_repeat/teach_repeat/route.h"

namespace htr = homography_teach_repeat;

namespace {

// The summary names a keyframe as claiming too little when its poses' NEES mean is above this over
// at least this many poses (a reporting threshold: a keyframe's poses are correlated, no χ² test).
constexpr double kClaimsTooLittleNees = 6.0;
constexpr std::size_t kClaimsTooLittlePoses = 10;

struct StampedEstimate {
  double stamp;
  htr::Pose2D pose;
  Eigen::Matrix3d covariance;  // of (x, y, yaw)
};

struct Run {
  std::vector<htr::Pose2D> truth;
  std::vector<double> truth_stamps;
  std::vector<StampedEstimate> estimates;  // repeat_node/pose
  std::map<double, int> integrity;         // repeat_node/integrity: level by stamp
  // repeat_node/heading_correction, by stamp: the keyframe the frame's fix was against, and whether
  // the fix was tracked.
  struct Fix {
    int keyframe;
    bool tracked;
  };
  std::map<double, Fix> fixes;
  std::string last_state;
  // planar_world_sim's `people` markers: per stamp, each body's pose and footprint (depth, width).
  struct Body {
    htr::Pose2D pose;
    double depth, width;
  };
  std::map<double, std::vector<Body>> people;
  // When controller_node's state changed (bag time) and whether it then said something was in its way.
  std::map<double, bool> blocked;
};

// The closest the base came to a person: each ground-truth sample against the bodies of the
// nearest `people` message in time (10 Hz; a walker moves 0.12 m between two). null without people.
nlohmann::json minPersonClearance(const Run& run) {
  if (run.people.empty()) return nullptr;
  double clearance = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < run.truth.size(); ++i) {
    auto after = run.people.lower_bound(run.truth_stamps[i]);
    if (after == run.people.end() || (after != run.people.begin() &&
                                      run.truth_stamps[i] - std::prev(after)->first < after->first - run.truth_stamps[i])) {
      after = std::prev(after);
    }
    for (const Run::Body& body : after->second) {
      clearance = std::min(clearance, htr::distanceToBox(Eigen::Vector2d(run.truth[i].x, run.truth[i].y), body.pose,
                                                         body.depth, body.width));
    }
  }
  return clearance;
}


// Mean speed over the straight legs (turning slower than 0.1 rad/s) between the first and the last
// ground-truth interval in which the robot moved; null for a robot that never moved. With
// `way_clear`: only the intervals in which the controller did not report something in its way
// (controller_node/state, "... something in the way"): how fast it drives where nobody stops it.
nlohmann::json straightLegSpeed(const Run& run, bool way_clear = false) {
  constexpr double kStraightYawRate = 0.1;  // [rad/s]
  constexpr double kMoving = 0.02;          // [m/s]
  struct Interval {
    double duration, speed, yaw_rate;  // [s], [m/s], [rad/s] between two ground-truth samples
  };
  std::vector<Interval> intervals;
  for (std::size_t i = 1; i < run.truth.size(); ++i) {
    const double dt = run.truth_stamps[i] - run.truth_stamps[i - 1];
    if (!(dt > 1e-3)) continue;
    if (way_clear) {
      // The controller's state at this interval: the last change at or before its start.
      const auto state = run.blocked.upper_bound(run.truth_stamps[i - 1]);
      if (state != run.blocked.begin() && std::prev(state)->second) continue;
    }
    const double ds = std::hypot(run.truth[i].x - run.truth[i - 1].x, run.truth[i].y - run.truth[i - 1].y);
    intervals.push_back({dt, ds / dt, htr::wrapToPi(run.truth[i].yaw - run.truth[i - 1].yaw) / dt});
  }
  std::size_t first = 0, last = intervals.size();
  while (first < intervals.size() && intervals[first].speed < kMoving) ++first;
  while (last > first && intervals[last - 1].speed < kMoving) --last;
  double distance = 0.0, time = 0.0;
  for (std::size_t i = first; i < last; ++i) {
    if (std::abs(intervals[i].yaw_rate) >= kStraightYawRate) continue;
    distance += intervals[i].speed * intervals[i].duration;
    time += intervals[i].duration;
  }
  if (!(time > 0.0)) return nullptr;
  return distance / time;
}

// The smallest distance [m] from base_link's ground-truth position to any wall.
double minWallClearance(const htr::PlanarWorld& world, const std::vector<htr::Pose2D>& truth) {
  double clearance = std::numeric_limits<double>::infinity();
  for (const auto& p : truth) {
    const Eigen::Vector2d q(p.x, p.y);
    for (const auto& wall : world.walls) {
      const Eigen::Vector2d e = wall.end - wall.start;
      const double s = std::clamp((q - wall.start).dot(e) / e.squaredNorm(), 0.0, 1.0);
      clearance = std::min(clearance, (wall.start + s * e - q).norm());
    }
  }
  return clearance;
}

Run readRun(const std::string& path) {
  Run run;
  rosbag::Bag bag(path, rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery({"ground_truth", "/ground_truth", "controller_node/state",
                                             "/controller_node/state", "repeat_node/pose", "/repeat_node/pose",
                                             "repeat_node/integrity", "/repeat_node/integrity", "people", "/people",
                                             "repeat_node/heading_correction", "/repeat_node/heading_correction"}));
  for (const rosbag::MessageInstance& m : view) {
    if (const auto odom = m.instantiate<nav_msgs::Odometry>()) {
      // A message that is not a planar pose (NaN, non-unit quaternion) is left out.
      const auto truth = htr::ros_conversions::toPose2D(odom->pose.pose);
      if (!truth) continue;
      run.truth.push_back(*truth);
      run.truth_stamps.push_back(odom->header.stamp.toSec());
    } else if (const auto correction = m.instantiate<htr::HeadingCorrectionStamped>()) {
      if (correction->ok && correction->reference_index >= 0) {
        run.fixes[correction->header.stamp.toSec()] = {correction->reference_index, correction->tracked != 0};
      }
    } else if (const auto integrity = m.instantiate<htr::Integrity>()) {
      run.integrity[integrity->header.stamp.toSec()] = integrity->level;
    } else if (const auto markers = m.instantiate<visualization_msgs::MarkerArray>()) {
      std::vector<Run::Body> bodies;
      double stamp = 0.0;
      for (const auto& marker : markers->markers) {
        const auto pose = htr::ros_conversions::toPose2D(marker.pose);
        if (!pose) continue;
        bodies.push_back({*pose, marker.scale.x, marker.scale.y});
        stamp = marker.header.stamp.toSec();
      }
      if (!bodies.empty()) run.people[stamp] = std::move(bodies);
    } else if (const auto state = m.instantiate<std_msgs::String>()) {
      run.last_state = state->data;
      run.blocked[m.getTime().toSec()] = state->data.find("something in the way") != std::string::npos;
    } else if (const auto pose = m.instantiate<geometry_msgs::PoseWithCovarianceStamped>()) {
      const auto estimate = htr::ros_conversions::toPose2D(pose->pose.pose);
      if (!estimate) continue;
      run.estimates.push_back({pose->header.stamp.toSec(), *estimate, htr::ros_conversions::planarCovariance(pose->pose)});
    }
  }
  return run;
}

// Whether repeat_node's ~integrity (the report of the same frame: the same stamp) flagged the
// published poses that were wrong (more than 0.3 m or 5° from the ground truth), and how many right
// ones it flagged. null when the bag has no integrity report.
nlohmann::json scoreIntegrity(const Run& run, const htr::OdometryBuffer& truth) {
  if (run.integrity.empty()) return nullptr;
  htr::IntegrityScore score;
  std::size_t without_report = 0;
  for (const StampedEstimate& e : run.estimates) {
    const auto report = run.integrity.find(e.stamp);
    const auto at = truth.poseAt(e.stamp);
    if (report == run.integrity.end() || !at) {
      ++without_report;
      continue;
    }
    score.add(e.pose, report->second != htr::Integrity::OK, *at);
  }
  const htr::IntegritySummary s = score.summary();
  std::size_t degraded = 0, lost = 0;
  for (const auto& [stamp, level] : run.integrity) {
    degraded += level == htr::Integrity::DEGRADED ? 1 : 0;
    lost += level == htr::Integrity::LOST ? 1 : 0;
  }
  return {{"reports", run.integrity.size()},          {"reports_degraded", degraded},
          {"reports_lost", lost},                     {"poses_scored", s.poses},
          {"wrong_poses", s.wrong},                   {"wrong_poses_flagged", s.wrong_flagged},
          {"right_poses", s.right},                   {"right_poses_flagged", s.right_flagged},
          {"detection", s.detection},                 {"false_alarm", s.false_alarm},
          {"poses_without_report", without_report}};
}

// The published poses against the ground truth at their stamps (the pose of an image is older than
// the newest ground truth: comparing with the latest sample would charge the latency to the pose).
nlohmann::json scoreLocalization(const Run& run) {
  if (run.estimates.empty()) return nullptr;
  htr::OdometryBuffer truth(std::numeric_limits<double>::max(), 0.5);
  for (std::size_t i = 0; i < run.truth.size(); ++i) truth.add(run.truth_stamps[i], run.truth[i]);
  htr::PoseConsistency consistency;
  std::map<int, htr::PoseConsistency> by_keyframe;  // the frame's keyframe: its heading correction's stamp
  htr::PoseConsistency by_source[2];                 // the frame's fix detected (0) or tracked (1)
  std::size_t unscored = 0;
  for (const StampedEstimate& e : run.estimates) {
    const auto at = truth.poseAt(e.stamp);
    if (!at || !consistency.add(e.pose, e.covariance, *at).isOk()) {
      ++unscored;
      continue;
    }
    const auto fix = run.fixes.find(e.stamp);
    if (fix == run.fixes.end()) continue;
    (void)by_keyframe[fix->second.keyframe].add(e.pose, e.covariance, *at);
    (void)by_source[fix->second.tracked ? 1 : 0].add(e.pose, e.covariance, *at);
  }
  const auto summary = consistency.summary();
  if (!summary) return {{"poses", run.estimates.size()}, {"unscored_poses", unscored}};
  nlohmann::json keyframes = run.fixes.empty() ? nlohmann::json(nullptr) : nlohmann::json::array();
  for (const auto& [keyframe, scores] : by_keyframe) {
    const auto of_keyframe = scores.summary();
    if (!of_keyframe) continue;
    keyframes.push_back({{"keyframe", keyframe},
                         {"poses", of_keyframe->samples},
                         {"nees_mean", of_keyframe->nees_mean},
                         {"nees_fraction_above_chi2_95", of_keyframe->fraction_above_chi2_95}});
  }
  const double deg = 180.0 / M_PI;
  nlohmann::json localization = {{"poses", summary->samples},
          {"position_err_rms_m", summary->position_error_rms},
          {"heading_err_rms_deg", summary->heading_error_rms * deg},
          {"position_sigma_rms_m", summary->position_sigma_rms},
          {"heading_sigma_rms_deg", summary->heading_sigma_rms * deg},
          {"nees_mean", summary->nees_mean},
          {"nees_median", summary->nees_median},
          {"nees_fraction_above_chi2_95", summary->fraction_above_chi2_95},
          {"unscored_poses", unscored}};
  localization["integrity"] = scoreIntegrity(run, truth);
  localization["by_keyframe"] = keyframes;
  nlohmann::json sources = nullptr;
  if (!run.fixes.empty()) {
    sources = nlohmann::json::object();
    for (int source = 0; source < 2; ++source) {
      const auto scores = by_source[source].summary();
      sources[source == 0 ? "detected" : "tracked"] =
          scores ? nlohmann::json({{"poses", scores->samples},
                                   {"nees_mean", scores->nees_mean},
                                   {"nees_median", scores->nees_median},
                                   {"nees_fraction_above_chi2_95", scores->fraction_above_chi2_95}})
                 : nlohmann::json(nullptr);
    }
  }
  localization["by_fix_source"] = sources;
  return localization;
}

}  // namespace

// Every `stride`-th pose as [x, y] (the plot needs the shape, not 200 samples per second).
nlohmann::json xyEvery(const std::vector<htr::Pose2D>& poses, const std::vector<double>& stamps, double period) {
  nlohmann::json xy = nlohmann::json::array();
  double last = -1e18;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (i + 1 < poses.size() && !stamps.empty() && stamps[i] - last < period) continue;
    if (!stamps.empty()) last = stamps[i];
    xy.push_back({poses[i].x, poses[i].y});
  }
  return xy;
}

void writeTrajectory(const std::filesystem::path& file, const htr::PlanarWorld& world, const std::vector<htr::Pose2D>& path,
                     const Run& run, const Run& baseline, const htr::cli::Arguments& args) {
  nlohmann::json t;
  t["kind"] = "demo_trajectory";
  t["mode"] = args.text("mode");
  t["laps"] = args.integer("laps");
  t["walls"] = nlohmann::json::array();
  for (const auto& w : world.walls) t["walls"].push_back({{w.start.x(), w.start.y()}, {w.end.x(), w.end.y()}});
  t["taught_path"] = xyEvery(path, {}, 0.0);
  // Where the people walked (one track each, from the `people` markers).
  t["people"] = nlohmann::json::array();
  for (const auto& [stamp, bodies] : run.people) {
    for (std::size_t i = 0; i < bodies.size(); ++i) {
      if (t["people"].size() <= i) t["people"].push_back(nlohmann::json::array());
      auto& track = t["people"][i];
      const nlohmann::json xy = {bodies[i].pose.x, bodies[i].pose.y};
      if (track.empty() || track.back() != xy) track.push_back(xy);
    }
  }
  constexpr double kPeriod = 0.05;  // [s]
  t["repeated"] = xyEvery(run.truth, run.truth_stamps, kPeriod);
  t["odometry_only"] = xyEvery(baseline.truth, baseline.truth_stamps, kPeriod);
  std::vector<htr::Pose2D> published;
  for (const auto& e : run.estimates) published.push_back(e.pose);
  t["published"] = xyEvery(published, {}, 0.0);
  // The published poses against the ground truth at their stamps.
  htr::OdometryBuffer truth(std::numeric_limits<double>::max(), 0.5);
  for (std::size_t i = 0; i < run.truth.size(); ++i) truth.add(run.truth_stamps[i], run.truth[i]);
  t["published_error_m"] = nlohmann::json::array();
  const double start = run.truth_stamps.empty() ? 0.0 : run.truth_stamps.front();
  for (const auto& e : run.estimates) {
    const auto at = truth.poseAt(e.stamp);
    if (at) t["published_error_m"].push_back({e.stamp - start, std::hypot(e.pose.x - at->x, e.pose.y - at->y)});
  }
  std::ofstream(file) << t.dump() << "\n";
}

int main(int argc, char** argv) {
  htr::cli::Arguments args("evaluate_demo_run",
                            {{"world", ""}, {"route", ""}, {"bag", ""}, {"baseline-bag", ""}, {"laps", "1"},
                             {"mode", "fast_hd"}, {"clutter", "0"}, {"out", ""}},
                            "--world W.yaml --route DIR --bag RUN.bag [--baseline-bag ODOM.bag] [--laps N] "
                            "[--mode M] [--clutter 0|1] --out DIR");
  args.parse(argc, argv);
  for (const char* required : {"world", "route", "bag", "out"}) {
    if (args.text(required).empty()) args.fail(std::string("--") + required + " is required");
  }
  try {
    auto world = htr::loadPlanarWorld(args.text("world"));
    if (!world) throw std::runtime_error(world.status().message());
    if (args.integer("clutter") != 0) *world = world->withClutter();  // the repeat ran among it
    const auto route = htr::loadRoute(args.text("route"));
    if (!route) throw std::runtime_error(route.status().message());
    std::vector<htr::Pose2D> path;
    for (const auto& k : route->keyframes) path.push_back(k.pose);
    const Run run = readRun(args.text("bag"));
    if (run.truth.empty()) throw std::runtime_error("no ground_truth in " + args.text("bag"));
    Run baseline;
    if (!args.text("baseline-bag").empty()) baseline = readRun(args.text("baseline-bag"));

    double max_err = 0.0, sum_err = 0.0;
    for (const auto& p : run.truth) {
      const double d = htr::deviationFromPath(path, p).distance;
      max_err = std::max(max_err, d);
      sum_err += d;
    }
    // Where the run must end (controller_node with start_index 1 and return_to_start): a loop ends
    // at its first keyframe, where the robot started; an open route at its last.
    const htr::Pose2D end = htr::isClosedLoop(path, 1.0) ? path.front() : path.back();
    auto endError = [&](const htr::Pose2D& p) { return std::hypot(p.x - end.x, p.y - end.y); };
    nlohmann::json metrics;
    metrics["laps"] = args.integer("laps");
    metrics["mode"] = args.text("mode");
    metrics["final_pos_err_m"] = endError(run.truth.back());
    metrics["final_heading_err_deg"] = std::abs(htr::wrapToPi(run.truth.back().yaw - end.yaw)) * 180.0 / M_PI;
    metrics["max_pos_err_m"] = max_err;
    metrics["mean_pos_err_m"] = sum_err / static_cast<double>(run.truth.size());
    metrics["final_path_err_m"] = htr::deviationFromPath(path, run.truth.back()).distance;
    metrics["samples"] = run.truth.size();
    metrics["controller_state"] = run.last_state;
    const bool finished = run.last_state.rfind("finished", 0) == 0;
    metrics["finished"] = finished;
    double travelled = 0.0, route_length = 0.0;
    for (std::size_t i = 1; i < run.truth.size(); ++i) {
      travelled += std::hypot(run.truth[i].x - run.truth[i - 1].x, run.truth[i].y - run.truth[i - 1].y);
    }
    for (std::size_t i = 1; i < path.size(); ++i) {
      route_length += std::hypot(path[i].x - path[i - 1].x, path[i].y - path[i - 1].y);
    }
    if (htr::isClosedLoop(path, 1.0)) route_length += std::hypot(path.back().x - end.x, path.back().y - end.y);
    metrics["distance_travelled_m"] = travelled;
    metrics["straight_speed_mps"] = straightLegSpeed(run);
    metrics["straight_speed_way_clear_mps"] = straightLegSpeed(run, /*way_clear=*/true);
    metrics["min_wall_clearance_m"] = minWallClearance(*world, run.truth);
    metrics["min_person_clearance_m"] = minPersonClearance(run);
    metrics["route_distance_m"] = route_length * static_cast<double>(args.integer("laps"));
    metrics["localization"] = scoreLocalization(run);
    if (!baseline.truth.empty()) {
      const htr::Pose2D& b = baseline.truth.back();
      metrics["odometry_only_final_pos_err_m"] = endError(b);
      metrics["odometry_only_final_heading_err_deg"] = std::abs(htr::wrapToPi(b.yaw - end.yaw)) * 180.0 / M_PI;
      metrics["odometry_only_max_pos_err_m"] = [&] {
        double m = 0.0;
        for (const auto& p : baseline.truth) m = std::max(m, htr::deviationFromPath(path, p).distance);
        return m;
      }();
      metrics["odometry_only_controller_state"] = baseline.last_state;
    } else {
      metrics["odometry_only_final_pos_err_m"] = nullptr;
    }
    const std::filesystem::path out = args.text("out");
    std::filesystem::create_directories(out);
    std::ofstream(out / "metrics.json") << metrics.dump(2) << "\n";

    writeTrajectory(out / "trajectory.json", *world, path, run, baseline, args);
    std::cout << metrics.dump(2) << "\n";
    // The short summary.
    std::printf("\n%s, %d lap(s): the robot ended %.3f m / %.2f deg from the route's end pose (path error mean "
                "%.3f m, max %.3f m)",
                args.text("mode").c_str(), static_cast<int>(args.integer("laps")),
                metrics["final_pos_err_m"].get<double>(), metrics["final_heading_err_deg"].get<double>(),
                metrics["mean_pos_err_m"].get<double>(), max_err);
    if (!baseline.truth.empty()) {
      std::printf("; odometry only: %.3f m", metrics["odometry_only_final_pos_err_m"].get<double>());
    }
    std::printf("\n");
    const auto& localization = metrics["localization"];
    if (localization.contains("nees_mean")) {
      std::printf("published pose vs ground truth: %.3f m / %.2f deg rms, claimed %.3f m / %.2f deg; NEES mean "
                  "%.1f (3 if the covariance is honest), %.0f %% of poses beyond its 95 %% bound (5 %%)\n",
                  localization["position_err_rms_m"].get<double>(), localization["heading_err_rms_deg"].get<double>(),
                  localization["position_sigma_rms_m"].get<double>(),
                  localization["heading_sigma_rms_deg"].get<double>(), localization["nees_mean"].get<double>(),
                  100.0 * localization["nees_fraction_above_chi2_95"].get<double>());
      if (localization["by_keyframe"].is_array()) {
        std::string claiming_too_little;
        for (const auto& keyframe : localization["by_keyframe"]) {
          if (keyframe["poses"].get<std::size_t>() < kClaimsTooLittlePoses ||
              !(keyframe["nees_mean"].get<double>() > kClaimsTooLittleNees)) {
            continue;
          }
          char entry[96];
          std::snprintf(entry, sizeof(entry), "%s%d (%.1f over %zu)", claiming_too_little.empty() ? "" : ", ",
                        keyframe["keyframe"].get<int>(), keyframe["nees_mean"].get<double>(),
                        keyframe["poses"].get<std::size_t>());
          claiming_too_little += entry;
        }
        std::printf("keyframes whose poses claim too little (NEES mean above %g over %zu or more poses): %s\n",
                    kClaimsTooLittleNees, kClaimsTooLittlePoses,
                    claiming_too_little.empty() ? "none" : claiming_too_little.c_str());
      }
      if (localization["by_fix_source"].is_object()) {
        std::string line;
        for (const char* source : {"detected", "tracked"}) {
          const auto& scores = localization["by_fix_source"][source];
          char entry[128];
          if (scores.is_null()) {
            std::snprintf(entry, sizeof(entry), "%s%s none", line.empty() ? "" : "; ", source);
          } else {
            std::snprintf(entry, sizeof(entry), "%s%s %zu, NEES mean %.1f (median %.1f), %.0f %% beyond",
                          line.empty() ? "" : "; ", source, scores["poses"].get<std::size_t>(),
                          scores["nees_mean"].get<double>(), scores["nees_median"].get<double>(),
                          100.0 * scores["nees_fraction_above_chi2_95"].get<double>());
          }
          line += entry;
        }
        std::printf("poses by the source of their fix: %s\n", line.c_str());
      }
      if (localization["integrity"].is_object()) {
        const auto& integrity = localization["integrity"];
        std::printf("integrity: %zu of %zu wrong poses (> 0.3 m or 5 deg) flagged, %zu of %zu right ones flagged\n",
                    integrity["wrong_poses_flagged"].get<std::size_t>(), integrity["wrong_poses"].get<std::size_t>(),
                    integrity["right_poses_flagged"].get<std::size_t>(), integrity["right_poses"].get<std::size_t>());
      }
    }
    if (!finished) {
      std::printf("the run did NOT finish: controller state '%s', %.2f of %.2f m travelled\n",
                  run.last_state.empty() ? "(none recorded)" : run.last_state.c_str(), travelled,
                  metrics["route_distance_m"].get<double>());
      return 3;
    }
  } catch (const std::exception& e) {
    std::cerr << "evaluate_demo_run: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
