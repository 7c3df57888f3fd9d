#include "homography_teach_repeat/mu/heading_aided_odometry.h"

#include <Eigen/Dense>

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "homography_teach_repeat/mu/heading_1d.h"

namespace homography_teach_repeat {
namespace {

void requireNonNegative(double value, const char* name) {
  if (!std::isfinite(value) || value < 0.0) {
    throw std::invalid_argument(std::string("heading-aided odometry: ") + name + " must be finite and >= 0");
  }
}

void requirePositive(double value, const char* name) {
  if (!std::isfinite(value) || !(value > 0.0)) {
    throw std::invalid_argument(std::string("heading-aided odometry: ") + name + " must be finite and > 0");
  }
}

// ∂f/∂(x, y, yaw) of a scalar function of the robot pose by central differences (1e-5 m, 1e-6 rad):
// the measurement models are smooth and six evaluations cost microseconds.
template <typename Measurement>
Expected<Eigen::RowVector3d> poseJacobian(const Pose2D& at, const Measurement& measure) {
  Eigen::RowVector3d jacobian;
  const double steps[3] = {1e-5, 1e-5, 1e-6};
  for (int i = 0; i < 3; ++i) {
    Pose2D plus = at, minus = at;
    (i == 0 ? plus.x : i == 1 ? plus.y : plus.yaw) += steps[i];
    (i == 0 ? minus.x : i == 1 ? minus.y : minus.yaw) -= steps[i];
    const Expected<double> value_plus = measure(plus), value_minus = measure(minus);
    if (!value_plus) return value_plus.status();
    if (!value_minus) return value_minus.status();
    jacobian(i) = (*value_plus - *value_minus) / (2.0 * steps[i]);
  }
  return jacobian;
}

// μ a camera at base pose `base` (route frame) measures against the observation's reference.
Expected<double> muAt(const MuObservation& observation, const Pose2D& base) {
  const auto H = wallHomography1dAt(observation, base);
  if (!H) return H.status();
  return (*H)(0, 1) / (*H)(1, 1);
}

}  // namespace

std::optional<MuObservation> muWallOf(const Pose2D& reference_pose, const std::optional<ScenePlane>& plane,
                                      const Pose2D& camera_mount, double focal_px, int reference_id) {
  if (!plane) return std::nullopt;
  const Eigen::Vector2d normal(plane->normal.x(), plane->normal.z());
  if (!(normal.norm() > 0.5) || !(plane->distance > 0.0)) return std::nullopt;
  MuObservation wall;
  wall.reference_pose = reference_pose;
  // The wall's line in the (x, z) plane: n·X = d with the unit horizontal part of n.
  wall.wall_normal = normal.normalized();
  wall.wall_distance = plane->distance / normal.norm();
  wall.camera_mount = camera_mount;
  wall.focal_px = focal_px;
  wall.reference_id = reference_id;
  return wall;
}

Expected<Eigen::Matrix2d> wallHomography1dAt(const MuObservation& wall, const Pose2D& base) {
  const CameraMount mount(wall.camera_mount.x, wall.camera_mount.y, wall.camera_mount.yaw);
  const PlanarPose camera = mount.baseToCamera(wall.reference_pose.inverse().compose(base));
  return planeHomography1d(camera, wall.wall_normal, wall.wall_distance, wall.focal_px);
}

void HeadingAidedOdometryOptions::validate() const {
  requireNonNegative(initial_position_variance, "initial_position_variance");
  requireNonNegative(position_variance_per_metre, "position_variance_per_metre");
  requirePositive(heading_fix_variance, "heading_fix_variance");
  requireNonNegative(heading_variance_per_metre, "heading_variance_per_metre");
  requireNonNegative(heading_variance_per_radian, "heading_variance_per_radian");
  requireNonNegative(position_variance_per_radian, "position_variance_per_radian");
  requirePositive(pose_innovation_gate, "pose_innovation_gate");
  if (!(pose_common_fraction >= 0.0 && pose_common_fraction <= 1.0)) {
    throw std::invalid_argument("heading-aided odometry: pose_common_fraction must be in [0, 1]");
  }
  requirePositive(min_mu_variance, "min_mu_variance");
  requirePositive(innovation_gate, "innovation_gate");
  if (refused_before_reset < 1) {
    throw std::invalid_argument("heading-aided odometry: refused_before_reset must be >= 1");
  }
  requirePositive(max_mu_step_px, "max_mu_step_px");
  requirePositive(max_confirmation_distance, "max_confirmation_distance");
  requireNonNegative(reset_position_variance, "reset_position_variance");
  requireNonNegative(reset_heading_variance, "reset_heading_variance");
  requirePositive(line_sigma_px, "line_sigma_px");
  if (min_landmark_lines < 2) throw std::invalid_argument("heading-aided odometry: min_landmark_lines must be >= 2");
  requirePositive(line_inlier_gate, "line_inlier_gate");
  requireNonNegative(line_heading_sigma_rad, "line_heading_sigma_rad");
  requireNonNegative(line_position_sigma_m, "line_position_sigma_m");
  requirePositive(line_max_brightness_difference, "line_max_brightness_difference");
}

HeadingAidedOdometry::HeadingAidedOdometry(const HeadingAidedOdometryOptions& options) : options_(options) {
  options_.validate();
}

Status HeadingAidedOdometry::align(const Pose2D& route_pose, const Pose2D& odom_pose) {
  if (!route_pose.isFinite() || !odom_pose.isFinite()) {
    return Status(StatusCode::kInvalidInput, "heading-aided odometry: non-finite alignment pose");
  }
  estimate_ = Pose2D(route_pose.x, route_pose.y, wrapToPi(route_pose.yaw));
  covariance_ = Eigen::Vector3d(options_.initial_position_variance, options_.initial_position_variance,
                                options_.heading_fix_variance)
                    .asDiagonal();
  last_odom_ = odom_pose;
  previous_mu_.reset();
  aligned_ = true;
  distance_since_fix_ = 0.0;
  refused_in_a_row_ = 0;
  return Status::ok();
}

Status HeadingAidedOdometry::align(const Pose2D& route_pose, const Pose2D& odom_pose,
                                   const Eigen::Matrix3d& covariance) {
  if (!covariance.allFinite() || !covariance.isApprox(covariance.transpose(), 1e-9) ||
      Eigen::LLT<Eigen::Matrix3d>(covariance).info() != Eigen::Success) {
    return Status(StatusCode::kInvalidInput, "heading-aided odometry: alignment covariance not symmetric positive definite");
  }
  Status aligned = align(route_pose, odom_pose);
  if (!aligned.isOk()) return aligned;
  covariance_ = covariance;
  return Status::ok();
}

Pose2D HeadingAidedOdometry::alignment() const { return estimate_.compose(last_odom_.inverse()); }

Expected<Pose2D> HeadingAidedOdometry::odometryStepTo(const Pose2D& odom_pose) const {
  if (!odom_pose.isFinite()) return Status(StatusCode::kInvalidInput, "heading-aided odometry: non-finite odometry");
  if (!aligned_) return Status(StatusCode::kNoConsensus, "heading-aided odometry: not aligned yet");
  return last_odom_.inverse().compose(odom_pose);
}

Status HeadingAidedOdometry::predict(const Pose2D& odom_pose) {
  const auto odometry_step = odometryStepTo(odom_pose);
  if (!odometry_step) return odometry_step.status();
  const Pose2D& step = *odometry_step;
  const double c = std::cos(estimate_.yaw), s = std::sin(estimate_.yaw);
  Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
  F(0, 2) = -s * step.x - c * step.y;
  F(1, 2) = c * step.x - s * step.y;
  const double distance = std::hypot(step.x, step.y);
  const double turned = std::abs(wrapToPi(step.yaw));
  // Position noise is isotropic in the body frame, so it needs no rotation into the route frame.
  const double position_variance =
      options_.position_variance_per_metre * distance + options_.position_variance_per_radian * turned;
  const Eigen::Vector3d process(position_variance, position_variance,
                                options_.heading_variance_per_metre * distance +
                                    options_.heading_variance_per_radian * turned);
  covariance_ = F * covariance_ * F.transpose() + Eigen::Matrix3d(process.asDiagonal());
  estimate_ = estimate_.compose(step);
  estimate_.yaw = wrapToPi(estimate_.yaw);
  last_odom_ = odom_pose;
  distance_since_fix_ += distance;
  return Status::ok();
}

Status HeadingAidedOdometry::update(double innovation, const Eigen::RowVector3d& jacobian, double variance,
                                    const char* what) {
  double innovation_variance = (jacobian * covariance_ * jacobian.transpose())(0, 0) + variance;
  const double nis = innovation * innovation / innovation_variance;
  last_innovation_ = FilterInnovation{nis, 1, false};
  if (nis > options_.innovation_gate * options_.innovation_gate) {
    if (!countRefusal()) {
      char message[200];
      std::snprintf(message, sizeof(message),
                    "heading-aided odometry: %s refused, %.3g from the prediction (%.1f sigma > %.1f)", what,
                    innovation, std::abs(innovation) / std::sqrt(innovation_variance), options_.innovation_gate);
      return Status(StatusCode::kNoConsensus, message);
    }
    innovation_variance = (jacobian * covariance_ * jacobian.transpose())(0, 0) + variance;
  }
  refused_in_a_row_ = 0;
  last_innovation_->accepted = true;
  const Eigen::Vector3d gain = covariance_ * jacobian.transpose() / innovation_variance;
  estimate_.x += gain(0) * innovation;
  estimate_.y += gain(1) * innovation;
  estimate_.yaw = wrapToPi(estimate_.yaw + gain(2) * innovation);
  // Joseph form: stays symmetric positive semi-definite.
  const Eigen::Matrix3d keep = Eigen::Matrix3d::Identity() - gain * jacobian;
  covariance_ = keep * covariance_ * keep.transpose() + gain * variance * gain.transpose();
  distance_since_fix_ = 0.0;
  return Status::ok();
}

Expected<double> HeadingAidedOdometry::correctWithPose(const Pose2D& measured, const Eigen::Matrix3d& measurement_covariance,
                                                       const Pose2D& odom_pose, const Eigen::Matrix3d& shared_covariance) {
  if (!shared_covariance.allFinite()) {
    return Status(StatusCode::kInvalidInput, "heading-aided odometry: the pose fix's shared covariance is not finite");
  }
  if (!measured.isFinite() || !measurement_covariance.allFinite() ||
      !measurement_covariance.isApprox(measurement_covariance.transpose(), 1e-9) ||
      Eigen::LLT<Eigen::Matrix3d>(measurement_covariance).info() != Eigen::Success) {
    return Status(StatusCode::kInvalidInput,
                  "heading-aided odometry: pose fix not finite or its covariance not symmetric positive definite");
  }
  Status predicted_to_fix = predict(odom_pose);
  if (!predicted_to_fix.isOk()) return predicted_to_fix;
  // H = I: the innovation is the pose difference (yaw wrapped), S = P + R (docs/math.md §7.1).
  const Eigen::Vector3d innovation(measured.x - estimate_.x, measured.y - estimate_.y,
                                   wrapToPi(measured.yaw - estimate_.yaw));
  Eigen::Matrix3d S = covariance_ + measurement_covariance;
  Eigen::LDLT<Eigen::Matrix3d> S_ldlt(S);
  const double nis = innovation.dot(S_ldlt.solve(innovation));
  last_innovation_ = FilterInnovation{nis, 3, false};
  if (!(nis <= options_.pose_innovation_gate)) {
    if (!countRefusal()) {
      char message[200];
      std::snprintf(message, sizeof(message),
                    "heading-aided odometry: pose fix refused, %.2f m / %.2f deg from the prediction (NIS %.1f > "
                    "pose_innovation_gate %.1f)",
                    std::hypot(innovation(0), innovation(1)), innovation(2) * 180.0 / M_PI, nis,
                    options_.pose_innovation_gate);
      return Status(StatusCode::kNoConsensus, message);
    }
    S = covariance_ + measurement_covariance;  // widened: the fix is taken
    S_ldlt.compute(S);
  }
  const Eigen::Matrix3d gain = covariance_ * S_ldlt.solve(Eigen::Matrix3d::Identity());
  const Eigen::Vector3d correction = gain * innovation;
  if (!correction.allFinite() || !std::isfinite(nis)) {
    return Status(StatusCode::kNotFinite, "heading-aided odometry: the pose update is not finite");
  }
  estimate_ = Pose2D(estimate_.x + correction(0), estimate_.y + correction(1), wrapToPi(estimate_.yaw + correction(2)));
  const Eigen::Matrix3d keep = Eigen::Matrix3d::Identity() - gain;
  covariance_ = keep * covariance_ * keep.transpose() + gain * measurement_covariance * gain.transpose();
  // The error shared by repeated fixes: the covariance is kept at least the fix's shared part, its
  // model covariance and pose_common_fraction of the rest (the positive part of the difference is
  // added: P ⪰ R_shared + c (R − R_shared) afterwards).
  const Eigen::Matrix3d shared =
      shared_covariance + options_.pose_common_fraction * (measurement_covariance - shared_covariance);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> lacking(shared - covariance_);
  covariance_ += lacking.eigenvectors() * lacking.eigenvalues().cwiseMax(0.0).asDiagonal() *
                 lacking.eigenvectors().transpose();
  covariance_ = 0.5 * (covariance_ + covariance_.transpose());
  refused_in_a_row_ = 0;
  distance_since_fix_ = 0.0;
  last_innovation_ = FilterInnovation{nis, 3, true};
  return nis;
}

bool HeadingAidedOdometry::countRefusal() {
  if (++refused_in_a_row_ < options_.refused_before_reset) return false;
  // Lasting disagreement: the estimate is the wrong one (e.g. a long outage with more drift than
  // modelled). Widen it so the measurements take over.
  covariance_ += Eigen::Vector3d(options_.reset_position_variance, options_.reset_position_variance,
                                 options_.reset_heading_variance)
                     .asDiagonal();
  refused_in_a_row_ = 0;
  return true;
}

Status HeadingAidedOdometry::correctWithMu(const MuObservation& observation, const Pose2D& odom_pose) {
  if (!std::isfinite(observation.mu) || !std::isfinite(observation.variance) || !observation.reference_pose.isFinite() ||
      !observation.camera_mount.isFinite()) {
    return Status(StatusCode::kInvalidInput, "heading-aided odometry: non-finite mu observation");
  }
  Status predicted_to_fix = predict(odom_pose);
  if (!predicted_to_fix.isOk()) return predicted_to_fix;
  const auto predicted = muAt(observation, estimate_);
  if (!predicted) return predicted.status();
  // Confirmation by the previous frame: the measured change of μ against the change the
  // prediction gives between the two robot poses (the previous one: the current prediction moved
  // back by the odometry between them).
  const std::optional<PreviousMu> previous = previous_mu_;
  previous_mu_ = PreviousMu{observation.reference_id, observation.mu, odom_pose};
  const Pose2D back = odom_pose.inverse().compose(previous ? previous->odom : odom_pose);
  if (!previous || previous->reference_id != observation.reference_id ||
      std::hypot(back.x, back.y) > options_.max_confirmation_distance) {
    return Status(StatusCode::kNoConsensus, "heading-aided odometry: mu fix waits for the next frame's confirmation");
  }
  const auto predicted_previous = muAt(observation, estimate_.compose(back));
  if (!predicted_previous) return predicted_previous.status();
  const double step_error = (observation.mu - previous->mu) - (*predicted - *predicted_previous);
  if (std::abs(step_error) > options_.max_mu_step_px) {
    char message[160];
    std::snprintf(message, sizeof(message),
                  "heading-aided odometry: mu changed %.1f px more than odometry predicts since the previous "
                  "frame (max_mu_step_px %.1f): a wrong line association in one of them",
                  step_error, options_.max_mu_step_px);
    return Status(StatusCode::kNoConsensus, message);
  }
  // ∂μ/∂(x, y, yaw) (only for a confirmed fix).
  const auto jacobian = poseJacobian(estimate_, [&](const Pose2D& pose) { return muAt(observation, pose); });
  if (!jacobian) return jacobian.status();
  return update(observation.mu - *predicted, *jacobian, std::max(observation.variance, options_.min_mu_variance),
                "mu fix");
}

namespace {

// A landmark's projection at a robot pose, with what the update needs of it.
struct ProjectedLandmark {
  std::size_t landmark = 0;
  double x = 0.0;                  // predicted image x [px]
  Eigen::RowVector3d jacobian;     // ∂x/∂(x, y, yaw) of the robot
  double noise = 0.0;              // [px²]: the line's x and the landmark's position
  double total = 0.0;              // [px²]: noise + the robot's whole covariance
  double without_heading = 0.0;    // [px²]: noise + the robot's position given its heading
};

class LineLandmarkModel {
 public:
  LineLandmarkModel(const LineLandmarkObservation& observation, double line_sigma_px)
      : observation_(observation),
        mount_(observation.camera_mount.x, observation.camera_mount.y, observation.camera_mount.yaw),
        line_variance_(line_sigma_px * line_sigma_px) {}

