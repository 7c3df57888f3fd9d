#include "homography_teach_repeat/trifocal/trifocal_localizer.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace homography_teach_repeat {
namespace {

// Camera pose (docs/math.md §1.1 axes, the frame of trifocal_motion.h) of view `pose` of base_link
// relative to base_link at `origin`.
PlanarPose cameraRelative(const CameraMount& mount, const Pose2D& origin, const Pose2D& pose) {
  return mount.baseToCamera(origin.inverse().compose(pose));
}

}  // namespace

Expected<std::vector<ThreeViewMatch>> matchThreeViews(const ImageFeatures& first, const ImageFeatures& second,
                                                      const ImageFeatures& third, const MatchOptions& options) {
  const auto first_second = matchFeatures(first, second, options);
  if (!first_second) return first_second.status();
  const auto second_third = matchFeatures(second, third, options);
  if (!second_third) return second_third.status();
  std::unordered_map<int, int> second_to_third;
  for (const auto& m : *second_third) second_to_third[m.queryIdx] = m.trainIdx;
  std::vector<ThreeViewMatch> matches;
  for (const auto& m : *first_second) {
    const auto it = second_to_third.find(m.trainIdx);
    if (it != second_to_third.end()) matches.push_back({m.queryIdx, m.trainIdx, it->second});
  }
  return matches;
}

void TrifocalLocalizerOptions::validate() const {
  features.validate();
  matching.validate();
  ransac.validate();
  motion.validate();
  if (min_off_plane < 1) throw std::invalid_argument("min_off_plane must be >= 1");
  if (!(min_off_plane_fraction >= 0.0 && min_off_plane_fraction < 1.0)) {
    throw std::invalid_argument("min_off_plane_fraction must be in [0, 1)");
  }
  if (!(max_prior_disagreement_fraction >= 0.0 && std::isfinite(max_prior_disagreement_fraction))) {
    throw std::invalid_argument("max_prior_disagreement_fraction must be finite and >= 0");
  }
  if (!(max_prior_heading_disagreement > 0.0 && max_prior_heading_disagreement <= M_PI)) {
    throw std::invalid_argument("max_prior_heading_disagreement must be in (0, pi]");
  }
  if (min_inliers < minimalTriplets(ransac.method)) {
    throw std::invalid_argument("min_inliers must be at least the minimal set of the method (" +
                                std::to_string(minimalTriplets(ransac.method)) + ")");
  }
}

TrifocalLocalizer::TrifocalLocalizer(const PinholeCamera& camera, const CameraMount& mount,
                                     const TrifocalLocalizerOptions& options)
    : camera_(camera), mount_(mount), options_(options), extractor_(options.features) {
  options_.validate();
}

Expected<ImageFeatures> TrifocalLocalizer::extract(const cv::Mat& image) {
  if (image.empty()) return Status(StatusCode::kInvalidInput, "image is empty");
  if (image.cols != camera_.width() || image.rows != camera_.height()) {
    return Status(StatusCode::kInvalidInput, "image is " + std::to_string(image.cols) + "x" +
                                                 std::to_string(image.rows) + ", the camera is " +
                                                 std::to_string(camera_.width()) + "x" +
                                                 std::to_string(camera_.height()));
  }
  return extractor_.extract(image);
}

Bearing TrifocalLocalizer::bearingOf(const cv::KeyPoint& keypoint) const {
  const cv::Point2d undistorted = camera_.undistortPixel(cv::Point2d(keypoint.pt.x, keypoint.pt.y));
  return bearingFromPixel(undistorted.x, camera_.fx(), camera_.cx());
}

