#include "homography_teach_repeat/teach_repeat/experience_learning.h"

#include <Eigen/Eigenvalues>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include "homography_teach_repeat/teach_repeat/teach_session.h"

namespace homography_teach_repeat {

void ExperienceLearningOptions::validate() const {
  if (learn_below_inliers < 1) throw std::invalid_argument("learn_below_inliers must be >= 1");
  if (!std::isfinite(max_distance) || !(max_distance > 0.0)) throw std::invalid_argument("max_distance must be > 0");
  if (!std::isfinite(max_angle) || !(max_angle > 0.0)) throw std::invalid_argument("max_angle must be > 0");
  if (!std::isfinite(max_position_sigma) || !(max_position_sigma > 0.0)) {
    throw std::invalid_argument("max_position_sigma must be > 0");
  }
  if (max_experiences < 1) throw std::invalid_argument("max_experiences must be >= 1");
}

std::optional<ExperienceObservation> observationOf(double stamp, const cv::Mat& image, const RepeatFrameResult& result) {
  if (!result.pose || !result.covariance) return std::nullopt;
  ExperienceObservation o;
  o.stamp = stamp;
  o.image = image;
  o.pose = *result.pose;
  o.covariance = *result.covariance;
  o.trusted = result.integrity.level == IntegrityLevel::kOk;
  const bool taught_view = result.status.isOk() && result.estimate && result.estimate->has_pose &&
                           !result.estimate->degraded && result.estimate->experience == 0;
  o.taught_inliers = taught_view ? result.estimate->inliers : -1;
  return o;
}

ExperienceRecorder::ExperienceRecorder(std::vector<Pose2D> keyframe_poses, const ExperienceLearningOptions& options)
    : keyframe_poses_(std::move(keyframe_poses)), options_(options) {
  options_.validate();
}

void ExperienceRecorder::observe(const ExperienceObservation& o) {
  if (!o.trusted || o.image.empty() || !o.covariance.allFinite()) return;
  // A taught view (the nearest keyframe's or a neighbour's) still works here.
  if (o.taught_inliers >= options_.learn_below_inliers) return;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> position(o.covariance.topLeftCorner<2, 2>());
  if (position.info() != Eigen::Success ||
      std::sqrt(std::max(0.0, position.eigenvalues().maxCoeff())) > options_.max_position_sigma) {
    return;  // a pose not known well enough teaches nothing
  }
  // The nearest keyframe facing the same way.
  int nearest = -1;
  double nearest_distance = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < keyframe_poses_.size(); ++k) {
    const Pose2D& p = keyframe_poses_[k];
    if (std::abs(wrapToPi(o.pose.yaw - p.yaw)) > options_.max_angle) continue;
    const double d = std::hypot(o.pose.x - p.x, o.pose.y - p.y);
    if (d < nearest_distance) {
      nearest_distance = d;
      nearest = static_cast<int>(k);
    }
  }
  if (nearest < 0 || nearest_distance > options_.max_distance) return;
  auto it = candidates_.find(nearest);
  if (it != candidates_.end() && it->second.distance <= nearest_distance) return;
  Candidate candidate;
  candidate.observation = o;
  candidate.observation.image = o.image.clone();
  candidate.distance = nearest_distance;
  candidates_[nearest] = std::move(candidate);
}

std::map<int, double> ExperienceRecorder::candidates() const {
  std::map<int, double> out;
  for (const auto& [k, c] : candidates_) out[k] = c.distance;
  return out;
}

Expected<int> ExperienceRecorder::commit(Route& route, FeatureExtractor& extractor) {
  int added = 0;
  std::map<int, std::pair<ImageFeatures, Pose2D>> learned;  // this run's views, by keyframe
  for (auto it = candidates_.begin(); it != candidates_.end();) {
    const ExperienceObservation& o = it->second.observation;
    auto features = extractor.extract(o.image);
    if (!features) return features.status();
    const Status status = addExperience(route, static_cast<std::size_t>(it->first), o.image, *features, o.pose,
                                        o.covariance, o.stamp, options_.max_experiences);
    if (!status.isOk()) return status;
    learned.emplace(it->first, std::make_pair(std::move(*features), o.pose));
    ++added;
    it = candidates_.erase(it);
  }
  if (measurePairs(route, learned) > 0) {
    const Status status = writeRouteIndex(route);
    if (!status.isOk()) return status;
  }
  return added;
}

int ExperienceRecorder::measurePairs(Route& route, const std::map<int, std::pair<ImageFeatures, Pose2D>>& learned) {
  // The teach run's measurement (teach_session.h, measureRouteNoise) on the views this run learned
  // at consecutive keyframes: the same camera, scene and light on both sides of the pair.
  const PinholeCamera camera(route.info.camera);
  const CameraMount mount(route.info.camera_mount.x, route.info.camera_mount.y, route.info.camera_mount.yaw);
  int measured = 0;
  for (const auto& [keyframe, view] : learned) {
    const auto next = learned.find(keyframe + 1);
    if (next == learned.end()) continue;
    const PairMeasurement pair =
        measureViewPair(view.first, next->second.first, view.second, next->second.second, camera, mount);
    RouteExperience& experience = route.keyframes[static_cast<std::size_t>(keyframe)].experiences.back();
    experience.match_residual = pair.match_residual;
    experience.tilt_to_next = pair.tilt_to_next;
    measured += pair.match_residual || pair.tilt_to_next ? 1 : 0;
  }
  return measured;
}

}  // namespace homography_teach_repeat
