// eval_mu: simulated counterparts of paper 002's Fig. 2-3 / Table 1 (heading from a 1D
// homography of vertical lines by μ, t, eigenvalues and complete motion) and Fig. 4 (a robot in a
// corridor correcting its heading every 7 m).
//
//   rosrun homography_teach_repeat eval_mu [--json F] [--seed S]; plots: scripts/plot_evaluation F
//          [--runs 100] [--lines 20] [--axis-offset 0]
//
// Table 1: a 1D camera (640 px, f = 500 px) rotates from −10° to 10° in 29 steps about a vertical
// axis through its optical centre (`--axis-offset` m behind it, default 0), seen against the
// central image; `--lines` vertical lines of the scene visible in both images; 1 px Gaussian noise
// on every line x in both images; the robust 1D homography (LMedS, Algorithm 1); mean absolute
// rotation error [deg] over the 29 steps × `--runs` noise draws. Scenes: a wall 4 m away rotated
// 25° from the image plane ("planar"), and two perpendicular walls meeting 5 m ahead
// ("non_planar"), lines at viewing angles within ±22° (all visible over the sweep). The eigenvalue
// method gives |θ| only: its error is ||θ̂| − |θ||. Complete motion uses det H = 1 (the depth ratio
// is unknown) and, of its two solutions, the one whose wall normal is closest to the optical axis
// ("ca"); "ca_oracle" (for information) takes the solution closest to the truth.
//
// Corridor (Fig. 4): the taught path is the corridor's centre line; reference images every 7 m,
// looking at the far wall of the hall the corridor opens into (75 m ahead, 20 m wide, 30
// vertical lines). Each step the robot advances 7 m and its
// heading drifts by N(0.05, 0.01²) rad; in the second run it also drifts sideways by N(5%, 1%²)
// of the advance. At each reference position it corrects its heading by the estimated θ: none,
// from μ, or from complete motion (given its best case: of the two solutions the one closer to
// the true heading error). Output: the final lateral error [m] and a PNG of the trajectories.
#include <nlohmann/json.hpp>

#include <cmath>
#include <iomanip>
#include <iostream>
#include <map>
#include <random>
#include <vector>

#include "homography_teach_repeat/common/command_line.h"
#include "homography_teach_repeat/mu/heading_1d.h"
#include "homography_teach_repeat/mu/homography_1d.h"
#include "homography_teach_repeat/eval/synthetic_line_scene.h"

using namespace homography_teach_repeat;

namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kWidth = 640.0;
const LineCamera kCamera{500.0, 319.5};

struct Estimates {
  bool ok = false;
  double mu = 0.0, t = 0.0, ev = 0.0;
  std::vector<CompleteMotion1d> complete;
};

// Noisy observations of `points` from the reference pose (identity) and `pose`, then the robust
// 1D homography and the four heading estimates.
Estimates estimate(const std::vector<Eigen::Vector2d>& points, const PlanarPose& pose,
                   double noise_px, std::mt19937_64* rng, unsigned seed) {
  std::normal_distribution<double> noise(0.0, noise_px);
  std::vector<LineCorrespondence> lines;
  std::vector<double> reference_xs;
  for (const auto& p : points) {
    const auto x1 = projectVerticalLine(kCamera, PlanarPose(), p, kWidth);
    const auto x2 = projectVerticalLine(kCamera, pose, p, kWidth);
    if (!x1 || !x2) continue;
    lines.push_back({*x1 + noise(*rng), *x2 + noise(*rng)});
  }
  Estimates e;
  Homography1dOptions options;
  options.seed = seed;
  const auto h = estimateHomography1dLmeds(lines, options);
  if (!h) return e;
  for (const int i : h->inliers) reference_xs.push_back(lines[static_cast<std::size_t>(i)].reference_x);
  const auto mu = headingFromMu(h->H, kCamera);
  const auto t = headingFromT(h->H, kCamera);
  const auto ev = headingMagnitudeFromEigenvalues(h->H);
  const auto complete = completeMotion1d(h->H, kCamera, reference_xs);
  if (!mu || !t || !ev || !complete) return e;
  e.ok = true;
  e.mu = *mu;
  e.t = *t;
  e.ev = *ev;
  e.complete = *complete;
  return e;
}

// Lines are placed at evenly spaced viewing angles in ±22° from the reference optical axis (like
// door and window frames along a wall), so that every line stays in the 65° field of view over
// the whole ±10° sweep.
constexpr double kMaxViewAngle = 22.0 * kDeg;

double viewAngle(int i, int count) {
  return -kMaxViewAngle + 2.0 * kMaxViewAngle * (i + 0.5) / count;
}

