// Teaches a route in a planar world without ROS, as sim_teach.launch does with the nodes (the
// same core: WaypointDriver on DifferentialDriveSim with perfect odometry, ending with a turn to
// the start heading, WorldRenderer at 10 Hz, TeachSession with planes from odometry), for the
// closed-loop rostest's fixture.
//   make_test_sim_route [--seed=N] [--supersampling=K | --texture-filtering=0] WORLD.yaml DIRECTORY FEATURE START_X,START_Y X1,Y1 X2,Y2 ...
// --seed: the renderer's noise (default 1, the fixture's). With the odometry perfect, routes taught
// with other seeds have the same keyframe poses and other draws of the images' noise, hence of the
// planes' and the features' errors (evaluate_route_audit pools over such routes).
// The pixels are the simulator's (RenderOptions, docs/simulator.md "What a pixel sees"): by default
// each samples the textures filtered to its footprint (band-limited); --texture-filtering=0: one
// point of the scene per pixel; --supersampling=K (K > 1, in place of the filtering): the mean of
// K x K behind the lens's blur, K² times slower.
// The camera is config/planar_world_sim.yaml's: 640x480, f = 500, 0.2 m ahead of base_link.
#include <opencv2/core.hpp>

#include <cstdint>
#include <cstdio>
#include <iostream>
#include <stdexcept>
#include <string>
#include <utility>

#include "homography_teach_repeat/sim/differential_drive.h"
#include "homography_teach_repeat/sim/planar_world.h"
#include "homography_teach_repeat/teach_repeat/teach_session.h"
#include "homography_teach_repeat/sim/waypoint_driver.h"
#include "homography_teach_repeat/sim/world_renderer.h"

namespace htr = homography_teach_repeat;

namespace {

Eigen::Vector2d parsePoint(const std::string& text) {
  double x = 0.0, y = 0.0;
  if (std::sscanf(text.c_str(), "%lf,%lf", &x, &y) != 2) throw std::invalid_argument("not 'x,y': " + text);
  return {x, y};
}

}  // namespace

int main(int argc, char** argv) {
  int seed = 1;
  int supersampling = 1;
  int texture_filtering = 1;
  // Leading options, each --name=integer.
  const std::pair<const char*, int*> options[] = {{"--seed=", &seed}, {"--supersampling=", &supersampling}, {"--texture-filtering=", &texture_filtering}};
  for (bool consumed = true; consumed && argc > 1;) {
    consumed = false;
    for (const auto& [prefix, value] : options) {
      const std::string argument = argv[1];
      if (argument.rfind(prefix, 0) != 0) continue;
      try {
        *value = std::stoi(argument.substr(std::string(prefix).size()));
      } catch (const std::exception&) {
        std::cerr << "make_test_sim_route: " << prefix << " needs an integer, got '" << argument << "'\n";
        return 2;
      }
      ++argv;
      --argc;
      consumed = true;
      break;
    }
  }
  const char* const usage =
      "usage: make_test_sim_route [--seed=N] [--supersampling=K | --texture-filtering=0] WORLD.yaml DIRECTORY FEATURE START_X,START_Y "
      "X1,Y1 [X2,Y2 ...]\nTeaches a route in a simulator world without ROS (as sim_teach.launch does) into DIRECTORY.\n";
  if (argc == 2 && (std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h")) {
    std::cout << usage;
    return 0;
  }
  if (argc < 6) {
    std::cerr << usage;
    return 2;
  }
  try {
    const auto world = htr::loadPlanarWorld(argv[1]);
    if (!world) throw std::runtime_error(world.status().message());
    const Eigen::Vector2d start = parsePoint(argv[4]);
    std::vector<Eigen::Vector2d> waypoints;
    for (int i = 5; i < argc; ++i) waypoints.push_back(parsePoint(argv[i]));

    htr::CameraCalibration calibration;
    calibration.width = 640;
    calibration.height = 480;
    calibration.fx = calibration.fy = 500.0;
    calibration.cx = (calibration.width - 1) / 2.0;
    calibration.cy = (calibration.height - 1) / 2.0;
    htr::RenderOptions render;
    render.camera_height = 0.6;
    render.noise_sigma = 2.0;
    render.blur_sigma = 0.5;
    render.supersampling = supersampling;
    render.texture_filtering = supersampling == 1 && texture_filtering != 0;
    const htr::WorldRenderer renderer{htr::PinholeCamera(calibration), render};
    const htr::Pose2D mount(0.2, 0.0, 0.0);

    htr::TeachOptions options;
    options.route_directory = argv[2];
    options.overwrite = true;
    options.features.type = htr::featureTypeFromString(argv[3]);
    options.features.max_features = 1500;
    options.keyframes.distance = 0.5;
    options.planes_from_odometry = true;
    auto session = htr::TeachSession::start(options, calibration, mount);
    if (!session) throw std::runtime_error(session.status().message());

    htr::DifferentialDriveSim robot(htr::Pose2D(start.x(), start.y(), 0.0), htr::OdometryErrorModel(),
                                    htr::DriveLimits());
    htr::WaypointDriverOptions driving;
    driving.turn_to_final_yaw = true;  // as sim_teach.launch: end facing the start heading
    driving.final_yaw = 0.0;
    htr::WaypointDriver driver(waypoints, driving);
    cv::RNG rng(static_cast<std::uint64_t>(seed));
    const htr::Status driven = htr::driveWaypoints(
        driver, robot, 0.01, 0.1, 2000.0, [&](const htr::DifferentialDriveSim& sim, double t) {
          const cv::Mat image = renderer.render(*world, sim.truth().compose(mount), 1.0, rng);
          const auto stored = session->offer(image, sim.odometry(), t);
          return stored ? htr::Status::ok() : stored.status();
        });
    if (!driven.isOk()) throw std::runtime_error(driven.message());
    const auto report = session->finish();
    if (!report) throw std::runtime_error(report.status().message());
    for (const auto& message : report->messages) std::cout << "  " << message << "\n";
    std::cout << "route written to " << argv[2] << ": " << report->keyframes << " keyframes, "
              << report->planes << " with a plane\n";
    if (report->planes < report->keyframes) return 1;
  } catch (const std::exception& e) {
    std::cerr << "make_test_sim_route: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
