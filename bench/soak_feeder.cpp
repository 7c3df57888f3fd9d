// The soak benchmark's camera (bench/soak runs it; issue 7). Two modes:
//
//   soak_feeder --teach ROUTE_DIR --size WxH [--world FILE] [--feature sift|orb|akaze]
//     Teaches the loop of test/data/worlds/small_room.yaml (start (0.9, 0.9), corners (2.6, 0.9),
//     (2.6, 2.1), (0.9, 2.1)) without ROS, as make_test_sim_route does: WaypointDriver on a
//     DifferentialDriveSim, WorldRenderer frames at 10 Hz, TeachSession with 1500 features of
//     --feature (default sift: config/teach_node.yaml's default) and planes from odometry. Camera: W x H, f = 500 W / 640,
//     0.2 m ahead of base_link, 0.6 m high.
//
//   soak_feeder --feed ROUTE_DIR --size WxH --duration S --pid PID --json FILE [--rate HZ] [--world FILE]
//     A ROS node. Renders one lap of the same loop at --rate (default 30 Hz; mono8, pixel noise
//     2 grey levels, so no two frames are equal), then publishes it lap after lap for S seconds
//     of wall time on camera/image_raw + camera/camera_info (stamp = wall clock at publication),
//     with odometry on odom (the lap's poses, chained so that odometry runs on continuously),
//     to a repeat_node with that route. Each frame repeat_node processes yields one
//     repeat_node/heading_correction with the image's stamp (ok or not): frames processed, and
//     latency = arrival of that message - image stamp. RSS of process PID (VmRSS) every 5 s.
//     Writes FILE (JSON): frames in / processed / dropped / localized, latency p50/p90/p99/max,
//     RSS at the first processed frame, "start" (largest sample in 10-30 % of the run, after
//     warm-up) and "end" (largest in the last 20 %), its max and the samples, the growth from
//     start to end in percent, and repeat_node's last diagnostics (processing time, image age).
#include <diagnostic_msgs/DiagnosticArray.h>
#include <image_transport/image_transport.h>
#include <nav_msgs/Odometry.h>
#include <nlohmann/json.hpp>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/image_encodings.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "homography_teach_repeat/HeadingCorrectionStamped.h"
#include "homography_teach_repeat/sim/differential_drive.h"
#include "homography_teach_repeat/sim/planar_world.h"
#include "homography_teach_repeat/ros/conversions.h"
#include "homography_teach_repeat/teach_repeat/teach_session.h"
#include "homography_teach_repeat/sim/waypoint_driver.h"
#include "homography_teach_repeat/sim/world_renderer.h"

namespace htr = homography_teach_repeat;

namespace {

const Eigen::Vector2d kStart(0.9, 0.9);
const std::vector<Eigen::Vector2d> kLoop = {{2.6, 0.9}, {2.6, 2.1}, {0.9, 2.1}, {0.9, 0.9}};
const htr::Pose2D kMount(0.2, 0.0, 0.0);

struct Arguments {
  std::string mode, route, world = HTR_DEFAULT_SOAK_WORLD, json, feature = "sift";
  int width = 640, height = 480, pid = -1;
  double duration = 300.0, rate = 30.0;
};

Arguments parse(int argc, char** argv) {
  Arguments a;
  for (int i = 1; i < argc; ++i) {
    const std::string key = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(key + " needs a value");
      return argv[++i];
    };
    if (key == "--teach" || key == "--feed") {
      a.mode = key.substr(2);
      a.route = value();
    } else if (key == "--size") {
      const std::string size = value();
      if (std::sscanf(size.c_str(), "%dx%d", &a.width, &a.height) != 2 || a.width < 64 || a.height < 48) {
        throw std::invalid_argument("--size must be WxH (at least 64x48), not '" + size + "'");
      }
    } else if (key == "--world") {
      a.world = value();
    } else if (key == "--feature") {
      a.feature = value();
    } else if (key == "--json") {
      a.json = value();
    } else if (key == "--pid") {
      a.pid = std::stoi(value());
    } else if (key == "--duration") {
      a.duration = std::stod(value());
    } else if (key == "--rate") {
      a.rate = std::stod(value());
    } else if (key.rfind("__", 0) == 0 || key.find(":=") != std::string::npos) {
      continue;  // ROS remapping arguments
    } else {
      throw std::invalid_argument("unknown argument '" + key + "'");
    }
  }
  if (a.mode.empty()) throw std::invalid_argument("--teach DIR or --feed DIR is required");
  if (a.mode == "feed" && (a.json.empty() || a.pid <= 0 || !(a.duration > 0.0) || !(a.rate > 0.0))) {
    throw std::invalid_argument("--feed needs --json FILE, --pid PID, --duration > 0 and --rate > 0");
  }
  return a;
}