// The point where the ray at `angle` meets the line nᵀX = d.
Eigen::Vector2d onWall(double angle, const Eigen::Vector2d& n, double d) {
  const Eigen::Vector2d ray(std::sin(angle), std::cos(angle));
  return ray * (d / n.dot(ray));
}

std::vector<Eigen::Vector2d> planarScene(int count) {
  // Wall 4 m ahead, rotated 25° from the image plane.
  const double phi = 25.0 * kDeg, d = 4.0;
  const Eigen::Vector2d n(std::sin(phi), std::cos(phi));
  std::vector<Eigen::Vector2d> points;
  for (int i = 0; i < count; ++i) points.push_back(onWall(viewAngle(i, count), n, d));
  return points;
}

std::vector<Eigen::Vector2d> cornerScene(int count) {
  // Two perpendicular walls meeting at (0, 5), at ±45° to the optical axis (a room corner).
  const double d = 5.0 / std::sqrt(2.0);
  const Eigen::Vector2d left(-1.0 / std::sqrt(2.0), 1.0 / std::sqrt(2.0));
  const Eigen::Vector2d right(1.0 / std::sqrt(2.0), 1.0 / std::sqrt(2.0));
  std::vector<Eigen::Vector2d> points;
  for (int i = 0; i < count; ++i) {
    const double a = viewAngle(i, count);
    points.push_back(onWall(a, a < 0.0 ? left : right, d));
  }
  return points;
}

nlohmann::json runTable1(const std::vector<Eigen::Vector2d>& scene, int runs, double axis_offset,
                         std::mt19937_64* rng) {
  std::map<std::string, double> sum{
      {"mu", 0.0}, {"t", 0.0}, {"ev", 0.0}, {"ca", 0.0}, {"ca_oracle", 0.0}};
  int count = 0, failures = 0;
  for (int step = 0; step < 29; ++step) {
    const double theta = (-10.0 + 20.0 * step / 28.0) * kDeg;
    // Rotation about an axis `axis_offset` behind the optical centre: C = a (sinθ... ) .
    const Eigen::Vector2d axis(0.0, -axis_offset);
    const Eigen::Vector2d forward(-std::sin(theta), std::cos(theta));
    const Eigen::Vector2d centre = axis + axis_offset * forward;
    const PlanarPose pose(centre.x(), centre.y(), theta);
    for (int run = 0; run < runs; ++run) {
      const Estimates e = estimate(scene, pose, 1.0, rng, static_cast<unsigned>(run + 1));
      if (!e.ok) {
        ++failures;
        continue;
      }
      // Of the two solutions, the one whose wall normal is closest to the optical axis (no
      // ground truth: the camera is known to face the scene).
      double ca = e.complete.front().theta, most_frontal = -2.0;
      for (const auto& m : e.complete) {
        if (m.normal.y() > most_frontal) {
          most_frontal = m.normal.y();
          ca = m.theta;
        }
      }
      sum["mu"] += std::abs(e.mu - theta);
      sum["t"] += std::abs(e.t - theta);
      sum["ev"] += std::abs(e.ev - std::abs(theta));
      sum["ca"] += std::abs(ca - theta);
      // For information: the solution closest to the truth (not available to a robot).
      double oracle = 1e9;
      for (const auto& m : e.complete) oracle = std::min(oracle, std::abs(m.theta - theta));
      sum["ca_oracle"] += oracle;
      ++count;
    }
  }
  nlohmann::json out;
  for (const auto& [k, v] : sum) out[k] = v / count / kDeg;
  out["estimates"] = count;
  out["failures"] = failures;
  return out;
}

struct Trajectory {
  std::vector<Eigen::Vector2d> positions;  // (x, z) world
  double final_lateral_error = 0.0;
};