  Expected<double> project(const LineLandmark& landmark, const Pose2D& base) const {
    const PlanarPose camera = mount_.baseToCamera(observation_.reference_pose.inverse().compose(base));
    return projectLineLandmark(camera, landmark.position, observation_.lens);
  }

  // The landmark at `base`; nullopt when it is behind the camera or outside the image.
  std::optional<ProjectedLandmark> at(std::size_t index, const Pose2D& base, const Eigen::Matrix3d& covariance) const {
    const LineLandmark& landmark = observation_.landmarks[index];
    const auto x = project(landmark, base);
    if (!x || *x < 0.0 || *x >= observation_.image_width) return std::nullopt;
    ProjectedLandmark p;
    p.landmark = index;
    p.x = *x;
    const auto jacobian = poseJacobian(base, [&](const Pose2D& pose) { return project(landmark, pose); });
    if (!jacobian) return std::nullopt;
    p.jacobian = *jacobian;
    Eigen::RowVector2d landmark_jacobian;
    for (int i = 0; i < 2; ++i) {
      const double step = 1e-6 * std::max(1.0, landmark.position.norm());
      LineLandmark plus = landmark, minus = landmark;
      plus.position(i) += step;
      minus.position(i) -= step;
      const auto x_plus = project(plus, base), x_minus = project(minus, base);
      if (!x_plus || !x_minus) return std::nullopt;
      landmark_jacobian(i) = (*x_plus - *x_minus) / (2.0 * step);
    }
    p.noise = line_variance_ + (landmark_jacobian * landmark.covariance * landmark_jacobian.transpose())(0, 0);
    p.total = p.noise + (p.jacobian * covariance * p.jacobian.transpose())(0, 0);
    // The position's covariance given the heading (the consensus is over the heading).
    Eigen::Matrix3d given_heading = covariance;
    if (covariance(2, 2) > 0.0) {
      given_heading -= covariance.col(2) * covariance.row(2) / covariance(2, 2);
    }
    p.without_heading = p.noise + (p.jacobian * given_heading * p.jacobian.transpose())(0, 0);
    return p;
  }