htr::CameraCalibration calibrationFor(int width, int height) {
  htr::CameraCalibration c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = 500.0 * width / 640.0;
  c.cx = (width - 1) / 2.0;
  c.cy = (height - 1) / 2.0;
  return c;
}

htr::WorldRenderer rendererFor(const htr::CameraCalibration& calibration) {
  htr::RenderOptions render;
  render.camera_height = 0.6;
  render.noise_sigma = 2.0;
  render.blur_sigma = 0.5;
  return htr::WorldRenderer(htr::PinholeCamera(calibration), render);
}

htr::Status driveTheLoop(double frame_period,
                         const std::function<htr::Status(const htr::DifferentialDriveSim&, double)>& on_frame) {
  htr::DifferentialDriveSim robot(htr::Pose2D(kStart.x(), kStart.y(), 0.0), htr::OdometryErrorModel(),
                                  htr::DriveLimits());
  htr::WaypointDriverOptions driving;
  driving.turn_to_final_yaw = true;
  driving.final_yaw = 0.0;
  htr::WaypointDriver driver(kLoop, driving);
  return htr::driveWaypoints(driver, robot, frame_period / 10.0, frame_period, 2000.0, on_frame);
}

int teach(const Arguments& a) {
  const auto world = htr::loadPlanarWorld(a.world);
  if (!world) throw std::runtime_error(world.status().message());
  const htr::CameraCalibration calibration = calibrationFor(a.width, a.height);
  const htr::WorldRenderer renderer = rendererFor(calibration);
  htr::TeachOptions options;
  options.route_directory = a.route;
  options.overwrite = true;
  options.features.type = htr::featureTypeFromString(a.feature);
  options.features.max_features = 1500;
  options.keyframes.distance = 0.5;
  options.planes_from_odometry = true;
  auto session = htr::TeachSession::start(options, calibration, kMount);
  if (!session) throw std::runtime_error(session.status().message());
  cv::RNG rng(1);
  const htr::Status driven = driveTheLoop(0.1, [&](const htr::DifferentialDriveSim& robot, double t) {
    const auto stored = session->offer(renderer.render(*world, robot.truth().compose(kMount), 1.0, rng),
                                       robot.odometry(), t);
    return stored ? htr::Status::ok() : stored.status();
  });
  if (!driven.isOk()) throw std::runtime_error(driven.message());
  const auto report = session->finish();
  if (!report) throw std::runtime_error(report.status().message());
  std::cout << "soak_feeder: route " << a.route << " (" << a.width << "x" << a.height << "): " << report->keyframes
            << " keyframes, " << report->planes << " with a plane\n";
  return report->planes == report->keyframes ? 0 : 1;
}

double residentMegabytes(int pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;  // kB
  }
  return -1.0;
}

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return -1.0;
  std::sort(values.begin(), values.end());
  const auto index = static_cast<std::size_t>(std::min(values.size() - 1.0, p / 100.0 * values.size()));
  return values[index];
}