// mode: 0 none, 1 μ, 2 complete motion.
Trajectory runCorridor(int mode, bool lateral_drift, unsigned seed) {
  std::mt19937_64 motion_rng(seed), vision_rng(seed + 1000);
  std::normal_distribution<double> heading_error(0.05, 0.01), lateral_error(0.05, 0.01);
  const double step = 7.0, end_wall = 75.0;
  std::vector<Eigen::Vector2d> wall_lines;
  // The corridor opens into a hall: its far wall, 20 m wide, carries the vertical lines.
  std::uniform_real_distribution<double> across(-10.0, 10.0);
  for (int i = 0; i < 30; ++i) wall_lines.emplace_back(across(motion_rng), end_wall);
  Trajectory trajectory;
  double x = 0.0, z = 0.0, heading = 0.0;  // heading: CCW, 0 = along +z
  trajectory.positions.emplace_back(x, z);
  for (int k = 1; k * step < end_wall - 3.0; ++k) {
    x += -std::sin(heading) * step;
    z += std::cos(heading) * step;
    heading += heading_error(motion_rng);
    if (lateral_drift) x += lateral_error(motion_rng) * step;
    trajectory.positions.emplace_back(x, z);
    if (mode == 0) continue;
    // Reference k: at (0, 7k), heading 0. Lines in the reference frame.
    const Eigen::Vector2d reference(0.0, k * step);
    std::vector<Eigen::Vector2d> points;
    for (const auto& p : wall_lines) points.push_back(p - reference);
    const PlanarPose pose(x - reference.x(), z - reference.y(), heading);
    const Estimates e = estimate(points, pose, 1.0, &vision_rng, static_cast<unsigned>(k));
    if (!e.ok) continue;
    double correction = e.mu;
    if (mode == 2) {
      // Complete motion gets its best case, the solution closest to the true heading error: the
      // comparison is about what a correct rotation estimate does to lateral drift (paper 002
      // Fig. 4), not about choosing between the two solutions.
      double best = 1e9;
      for (const auto& m : e.complete) {
        if (std::abs(m.theta - pose.theta) < best) {
          best = std::abs(m.theta - pose.theta);
          correction = m.theta;
        }
      }
    }
    heading -= correction;
  }
  trajectory.final_lateral_error = std::abs(x);
  return trajectory;
}

}  // namespace

int main(int argc, char** argv) {
  cli::Arguments args("eval_mu",
                       {{"json", ""}, {"seed", "1"}, {"runs", "100"}, {"lines", "20"}, {"axis-offset", "0"}},
                       "[--json F] [--seed S] [--runs N] [--lines N] [--axis-offset M]");
  args.parse(argc, argv);
  const int runs = args.integer("runs");
  const int line_count = args.integer("lines");
  if (runs < 1 || line_count < 3) args.fail("--runs >= 1 and --lines >= 3 are required");
  const unsigned seed = static_cast<unsigned>(args.integer("seed"));
  std::mt19937_64 rng(seed);

  nlohmann::json document;
  const auto planar = planarScene(line_count);
  const auto corner = cornerScene(line_count);
  document["table1"]["planar"] = runTable1(planar, runs, args.number("axis-offset"), &rng);
  document["table1"]["non_planar"] = runTable1(corner, runs, args.number("axis-offset"), &rng);

  std::vector<std::vector<Trajectory>> trajectories(2);
  const char* run_names[] = {"rotation_drift", "rotation_and_lateral_drift"};
  for (int drift = 0; drift < 2; ++drift) {
    for (int mode = 0; mode < 3; ++mode) {
      trajectories[drift].push_back(runCorridor(mode, drift == 1, seed));
    }
    // The trajectories (x across, z along the corridor [m]) for scripts/plot_evaluation.
    auto positions = [&](int mode) {
      nlohmann::json xz = nlohmann::json::array();
      for (const auto& p : trajectories[drift][static_cast<std::size_t>(mode)].positions) xz.push_back({p.x(), p.y()});
      return xz;
    };
    document["corridor"][run_names[drift]] = {
        {"none_final_lateral_error_m", trajectories[drift][0].final_lateral_error},
        {"mu_final_lateral_error_m", trajectories[drift][1].final_lateral_error},
        {"ca_final_lateral_error_m", trajectories[drift][2].final_lateral_error},
        {"trajectories_xz_m", {{"none", positions(0)}, {"mu", positions(1)}, {"complete_motion", positions(2)}}}};
  }
  document["setup"] = {{"runs", runs}, {"lines", line_count}, {"seed", seed},
                       {"f_px", kCamera.f}, {"width_px", kWidth}, {"noise_px", 1.0},
                       {"axis_offset_m", args.number("axis-offset")}};

  std::cout << std::fixed << std::setprecision(4) << "Table 1 (mean |rotation error| [deg]):\n";
  for (const char* scene : {"planar", "non_planar"}) {
    const auto& t = document["table1"][scene];
    std::cout << "  " << std::setw(10) << scene << ": mu " << t["mu"].get<double>() << "  t "
              << t["t"].get<double>() << "  ev " << t["ev"].get<double>() << "  ca "
              << t["ca"].get<double>() << " (closest solution " << t["ca_oracle"].get<double>()
              << ")\n";
  }
  std::cout << std::setprecision(3) << "Corridor final lateral error [m]:\n";
  for (const char* run : run_names) {
    const auto& c = document["corridor"][run];
    std::cout << "  " << run << ": none " << c["none_final_lateral_error_m"].get<double>()
              << "  mu " << c["mu_final_lateral_error_m"].get<double>() << "  complete motion "
              << c["ca_final_lateral_error_m"].get<double>() << "\n";
  }
  args.writeJson(document);
  return 0;
}