Expected<TrifocalLocalization> TrifocalLocalizer::localize(const TrifocalView& first, const TrifocalView& second,
                                                           const TrifocalView& third,
                                                           const std::optional<Pose2D>& first_to_second) const {
  if (!first.odometry.isFinite() || !second.odometry.isFinite() || !third.odometry.isFinite() ||
      (first_to_second && !first_to_second->isFinite())) {
    return Status(StatusCode::kInvalidInput, "trifocal localization: odometry of a view is not finite");
  }
  // The prior (docs/math.md §5.6: it picks the candidate and gives the metric scale): odometry, with
  // view 2 from `first_to_second` when given (view 3 then follows it by odometry from view 2).
  const Pose2D second_pose = first_to_second ? first.odometry.compose(*first_to_second) : second.odometry;
  const Pose2D third_pose = second_pose.compose(second.odometry.inverse().compose(third.odometry));
  const PlanarPose second_camera = cameraRelative(mount_, first.odometry, second_pose);
  const PlanarPose third_camera = cameraRelative(mount_, first.odometry, third_pose);
  TrifocalMotionPrior prior;
  prior.centre_second = Eigen::Vector2d(second_camera.x, second_camera.z);
  prior.centre_third = Eigen::Vector2d(third_camera.x, third_camera.z);
  prior.theta_second = second_camera.theta;
  prior.theta_third = third_camera.theta;
  const double smallest_baseline =
      std::min({prior.centre_second.norm(), prior.centre_third.norm(), (prior.centre_third - prior.centre_second).norm()});
  if (!(smallest_baseline > 1e-3)) {
    return Status(StatusCode::kDegenerate, "trifocal localization: two views were taken at the same place "
                                           "(odometry baseline " + std::to_string(smallest_baseline) + " m)");
  }

  const auto matches = matchThreeViews(first.features, second.features, third.features, options_.matching);
  if (!matches) return matches.status();
  std::vector<BearingTriplet> triplets;
  triplets.reserve(matches->size());
  for (const auto& m : *matches) {
    triplets.push_back({bearingOf(first.features.keypoints[static_cast<std::size_t>(m.first)]),
                        bearingOf(second.features.keypoints[static_cast<std::size_t>(m.second)]),
                        bearingOf(third.features.keypoints[static_cast<std::size_t>(m.third)])});
  }
  const auto tensor = estimateTrifocalRansac(triplets, options_.ransac);
  if (!tensor) return tensor.status();
  if (static_cast<int>(tensor->inliers.size()) < options_.min_inliers) {
    return Status(StatusCode::kNoConsensus, std::to_string(tensor->inliers.size()) + " of " +
                                                std::to_string(triplets.size()) +
                                                " three-view matches agree with the tensor, need " +
                                                std::to_string(options_.min_inliers));
  }
  std::vector<BearingTriplet> inliers;
  for (const int k : tensor->inliers) inliers.push_back(triplets[static_cast<std::size_t>(k)]);
  // Landmarks on one wall are collinear in the top view: a single pair of 1D homographies explains
  // them and the tensor is not determined by them (in the simulated room, with one wall in view,
  // tensors 0.13 apart fitted the same triplets within 1 mrad and the heading came out 2-7° off).
  const auto plane = estimateDominantPlane(inliers, options_.ransac);
  const int off_plane = static_cast<int>(inliers.size()) - (plane ? static_cast<int>(plane->inliers.size()) : 0);
  const int needed_off_plane =
      std::max(options_.min_off_plane,
               static_cast<int>(std::ceil(options_.min_off_plane_fraction * static_cast<double>(inliers.size()))));
  if (off_plane < needed_off_plane) {
    return Status(StatusCode::kDegenerate,
                  std::to_string(inliers.size() - static_cast<std::size_t>(off_plane)) + " of " +
                      std::to_string(inliers.size()) +
                      " three-view matches lie on one wall (one homography explains them): the tensor is not "
                      "determined, need " + std::to_string(needed_off_plane) + " off it");
  }
  const auto motion = estimateTrifocalMotion(tensor->tensor, inliers, prior, options_.motion);
  if (!motion) return motion.status();

  TrifocalLocalization result;
  result.motion = motion->motion;
  result.triplets = static_cast<int>(triplets.size());
  result.inliers = static_cast<int>(inliers.size());
  result.off_plane = off_plane;
  result.iterations = tensor->iterations;
  result.ambiguous = motion->ambiguous;
  const Eigen::Vector2d c2 = motion->motion.centreSecond(), c3 = motion->motion.centreThird();
  result.base_poses[0] = first.odometry;
  result.base_poses[1] = first.odometry.compose(mount_.cameraToBase(PlanarPose(c2.x(), c2.y(), motion->motion.theta_second)));
  result.base_poses[2] = first.odometry.compose(mount_.cameraToBase(PlanarPose(c3.x(), c3.y(), motion->motion.theta_third)));
  const Pose2D prior_poses[2] = {second_pose, third_pose};
  for (int view = 1; view <= 2; ++view) {
    const Pose2D& prior_pose = prior_poses[view - 1];
    const Pose2D& vision_pose = result.base_poses[static_cast<std::size_t>(view)];
    const double travelled = std::hypot(prior_pose.x - first.odometry.x, prior_pose.y - first.odometry.y);
    const double position = std::hypot(vision_pose.x - prior_pose.x, vision_pose.y - prior_pose.y);
    const double heading = std::abs(wrapToPi(vision_pose.yaw - prior_pose.yaw));
    if (position > options_.max_prior_disagreement_fraction * travelled + 0.05 ||
        heading > options_.max_prior_heading_disagreement) {
      return Status(StatusCode::kNoConsensus,
                    "trifocal localization: view " + std::to_string(view + 1) + " is " + std::to_string(position) +
                        " m / " + std::to_string(heading) + " rad from its odometry prior (" +
                        std::to_string(travelled) + " m travelled): a wrong tensor, not published");
    }
  }
  const Pose2D& camera_in_base = mount_.forwardFrame();
  for (const auto& t : inliers) {
    const auto landmark = triangulateLandmark(motion->motion, t);
    if (!landmark) continue;
    // Camera axes (X right, Z forward) -> the camera's forward frame (x forward, y left).
    const Eigen::Vector2d forward(landmark->y(), -landmark->x());
    result.landmarks.push_back(first.odometry.transformPoint(camera_in_base.transformPoint(forward)));
  }
  return result;
}

}  // namespace homography_teach_repeat