 private:
  const LineLandmarkObservation& observation_;
  CameraMount mount_;
  double line_variance_;
};

struct LinePair {
  std::size_t projected = 0;  // into the projected landmarks
  std::size_t current = 0;    // into the current lines
  double heading = 0.0;       // the heading change that puts the landmark on this line [rad]
};

}  // namespace

Expected<int> HeadingAidedOdometry::correctWithLineLandmarks(const LineLandmarkObservation& observation,
                                                             const Pose2D& odom_pose) {
  if (!observation.reference_pose.isFinite() || !observation.camera_mount.isFinite() ||
      !std::isfinite(observation.image_width) || !observation.lens.validate().isOk()) {
    return Status(StatusCode::kInvalidInput, "heading-aided odometry: non-finite line landmark observation");
  }
  for (const LineLandmark& landmark : observation.landmarks) {
    if (landmark.line < 0 || landmark.line >= static_cast<int>(observation.reference_lines.size()) ||
        !landmark.position.allFinite() || !landmark.covariance.allFinite()) {
      return Status(StatusCode::kInvalidInput, "heading-aided odometry: a line landmark without its line or not finite");
    }
  }
  Status predicted_to_fix = predict(odom_pose);
  if (!predicted_to_fix.isOk()) return predicted_to_fix;
  previous_mu_.reset();
  const LineLandmarkModel model(observation, options_.line_sigma_px);
  const auto refuse = [&](const std::string& why) {
    countRefusal();
    return Status(StatusCode::kNoConsensus, "heading-aided odometry: line landmarks: " + why);
  };

  // Every landmark in view paired with the current lines that look like it within the gate.
  std::vector<ProjectedLandmark> projected;
  std::vector<LinePair> pairs;
  for (std::size_t i = 0; i < observation.landmarks.size(); ++i) {
    const auto p = model.at(i, estimate_, covariance_);
    if (!p || !(std::abs(p->jacobian(2)) > 1e-6)) continue;
    const VerticalLine& taught = observation.reference_lines[static_cast<std::size_t>(observation.landmarks[i].line)];
    const double window = options_.innovation_gate * std::sqrt(p->total);
    bool paired = false;
    for (std::size_t j = 0; j < observation.current_lines.size(); ++j) {
      const VerticalLine& line = observation.current_lines[j];
      if (!std::isfinite(line.x) || std::abs(line.x - p->x) > window ||
          !lineAppearanceAgrees(taught, line, options_.line_max_brightness_difference)) {
        continue;
      }
      pairs.push_back(LinePair{projected.size(), j, (line.x - p->x) / p->jacobian(2)});
      paired = true;
    }
    if (paired) projected.push_back(*p);
  }
  // The heading change most landmarks agree on (each landmark counted once).
  const auto agrees = [&](const LinePair& pair, double heading) {
    const ProjectedLandmark& p = projected[pair.projected];
    const double residual = observation.current_lines[pair.current].x - p.x - p.jacobian(2) * heading;
    return std::abs(residual) <= options_.line_inlier_gate * std::sqrt(p.without_heading);
  };
  const auto support = [&](double heading) {
    std::vector<char> counted(projected.size(), 0);
    int count = 0;
    for (const LinePair& pair : pairs) {
      if (!counted[pair.projected] && agrees(pair, heading)) {
        counted[pair.projected] = 1;
        ++count;
      }
    }
    return count;
  };
  std::vector<int> supports(pairs.size());
  int best = -1;
  for (std::size_t h = 0; h < pairs.size(); ++h) {
    supports[h] = support(pairs[h].heading);
    if (best < 0 || supports[h] > supports[static_cast<std::size_t>(best)]) best = static_cast<int>(h);
  }
  char message[200];
  if (best < 0 || supports[static_cast<std::size_t>(best)] < options_.min_landmark_lines) {
    std::snprintf(message, sizeof(message), "%d of %zu landmarks in view agree (min_landmark_lines %d)",
                  best < 0 ? 0 : supports[static_cast<std::size_t>(best)], projected.size(), options_.min_landmark_lines);
    return refuse(message);
  }
  const double heading = pairs[static_cast<std::size_t>(best)].heading;
  // Another heading nearly as well supported: a row of equal windows or posts, any one of which
  // fits (a heading apart that no pair of the best agrees with).
  for (std::size_t h = 0; h < pairs.size(); ++h) {
    if (agrees(pairs[static_cast<std::size_t>(best)], pairs[h].heading) || agrees(pairs[h], heading)) continue;
    if (5 * supports[h] >= 4 * supports[static_cast<std::size_t>(best)]) {
      std::snprintf(message, sizeof(message), "two headings %.2f deg apart both fit %d and %d lines (repeated structure)",
                    std::abs(pairs[h].heading - heading) * 180.0 / M_PI, supports[h], supports[static_cast<std::size_t>(best)]);
      return refuse(message);
    }
  }
  // One line per landmark (none where two fit) and one landmark per line.
  std::vector<int> line_of(projected.size(), -1);
  std::vector<int> uses(observation.current_lines.size(), 0);
  for (const LinePair& pair : pairs) {
    if (!agrees(pair, heading)) continue;
    int& chosen = line_of[pair.projected];
    chosen = chosen == -1 ? static_cast<int>(pair.current) : -2;
  }
  for (const int j : line_of) {
    if (j >= 0) ++uses[static_cast<std::size_t>(j)];
  }
  std::vector<std::pair<std::size_t, std::size_t>> associations;  // (landmark, current line)
  for (std::size_t p = 0; p < projected.size(); ++p) {
    const int j = line_of[p];
    if (j >= 0 && uses[static_cast<std::size_t>(j)] == 1) associations.emplace_back(projected[p].landmark, static_cast<std::size_t>(j));
  }
  // Iterated EKF update (Gauss-Newton on the prior and all lines, relinearized at each iterate);
  // a line the updated pose leaves further than line_inlier_gate of its own noise was a wrong
  // pairing that the consensus, with the prior's position uncertainty, let through: dropped, and
  // the update redone from the prior without it.
  const Pose2D prior = estimate_;
  const Eigen::Matrix3d P = covariance_;
  Pose2D iterate = prior;
  Eigen::MatrixXd H, K, R, S;
  Eigen::VectorXd noise, prior_innovation;
  for (int round = 0;; ++round) {
    const int n = static_cast<int>(associations.size());
    if (n < options_.min_landmark_lines) {
      std::snprintf(message, sizeof(message), "%d landmarks have one line each that fits (min_landmark_lines %d)", n,
                    options_.min_landmark_lines);
      return refuse(message);
    }
    H.resize(n, 3);
    noise.resize(n);
    Eigen::VectorXd innovation(n);
    iterate = prior;
    for (int iteration = 0; iteration < 4; ++iteration) {
      for (int r = 0; r < n; ++r) {
        const auto p = model.at(associations[static_cast<std::size_t>(r)].first, iterate, P);
        if (!p) return refuse("a landmark left the view during the update");
        H.row(r) = p->jacobian;
        noise(r) = p->noise;
        innovation(r) = observation.current_lines[associations[static_cast<std::size_t>(r)].second].x - p->x;
      }
      const Eigen::Vector3d offset(prior.x - iterate.x, prior.y - iterate.y, wrapToPi(prior.yaw - iterate.yaw));
      R = Eigen::MatrixXd(noise.asDiagonal()) +
          options_.line_heading_sigma_rad * options_.line_heading_sigma_rad * H.col(2) * H.col(2).transpose() +
          options_.line_position_sigma_m * options_.line_position_sigma_m *
              (H.col(0) * H.col(0).transpose() + H.col(1) * H.col(1).transpose());
      S = H * P * H.transpose() + R;
      K = P * H.transpose() * S.ldlt().solve(Eigen::MatrixXd::Identity(n, n));
      prior_innovation = innovation - H * offset;  // linearized about the prior
      const Eigen::Vector3d correction = K * prior_innovation;
      if (!correction.allFinite()) return refuse("the update is not finite");
      iterate = Pose2D(prior.x + correction(0), prior.y + correction(1), wrapToPi(prior.yaw + correction(2)));
    }
    std::vector<std::pair<std::size_t, std::size_t>> fitting;
    for (const auto& association : associations) {
      const auto p = model.at(association.first, iterate, P);
      if (p && std::abs(observation.current_lines[association.second].x - p->x) <=
                   options_.line_inlier_gate * std::sqrt(p->noise)) {
        fitting.push_back(association);
      }
    }
    if (fitting.size() == associations.size() || round == 3) break;
    associations = std::move(fitting);
  }
  const int n = static_cast<int>(associations.size());
  // Joseph form at the last linearization.
  const Eigen::Matrix3d keep = Eigen::Matrix3d::Identity() - K * H;
  covariance_ = keep * P * keep.transpose() + K * R * K.transpose();
  estimate_ = iterate;
  refused_in_a_row_ = 0;
  distance_since_fix_ = 0.0;
  last_innovation_ = FilterInnovation{prior_innovation.dot(S.ldlt().solve(prior_innovation)), n, true};
  return n;
}

Status HeadingAidedOdometry::correctHeading(double route_yaw, const Pose2D& odom_pose) {
  if (!std::isfinite(route_yaw)) {
    return Status(StatusCode::kInvalidInput, "heading-aided odometry: non-finite heading fix");
  }
  Status predicted_to_fix = predict(odom_pose);
  if (!predicted_to_fix.isOk()) return predicted_to_fix;
  return update(wrapToPi(route_yaw - estimate_.yaw), Eigen::RowVector3d(0.0, 0.0, 1.0),
                options_.heading_fix_variance, "heading fix");
}

Expected<Pose2D> HeadingAidedOdometry::predictedPose(const Pose2D& odom_pose) const {
  const auto step = odometryStepTo(odom_pose);
  if (!step) return step.status();
  Pose2D pose = estimate_.compose(*step);
  pose.yaw = wrapToPi(pose.yaw);
  return pose;
}

Expected<Pose2D> HeadingAidedOdometry::routePose(const Pose2D& odom_pose) {
  const Status predicted = predict(odom_pose);
  if (!predicted.isOk()) return predicted;
  return estimate_;
}

}  // namespace homography_teach_repeat