int feed(const Arguments& a) {
  const auto world = htr::loadPlanarWorld(a.world);
  if (!world) throw std::runtime_error(world.status().message());
  const htr::CameraCalibration calibration = calibrationFor(a.width, a.height);
  const htr::WorldRenderer renderer = rendererFor(calibration);
  struct Frame {
    cv::Mat image;  // mono8
    htr::Pose2D odometry;
  };
  std::vector<Frame> lap;
  cv::RNG rng(2);
  const htr::Status driven = driveTheLoop(1.0 / a.rate, [&](const htr::DifferentialDriveSim& robot, double) {
    cv::Mat grey;
    cv::cvtColor(renderer.render(*world, robot.truth().compose(kMount), 1.0, rng), grey, cv::COLOR_BGR2GRAY);
    lap.push_back({grey, robot.odometry()});
    return htr::Status::ok();
  });
  if (!driven.isOk() || lap.size() < 2) throw std::runtime_error("lap not rendered: " + driven.message());
  ROS_INFO("soak_feeder: one lap rendered, %zu frames of %dx%d (%.0f s at %.0f Hz)", lap.size(), a.width,
           a.height, lap.size() / a.rate, a.rate);

  ros::NodeHandle nh;
  image_transport::ImageTransport transport(nh);
  image_transport::CameraPublisher camera = transport.advertiseCamera("camera/image_raw", 1);
  ros::Publisher odometry_publisher = nh.advertise<nav_msgs::Odometry>("odom", 50);
  std::mutex mutex;
  std::map<double, bool> published;  // image stamp -> processed
  std::vector<double> latencies_ms;
  long localized = 0;
  double first_processed_rss = -1.0;
  ros::Subscriber results = nh.subscribe<htr::HeadingCorrectionStamped>(
      "repeat_node/heading_correction", 100, [&](const htr::HeadingCorrectionStamped::ConstPtr& m) {
        const double arrival = ros::WallTime::now().toSec();
        std::lock_guard<std::mutex> lock(mutex);
        const auto it = published.find(m->header.stamp.toSec());
        if (it == published.end() || it->second) return;
        it->second = true;
        latencies_ms.push_back(1e3 * (arrival - m->header.stamp.toSec()));
        localized += m->ok ? 1 : 0;
        if (first_processed_rss < 0.0) first_processed_rss = residentMegabytes(a.pid);
      });
  nlohmann::json node_diagnostics = nlohmann::json::object();  // repeat_node's last diagnostics
  ros::Subscriber diagnostics = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 10, [&](const diagnostic_msgs::DiagnosticArray::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mutex);
        for (const auto& status : m->status) {
          if (status.name.find("repeat_node") == std::string::npos) continue;
          node_diagnostics["message"] = status.message;
          for (const auto& v : status.values) node_diagnostics[v.key] = v.value;
        }
      });
  ros::AsyncSpinner spinner(1);
  spinner.start();
  const ros::WallTime wait_until = ros::WallTime::now() + ros::WallDuration(30.0);
  while (ros::ok() && (camera.getNumSubscribers() == 0 || odometry_publisher.getNumSubscribers() == 0)) {
    if (ros::WallTime::now() > wait_until) throw std::runtime_error("repeat_node did not subscribe within 30 s");
    ros::WallDuration(0.05).sleep();
  }
  ros::WallDuration(1.0).sleep();  // let the subscriptions settle

  sensor_msgs::CameraInfo info;
  info.width = static_cast<uint32_t>(a.width);
  info.height = static_cast<uint32_t>(a.height);
  info.distortion_model = "plumb_bob";
  info.D = {0, 0, 0, 0, 0};
  info.K = {calibration.fx, 0, calibration.cx, 0, calibration.fy, calibration.cy, 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {calibration.fx, 0, calibration.cx, 0, 0, calibration.fy, calibration.cy, 0, 0, 0, 1, 0};
  // Odometry runs on from lap to lap: frame i of lap k is at lap_step^k ∘ lap[i] with
  // lap_step = lap.back() ∘ lap.front()^-1, so lap k + 1 starts where lap k ended.
  htr::Pose2D lap_origin(0.0, 0.0, 0.0);  // lap_step^k
  const htr::Pose2D lap_step = lap.back().odometry.compose(lap.front().odometry.inverse());

  nlohmann::json rss_samples = nlohmann::json::array();
  double rss_max = 0.0;
  const ros::WallTime begin = ros::WallTime::now();
  const ros::WallTime end = begin + ros::WallDuration(a.duration);
  ros::WallTime next_rss = begin;
  long frames_in = 0;
  ros::WallRate rate(a.rate);
  for (std::size_t i = 0; ros::ok() && ros::WallTime::now() < end; ++i) {
    if (i == lap.size()) {
      i = 0;
      lap_origin = lap_step.compose(lap_origin);
    }
    const ros::WallTime now = ros::WallTime::now();
    if (now >= next_rss) {
      const double rss = residentMegabytes(a.pid);
      if (rss < 0.0) throw std::runtime_error("process " + std::to_string(a.pid) + " is gone (repeat_node died?)");
      rss_samples.push_back({{"t_s", (now - begin).toSec()}, {"rss_mb", rss}});
      rss_max = std::max(rss_max, rss);
      next_rss = next_rss + ros::WallDuration(5.0);
    }
    const ros::Time stamp = ros::Time::now();
    const htr::Pose2D odometry = lap_origin.compose(lap[i].odometry);
    nav_msgs::Odometry odom;
    odom.header.stamp = stamp;
    odom.header.frame_id = "odom";
    odom.child_frame_id = "base_link";
    odom.pose.pose.position.x = odometry.x;
    odom.pose.pose.position.y = odometry.y;
    odom.pose.pose.orientation = htr::ros_conversions::yawQuaternion(odometry.yaw);
    odometry_publisher.publish(odom);
    sensor_msgs::Image image;
    image.header.stamp = stamp;
    image.header.frame_id = "camera_optical_frame";
    image.height = static_cast<uint32_t>(a.height);
    image.width = static_cast<uint32_t>(a.width);
    image.encoding = sensor_msgs::image_encodings::MONO8;
    image.step = static_cast<uint32_t>(a.width);
    image.data.assign(lap[i].image.data, lap[i].image.data + lap[i].image.total());
    info.header = image.header;
    {
      std::lock_guard<std::mutex> lock(mutex);
      published.emplace(stamp.toSec(), false);
    }
    camera.publish(image, info);
    ++frames_in;
    rate.sleep();
  }
  ros::WallDuration(2.5).sleep();  // the last frame's result and a diagnostics update
  rss_samples.push_back({{"t_s", (ros::WallTime::now() - begin).toSec()}, {"rss_mb", residentMegabytes(a.pid)}});
  spinner.stop();
  // The allocator returns memory to the system now and then, so single samples swing by ~10 %:
  // "start" is the largest sample in [10 %, 30 %] of the run (after warm-up), "end" the largest in
  // its last 20 %; a leak raises the second.
  auto windowMax = [&](double from, double to) {
    double m = -1.0;
    for (const auto& sample : rss_samples) {
      const double t = sample["t_s"].get<double>() / a.duration;
      if (t >= from && t <= to) m = std::max(m, sample["rss_mb"].get<double>());
    }
    return m;
  };
  const double rss_start = windowMax(0.1, 0.3), rss_end = windowMax(0.8, 2.0);

  std::lock_guard<std::mutex> lock(mutex);
  const auto processed = static_cast<long>(latencies_ms.size());
  const nlohmann::json out = {
      {"size", std::to_string(a.width) + "x" + std::to_string(a.height)},
      {"feature_type", a.feature},
      {"max_features", 1500},
      {"encoding", "mono8"},
      {"rate_hz", a.rate},
      {"duration_s", a.duration},
      {"lap_frames", lap.size()},
      {"frames_in", frames_in},
      {"frames_processed", processed},
      {"frames_dropped", frames_in - processed},
      {"frames_localized", localized},
      {"latency_ms",
       {{"p50", percentile(latencies_ms, 50)},
        {"p90", percentile(latencies_ms, 90)},
        {"p99", percentile(latencies_ms, 99)},
        {"max", percentile(latencies_ms, 100)}}},
      {"rss_mb",
       {{"first_processed_frame", first_processed_rss},
        {"start", rss_start},
        {"end", rss_end},
        {"max", std::max(rss_max, rss_end)},
        {"samples", rss_samples}}},
      {"repeat_node_diagnostics", node_diagnostics},
      {"rss_growth_percent", rss_start > 0.0 ? 100.0 * (rss_end - rss_start) / rss_start : -1.0},
      {"note", "latency: image stamp (wall clock at publication) to the arrival of repeat_node's "
               "heading_correction for it; RSS sampled every 5 s: start = largest sample in 10-30 % of "
               "the run, end = largest in the last 20 %"}};
  std::ofstream(a.json) << out.dump(2) << "\n";
  std::cout << out.dump(2) << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Arguments a = parse(argc, argv);
    if (a.mode == "teach") return teach(a);
    ros::init(argc, argv, "soak_feeder");
    return feed(a);
  } catch (const std::exception& e) {
    std::cerr << "soak_feeder: " << e.what() << "\n";
    return 1;
  }
}
