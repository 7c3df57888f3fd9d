#include "homography_teach_repeat/sim/ros/planar_world_sim.h"

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/LaserScan.h>
#include <visualization_msgs/MarkerArray.h>

#include <tf2/LinearMath/Matrix3x3.h>
#include <tf2/LinearMath/Quaternion.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "homography_teach_repeat/ros/conversions.h"
#include "homography_teach_repeat/ros/parameters.h"

namespace homography_teach_repeat {
namespace {

// Odometry as a base publishes it: pose and twist with their covariances, row-major 6x6. The
// planar entries (pose x, y, yaw; twist vx, vy, wz) get the model's covariance plus `floor` (never
// exactly zero: robot_localization warns about zero variances and takes them as certainty); the
// others (z, roll, pitch and their rates: a planar base does not observe them) `unobserved`.
nav_msgs::Odometry odometryMessage(const Pose2D& pose, const Eigen::Matrix3d& pose_covariance,
                                   const MeasuredVelocity& velocity, const ros::Time& stamp, const std::string& frame,
                                   const std::string& child, double floor, double unobserved) {
  nav_msgs::Odometry m;
  m.header.stamp = stamp;
  m.header.frame_id = frame;
  m.child_frame_id = child;
  const Eigen::Matrix3d covariance = pose_covariance + floor * Eigen::Matrix3d::Identity();
  m.pose = ros_conversions::toPoseWithCovariance(pose, &covariance, unobserved);
  m.twist.twist.linear.x = velocity.v;
  m.twist.twist.angular.z = velocity.w;
  auto& t = m.twist.covariance;
  t.fill(0.0);
  t[0 * 6 + 0] = velocity.covariance(0, 0) + floor;
  t[1 * 6 + 1] = floor;  // no sideways slip: known to be ~0
  t[5 * 6 + 5] = velocity.covariance(1, 1) + floor;
  t[2 * 6 + 2] = t[3 * 6 + 3] = t[4 * 6 + 4] = unobserved;
  return m;
}

geometry_msgs::TransformStamped transformMessage(const Pose2D& pose, double z, const ros::Time& stamp,
                                                 const std::string& parent, const std::string& child) {
  geometry_msgs::TransformStamped t;
  t.header.stamp = stamp;
  t.header.frame_id = parent;
  t.child_frame_id = child;
  t.transform.translation.x = pose.x;
  t.transform.translation.y = pose.y;
  t.transform.translation.z = z;
  t.transform.rotation = ros_conversions::yawQuaternion(pose.yaw);
  return t;
}

void requirePositive(const ros::NodeHandle& nh, const std::string& name, double value) {
  if (!std::isfinite(value) || !(value > 0.0)) {
    throw std::runtime_error("parameter '" + nh.resolveName(name) + "' must be > 0");
  }
}

}  // namespace

PlanarWorldSim::PlanarWorldSim(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh)
    : nh_(nh), private_nh_(private_nh), image_transport_(nh) {
  const auto& p = private_nh;
  const std::string world_file = readRequiredParameter<std::string>(p, "world_file");
  auto world = loadPlanarWorld(world_file);
  if (!world) throw std::runtime_error(world.status().message());
  // Appearance change between runs: the walls' texture variants (planar_world.h).
  const int variant = readParameter(p, "appearance_variant", 0);
  auto appearance = world->withAppearance(variant);
  if (!appearance) {
    throw std::runtime_error("parameter '" + p.resolveName("appearance_variant") + "': " + appearance.status().message());
  }
  world_ = std::move(*appearance);
  // Things moved in after the teach run, and people walking by (docs/simulator.md).
  if (readParameter(p, "clutter", false)) world_ = world_.withClutter();
  world_.clutter.clear();
  if (!readParameter(p, "people", false)) world_.people.clear();
  // People stand rather than walk into the robot or step into its path (Crowd).
  const double yield_distance = readParameter(p, "people_yield_distance", 1.0);
  const double yield_width = readParameter(p, "people_yield_width", 0.55);
  if (!std::isfinite(yield_distance) || yield_distance < 0.0 || !std::isfinite(yield_width) || yield_width < 0.0) {
    throw std::runtime_error("parameters '" + p.resolveName("people_yield_distance") + "' and '" +
                             p.resolveName("people_yield_width") + "' must be >= 0");
  }
  const double yield_patience = readParameter(p, "people_yield_patience", 3.0);
  if (!(yield_patience > 0.0)) {  // NaN too; +inf: never turn back
    throw std::runtime_error("parameter '" + p.resolveName("people_yield_patience") + "' must be > 0");
  }
  if (!world_.people.empty()) crowd_.emplace(world_.people, CrowdOptions{yield_distance, yield_width, yield_patience});

  physics_rate_ = readParameter(p, "physics_rate", physics_rate_);
  camera_rate_ = readParameter(p, "camera_rate", camera_rate_);
  scan_rate_ = readParameter(p, "scan_rate", scan_rate_);
  real_time_factor_ = readParameter(p, "real_time_factor", real_time_factor_);
  cmd_vel_timeout_ = readParameter(p, "cmd_vel_timeout", cmd_vel_timeout_);
  camera_mount_x_ = readParameter(p, "camera_mount_x", camera_mount_x_);
  start_time_ = readParameter(p, "start_time", start_time_);
  odometry_rate_ = readParameter(p, "odometry_rate", odometry_rate_);
  odometry_jitter_ = readParameter(p, "odometry_jitter", odometry_jitter_);
  if (!std::isfinite(odometry_jitter_) || odometry_jitter_ < 0.0 || odometry_jitter_ > 0.5) {
    throw std::runtime_error("parameter '" + p.resolveName("odometry_jitter") + "' must be in [0, 0.5] s");
  }
  for (const auto& [name, value] : {std::pair<const char*, double>{"physics_rate", physics_rate_},
                                    {"camera_rate", camera_rate_},
                                    {"scan_rate", scan_rate_},
                                    {"odometry_rate", odometry_rate_},
                                    {"real_time_factor", real_time_factor_},
                                    {"cmd_vel_timeout", cmd_vel_timeout_},
                                    {"start_time", start_time_}}) {
    requirePositive(p, name, value);
  }
  if (camera_rate_ > physics_rate_ || scan_rate_ > physics_rate_ || odometry_rate_ > physics_rate_) {
    throw std::runtime_error("parameters camera_rate, scan_rate and odometry_rate must not exceed physics_rate");
  }
  odom_frame_ = readParameter<std::string>(p, "odom_frame", "odom");
  base_frame_ = readParameter<std::string>(p, "base_frame", "base_link");
  camera_frame_ = readParameter<std::string>(p, "camera_frame", "camera_optical_frame");
  world_frame_ = readParameter<std::string>(p, "world_frame", "world");
  ground_truth_prefix_ = readParameter<std::string>(p, "ground_truth_prefix", "ground_truth");

  CameraCalibration calibration;
  calibration.width = readParameter(p, "image_width", 640);
  calibration.height = readParameter(p, "image_height", 480);
  calibration.fx = readParameter(p, "fx", 500.0);
  calibration.fy = readParameter(p, "fy", 500.0);
  calibration.cx = readParameter(p, "cx", (calibration.width - 1) / 2.0);
  calibration.cy = readParameter(p, "cy", (calibration.height - 1) / 2.0);
  calibration.distortion_model = readParameter<std::string>(p, "distortion_model", "plumb_bob");
  calibration.distortion = readParameter<std::vector<double>>(p, "distortion", {0.0, 0.0, 0.0, 0.0, 0.0});
  RenderOptions render;
  render.camera_height = readParameter(p, "camera_height", render.camera_height);
  render.noise_sigma = readParameter(p, "image_noise_sigma", render.noise_sigma);
  render.blur_sigma = readParameter(p, "image_blur_sigma", render.blur_sigma);
  render.supersampling = readParameter(p, "image_supersampling", render.supersampling);
  render.texture_filtering = readParameter(p, "image_texture_filtering", render.texture_filtering);
  if (render.texture_filtering && render.supersampling > 1) {
    // Both band-limit the image; config/planar_world_sim.yaml turns the filtering on.
    throw std::runtime_error("parameter '" + p.resolveName("image_supersampling") + "' > 1 supersamples the image in place of '" +
                             p.resolveName("image_texture_filtering") + "': set that false to supersample");
  }
  render.camera_pitch = readParameter(p, "camera_pitch", render.camera_pitch);
  render.camera_roll = readParameter(p, "camera_roll", render.camera_roll);
  render.exposure_time = readParameter(p, "exposure_time", render.exposure_time);
  render.lamp_contrast = readParameter(p, "lamp_contrast", render.lamp_contrast);
  render.lamp_spacing = readParameter(p, "lamp_spacing", render.lamp_spacing);
  camera_height_ = render.camera_height;
  light_level_ = readParameter(p, "light_level", light_level_);
  if (!std::isfinite(light_level_) || !(light_level_ > 0.0) || light_level_ > 3.0) {
    throw std::runtime_error("parameter '" + p.resolveName("light_level") + "' must be in (0, 3]");
  }
  const std::vector<double> latency = readParameter<std::vector<double>>(p, "image_latency", {0.0, 0.0});
  if (latency.size() != 2 || !std::isfinite(latency[0]) || !std::isfinite(latency[1]) || latency[0] < 0.0 ||
      latency[1] < latency[0] || latency[1] > 2.0) {
    throw std::runtime_error("parameter '" + p.resolveName("image_latency") +
                             "' must be [min, max] seconds with 0 <= min <= max <= 2");
  }
  latency_min_ = latency[0];
  latency_max_ = latency[1];
  drop_probability_ = readParameter(p, "image_drop_probability", drop_probability_);
  if (!std::isfinite(drop_probability_) || drop_probability_ < 0.0 || drop_probability_ >= 1.0) {
    throw std::runtime_error("parameter '" + p.resolveName("image_drop_probability") + "' must be in [0, 1)");
  }

  OdometryErrorModel errors;
  errors.scale_error = readParameter(p, "odometry_scale_error", errors.scale_error);
  errors.heading_bias_per_metre = readParameter(p, "odometry_heading_bias_per_metre", errors.heading_bias_per_metre);
  errors.distance_noise = readParameter(p, "odometry_distance_noise", errors.distance_noise);
  errors.heading_noise = readParameter(p, "odometry_heading_noise", errors.heading_noise);
  odometry_errors_ = errors;
  odometry_variance_floor_ = readParameter(p, "odometry_variance_floor", odometry_variance_floor_);
  if (!std::isfinite(odometry_variance_floor_) || !(odometry_variance_floor_ > 0.0)) {
    throw std::runtime_error("parameter '" + p.resolveName("odometry_variance_floor") + "' must be > 0");
  }
  DriveLimits limits;
  limits.max_linear_velocity = readParameter(p, "max_linear_velocity", limits.max_linear_velocity);
  limits.max_angular_velocity = readParameter(p, "max_angular_velocity", limits.max_angular_velocity);
  const std::vector<double> start = readParameter<std::vector<double>>(p, "start_pose", {0.0, 0.0, 0.0});
  if (start.size() != 3) throw std::runtime_error("parameter '" + p.resolveName("start_pose") + "' must be [x, y, yaw]");
  scan_count_ = readParameter(p, "scan_count", 181);
  scan_angle_min_ = readParameter(p, "scan_angle_min", scan_angle_min_);
  scan_angle_max_ = readParameter(p, "scan_angle_max", scan_angle_max_);
  scan_range_max_ = readParameter(p, "scan_range_max", scan_range_max_);
  rng_ = cv::RNG(static_cast<std::uint64_t>(readParameter(p, "seed", 1)));
  kidnap_time_ = readParameter(p, "kidnap_time", kidnap_time_);
  const std::vector<double> kidnap = readParameter<std::vector<double>>(p, "kidnap_offset", {0.0, 0.0, 0.0});
  if (kidnap.size() != 3 || !std::isfinite(kidnap[0]) || !std::isfinite(kidnap[1]) || !std::isfinite(kidnap[2]) ||
      !std::isfinite(kidnap_time_)) {
    throw std::runtime_error("parameter '" + p.resolveName("kidnap_offset") +
                             "' must be [dx, dy, dyaw] (finite), and '" + p.resolveName("kidnap_time") + "' finite");
  }
  kidnap_offset_ = Pose2D(kidnap[0], kidnap[1], kidnap[2]);
  readParameters(p, [&] {
    renderer_.emplace(PinholeCamera(calibration), render);
    robot_.emplace(Pose2D(start[0], start[1], start[2]), errors, limits,
                   static_cast<std::uint64_t>(readParameter(p, "seed", 1)) + 1);
  });
  // The camera's calibration as camera_info carries it (the same for every frame).
  const PinholeCamera& camera = renderer_->camera();
  camera_info_.width = static_cast<uint32_t>(camera.width());
  camera_info_.height = static_cast<uint32_t>(camera.height());
  camera_info_.distortion_model =
      camera.distortionModel() == DistortionModel::kNone ? "plumb_bob" : toString(camera.distortionModel());
  camera_info_.D = camera.distortionCoefficients();
  if (camera_info_.D.empty()) camera_info_.D = {0.0, 0.0, 0.0, 0.0, 0.0};
  camera_info_.K = {camera.fx(), 0.0, camera.cx(), 0.0, camera.fy(), camera.cy(), 0.0, 0.0, 1.0};
  camera_info_.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  camera_info_.P = {camera.fx(), 0.0, camera.cx(), 0.0, 0.0, camera.fy(), camera.cy(), 0.0, 0.0, 0.0, 1.0, 0.0};
  if (scan_count_ < 0 || !(scan_range_max_ > 0.0) || !(scan_angle_max_ >= scan_angle_min_)) {
    throw std::runtime_error("invalid scan parameters in " + p.getNamespace());
  }

  command_subscriber_ = nh_.subscribe("cmd_vel", 1, &PlanarWorldSim::onCommand, this);
  camera_publisher_ = image_transport_.advertiseCamera("camera/image_raw", 2);
  odometry_publisher_ = nh_.advertise<nav_msgs::Odometry>("odom", 20);
  ground_truth_publisher_ = nh_.advertise<nav_msgs::Odometry>("ground_truth", 20);
  if (scan_count_ > 0) scan_publisher_ = nh_.advertise<sensor_msgs::LaserScan>("scan", 2);
  clock_publisher_ = nh_.advertise<rosgraph_msgs::Clock>("/clock", 10);
  if (!world_.people.empty()) people_publisher_ = nh_.advertise<visualization_msgs::MarkerArray>("people", 2);

  // The camera mount: optical z forward (base x), optical x right (-base y), optical y down.
  geometry_msgs::TransformStamped mount;
  mount.header.stamp = ros::Time(start_time_);
  mount.header.frame_id = base_frame_;
  mount.child_frame_id = camera_frame_;
  mount.transform.translation.x = camera_mount_x_;
  mount.transform.translation.z = camera_height_;
  // Level unless camera_pitch / camera_roll tilt it (a calibrated mount: the tf states the tilt).
  const Eigen::Matrix3d r = renderer_->opticalToBase();
  tf2::Quaternion q;
  tf2::Matrix3x3(r(0, 0), r(0, 1), r(0, 2), r(1, 0), r(1, 1), r(1, 2), r(2, 0), r(2, 1), r(2, 2)).getRotation(q);
  mount.transform.rotation.x = q.x();
  mount.transform.rotation.y = q.y();
  mount.transform.rotation.z = q.z();
  mount.transform.rotation.w = q.w();
  static_broadcaster_.sendTransform(mount);
  if (!world_.people.empty()) ROS_INFO("planar_world_sim: %zu people walking", world_.people.size());
  ROS_INFO("planar_world_sim: world '%s' (%zu walls), camera %dx%d f=%.0f at %.0f Hz, %.1fx real time",
           world_file.c_str(), world_.walls.size(), calibration.width, calibration.height, calibration.fx,
           camera_rate_, real_time_factor_);
}

PlanarWorldSim::~PlanarWorldSim() = default;

void PlanarWorldSim::onCommand(const geometry_msgs::TwistConstPtr& command) {
  std::lock_guard<std::mutex> lock(command_mutex_);
  command_v_ = command->linear.x;
  command_w_ = command->angular.z;
  command_stamp_ = sim_seconds_.load();  // simulated time, whatever use_sim_time says
}

void PlanarWorldSim::run() {
  const double dt = 1.0 / physics_rate_;
  const int camera_every = std::max(1, static_cast<int>(std::lround(physics_rate_ / camera_rate_)));
  const int scan_every = std::max(1, static_cast<int>(std::lround(physics_rate_ / scan_rate_)));
  const int odometry_every = std::max(1, static_cast<int>(std::lround(physics_rate_ / odometry_rate_)));
  double sim_seconds = start_time_;
  sim_seconds_.store(sim_seconds);
  long step = 0;
  ros::WallTime due = ros::WallTime::now();
  while (ros::ok()) {
    const ros::Time stamp(sim_seconds);
    rosgraph_msgs::Clock clock;
    clock.clock = stamp;
    clock_publisher_.publish(clock);
    if (step % odometry_every == 0) publishState(stamp);
    if (step % camera_every == 0) publishCamera(stamp, sim_seconds);
    deliverOdometry(sim_seconds);
    deliverImages(sim_seconds);
    if (scan_count_ > 0 && step % scan_every == 0) publishScan(stamp);
    if (crowd_ && step % camera_every == 0) publishPeople(stamp);
    double v = 0.0, w = 0.0;
    {
      std::lock_guard<std::mutex> lock(command_mutex_);
      if (command_stamp_ > 0.0 && sim_seconds - command_stamp_ <= cmd_vel_timeout_) {
        v = command_v_;
        w = command_w_;
      }
    }
    robot_->step(v, w, dt);
    if (crowd_) crowd_->advance(sim_seconds, dt, robot_->truth());
    if (kidnap_time_ > 0.0 && !kidnapped_ && sim_seconds >= kidnap_time_) {
      kidnapped_ = true;
      robot_->teleport(robot_->truth().compose(kidnap_offset_));
      ROS_WARN("planar_world_sim: kidnapped: the robot moved by (%.2f m, %.2f m, %.2f rad) without its odometry noticing",
               kidnap_offset_.x, kidnap_offset_.y, kidnap_offset_.yaw);
    }
    sim_seconds += dt;
    sim_seconds_.store(sim_seconds);
    ++step;
    // Pace: sim time runs real_time_factor times faster than wall time. The steps after a late
    // one (a camera frame takes longer to render than a physics step) run without pause until the
    // clock is on time again, but never to make up more than kMaxCatchUpSeconds: a longer delay
    // (the machine busy) made up at once is a burst of sim time that reaches the other nodes as a
    // gap (repeat_node saw 3.1 s of sim time in 1.5 s of wall time after a busy start and reported
    // "camera stopped"); beyond it the clock slows down, as a real-time simulator that cannot keep
    // up does. (Without any catching up the closed-loop rostests ran 1.3-1.7 times as long.)
    constexpr double kMaxCatchUpSeconds = 0.2;
    const ros::WallTime now = ros::WallTime::now();
    due = std::max(due + ros::WallDuration(dt / real_time_factor_), now - ros::WallDuration(kMaxCatchUpSeconds));
    if (due > now) (due - now).sleep();
  }
}

void PlanarWorldSim::publishState(const ros::Time& stamp) {
  const Pose2D& odom = robot_->odometry();
  const Pose2D& truth = robot_->truth();
  // Velocities over the interval since the previous message (the first one: at rest).
  const StateSample previous = last_state_.value_or(StateSample{odom, truth, stamp});
  const double interval = (stamp - previous.stamp).toSec();
  const MeasuredVelocity odometry_velocity = velocityFromOdometry(previous.odometry, odom, interval, odometry_errors_);
  const MeasuredVelocity truth_velocity = velocityFromOdometry(previous.truth, truth, interval, OdometryErrorModel());
  truth_yaw_rate_ = truth_velocity.w;
  last_state_ = StateSample{odom, truth, stamp};
  // Odometry is delivered after its jitter (tf with it); the ground truth at once.
  const double jitter = odometry_jitter_ > 0.0 ? rng_.uniform(0.0, odometry_jitter_) : 0.0;
  pending_odometry_.push_back(
      PendingOdometry{stamp.toSec() + jitter,
                      odometryMessage(odom, robot_->odometryCovariance(), odometry_velocity, stamp, odom_frame_,
                                      base_frame_, odometry_variance_floor_, kUnobservedVariance),
                      transformMessage(odom, 0.0, stamp, odom_frame_, base_frame_)});
  ground_truth_publisher_.publish(odometryMessage(truth, Eigen::Matrix3d::Zero(), truth_velocity, stamp, world_frame_,
                                                  base_frame_, odometry_variance_floor_, kUnobservedVariance));
  tf_broadcaster_.sendTransform(
      transformMessage(truth, 0.0, stamp, world_frame_, ground_truth_prefix_ + "/" + base_frame_));
}

void PlanarWorldSim::deliverOdometry(double sim_seconds) {
  // In stamp order, as a base driver publishes (a late message holds back the ones after it).
  while (!pending_odometry_.empty() && pending_odometry_.front().deliver_at <= sim_seconds + 1e-9) {
    odometry_publisher_.publish(pending_odometry_.front().message);
    tf_broadcaster_.sendTransform(pending_odometry_.front().transform);
    pending_odometry_.pop_front();
  }
}

PlanarWorld PlanarWorldSim::scene() const { return crowd_ ? world_.withPeople(crowd_->poses()) : world_; }

void PlanarWorldSim::publishPeople(const ros::Time& stamp) {
  visualization_msgs::MarkerArray markers;
  const std::vector<Pose2D> poses = crowd_->poses();
  for (std::size_t i = 0; i < world_.people.size(); ++i) {
    const Person& person = world_.people[i];
    const Pose2D& pose = poses[i];
    visualization_msgs::Marker m;
    m.header.stamp = stamp;
    m.header.frame_id = world_frame_;
    m.ns = "people";
    m.id = static_cast<int>(i);
    m.type = visualization_msgs::Marker::CUBE;
    m.action = visualization_msgs::Marker::ADD;
    m.pose.position.x = pose.x;
    m.pose.position.y = pose.y;
    m.pose.position.z = 0.5 * person.surface.height;
    m.pose.orientation = ros_conversions::yawQuaternion(pose.yaw);
    m.scale.x = person.depth;
    m.scale.y = person.width;
    m.scale.z = person.surface.height;
    m.color.r = 0.9f;
    m.color.g = 0.4f;
    m.color.b = 0.1f;
    m.color.a = 0.8f;
    m.text = person.name;
    markers.markers.push_back(m);
  }
  people_publisher_.publish(markers);
}

void PlanarWorldSim::publishCamera(const ros::Time& stamp, double sim_seconds) {
  if (camera_publisher_.getNumSubscribers() == 0) return;
  // A dropped frame is never delivered: not rendered either.
  if (drop_probability_ > 0.0 && rng_.uniform(0.0, 1.0) < drop_probability_) return;
  const Pose2D camera_pose = robot_->truth().compose(Pose2D(camera_mount_x_, 0.0, 0.0));
  cv::Mat image;
  if (world_.cameraCoveredAt(Eigen::Vector2d(robot_->truth().x, robot_->truth().y))) {
    // Something over the lens: a dark, slightly noisy frame (a camera still delivers images).
    image = cv::Mat(renderer_->camera().height(), renderer_->camera().width(), CV_8UC3, cv::Scalar(25, 25, 25));
    cv::Mat noise(image.size(), CV_8UC3);
    rng_.fill(noise, cv::RNG::UNIFORM, 0, 4);
    image += noise;
  } else {
    image = renderer_->render(scene(), camera_pose, light_level_ * world_.illumination.gainAt(sim_seconds), rng_,
                              truth_yaw_rate_);
  }
  std_msgs::Header header;
  header.stamp = stamp;
  header.frame_id = camera_frame_;
  sensor_msgs::CameraInfo info = camera_info_;
  info.header = header;
  // Stamped when taken; delivered after the latency.
  const double latency = latency_max_ > latency_min_ ? rng_.uniform(latency_min_, latency_max_) : latency_min_;
  pending_images_.push_back(
      PendingImage{sim_seconds + latency, cv_bridge::CvImage(header, "bgr8", image).toImageMsg(), info});
}

void PlanarWorldSim::deliverImages(double sim_seconds) {
  // Latencies are drawn per image, so a later image may be due first; deliver in stamp order
  // as a camera driver does (it never reorders), each once its own time has come.
  while (!pending_images_.empty() && pending_images_.front().deliver_at <= sim_seconds + 1e-9) {
    camera_publisher_.publish(*pending_images_.front().image, pending_images_.front().info);
    pending_images_.pop_front();
  }
}

void PlanarWorldSim::publishScan(const ros::Time& stamp) {
  sensor_msgs::LaserScan scan;
  scan.header.stamp = stamp;
  scan.header.frame_id = base_frame_;
  scan.angle_min = static_cast<float>(scan_angle_min_);
  scan.angle_max = static_cast<float>(scan_angle_max_);
  scan.angle_increment =
      scan_count_ > 1 ? static_cast<float>((scan_angle_max_ - scan_angle_min_) / (scan_count_ - 1)) : 0.0f;
  scan.range_min = 0.05f;
  scan.range_max = static_cast<float>(scan_range_max_);
  scan.ranges = castScan(scene(), robot_->truth(), scan_angle_min_, scan_angle_max_, scan_count_, scan_range_max_);
  scan_publisher_.publish(scan);
}

}  // namespace homography_teach_repeat
