// LocalizationFilter::correctWithLineLandmarks: a fix from the current vertical lines against a
// reference keyframe's line landmarks (docs/math.md §4.9); the rest of the filter is in
// localization_filter.cpp.
#include "homography_teach_repeat/localization/localization_filter.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "homography_teach_repeat/localization/pose_jacobian.h"
#include "homography_teach_repeat/mu/heading_1d.h"

namespace homography_teach_repeat {

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

Expected<int> LocalizationFilter::correctWithLineLandmarks(const LineLandmarkObservation& observation,
                                                             const Pose2D& odom_pose) {
  if (!observation.reference_pose.isFinite() || !observation.camera_mount.isFinite() ||
      !std::isfinite(observation.image_width) || !observation.lens.validate().isOk()) {
    return Status(StatusCode::kInvalidInput, "localization filter: non-finite line landmark observation");
  }
  for (const LineLandmark& landmark : observation.landmarks) {
    if (landmark.line < 0 || landmark.line >= static_cast<int>(observation.reference_lines.size()) ||
        !landmark.position.allFinite() || !landmark.covariance.allFinite()) {
      return Status(StatusCode::kInvalidInput, "localization filter: a line landmark without its line or not finite");
    }
  }
  Status predicted_to_fix = predict(odom_pose);
  if (!predicted_to_fix.isOk()) return predicted_to_fix;
  previous_mu_.reset();
  const LineLandmarkModel model(observation, options_.line_sigma_px);
  const auto refuse = [&](const std::string& why) {
    countRefusal();
    return Status(StatusCode::kNoConsensus, "localization filter: line landmarks: " + why);
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

}  // namespace homography_teach_repeat
