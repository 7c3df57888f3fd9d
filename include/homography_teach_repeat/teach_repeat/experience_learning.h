// Routes that learn (docs/route_format.md, "Experiences"): a repeat run keeps, for each keyframe
// whose taught view matched weakly or not at all while the pose was trusted, the frame taken
// nearest to the keyframe's pose, and adds it to the route as an experience of that place (route
// format 2). Later runs try a keyframe's experiences where its taught view fails (RepeatLocalizer),
// so a place whose appearance changed (a poster replaced, other light) is recognized again.
//
// What is learned is only as good as the pose it was taken at: a frame is kept only with integrity
// OK, a position σ below max_position_sigma, and near the keyframe (max_distance, max_angle); its
// pose covariance goes into the route and into every pose later measured against it.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <map>
#include <optional>
#include <string>
#include <utility>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/teach_repeat/repeat_pipeline.h"
#include "homography_teach_repeat/teach_repeat/route.h"

namespace homography_teach_repeat {

struct ExperienceLearningOptions {
  // A keyframe's taught view is weak in a frame when it gave no estimate or fewer inliers than this.
  int learn_below_inliers = 40;
  double max_distance = 0.2;          // [m] of the frame's pose from the keyframe's
  double max_angle = 0.1;             // [rad] of its heading from the keyframe's
  double max_position_sigma = 0.05;   // [m] largest σ of the frame's position (sqrt of the
                                      // covariance's largest x-y eigenvalue)
  int max_experiences = 3;            // per keyframe; the oldest goes first

  void validate() const;  // throws std::invalid_argument naming the bad field
};

// What a repeat frame says about the taught view of the keyframe nearest to it.
struct ExperienceObservation {
  double stamp = 0.0;
  cv::Mat image;              // as received (distorted, as the taught images are stored)
  Pose2D pose;                // the published pose (route frame)
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  bool trusted = false;       // integrity OK
  int taught_inliers = -1;    // inliers against that keyframe's taught view (-1: it failed or an
                              // experience gave the estimate)
};

// What a repeat frame (RepeatPipeline::processFrame's result for `image`) says: its published pose
// and covariance, whether the integrity is OK, the inliers when a keyframe's taught view localized
// it. nullopt for a frame without a pose or a covariance.
std::optional<ExperienceObservation> observationOf(double stamp, const cv::Mat& image, const RepeatFrameResult& result);

class ExperienceRecorder {
 public:
  // Throws std::invalid_argument on bad options.
  ExperienceRecorder(std::vector<Pose2D> keyframe_poses, const ExperienceLearningOptions& options);

  // One repeat frame: kept as its nearest keyframe's candidate when the taught view was weak there,
  // the pose trusted and near the keyframe, and nearer than the candidate so far.
  void observe(const ExperienceObservation& observation);

  // The keyframes with a candidate, and how far their candidate is from the keyframe [m].
  std::map<int, double> candidates() const;

  // Adds every candidate to `route` as an experience of its keyframe (features extracted with
  // `extractor`, of the route's type) and forgets them. The candidates of consecutive keyframes are
  // then registered as the teach run registers its keyframe pairs, and each such experience keeps
  // its match residual and tilt to the next (route.h, RouteExperience): the route's measured noise
  // takes in what this run saw (docs/route_format.md, "Measured noise"). Returns how many were
  // added; the first failure (a write, the features) is returned instead, the experiences added
  // before it stay.
  Expected<int> commit(Route& route, FeatureExtractor& extractor);

 private:
  // The pairs of `learned` (features and pose by keyframe) at consecutive keyframes measured into
  // their experiences (each keyframe's last); returns how many got a measurement.
  static int measurePairs(Route& route, const std::map<int, std::pair<ImageFeatures, Pose2D>>& learned);

  struct Candidate {
    ExperienceObservation observation;
    double distance = 0.0;  // [m] to the keyframe's pose
  };
  std::vector<Pose2D> keyframe_poses_;
  ExperienceLearningOptions options_;
  std::map<int, Candidate> candidates_;
};

}  // namespace homography_teach_repeat
