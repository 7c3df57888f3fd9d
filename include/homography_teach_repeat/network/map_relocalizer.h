// Finding the robot's place in a map of routes from no hint, or from a rough one (rviz's
// "2D Pose Estimate"), and saying so only once it is sure (docs/map_format.md, "Finding the place
// without a hint"; docs/design.md, "Relocalization").
//
// Each frame (an image and the odometry pose it was taken at):
//  1. every place hypothesis (a keyframe and the pose of base_link in its route's frame) moves with
//     the odometry and is checked again against its route's keyframe nearest to where it now
//     predicts the robot (fast_hd against the keyframe's taught view, then its learned views); a
//     check that gives a pose within the gate of the prediction supports it, and a hypothesis that
//     is not supported for `max_misses` frames in a row is dropped;
//  2. the place index proposes `candidates` keyframes (a hint instead: the keyframes of its route
//     nearest to its pose); up to `checks_per_frame` of those not yet hypotheses are checked, most
//     similar first (the others wait for the next frames, so that a frame's time stays bounded);
//     one that gives a pose becomes a new hypothesis;
//  3. the verdict: kConfirmed when one place has been supported in `confirmations` frames, the
//     robot has driven `confirmation_distance` or turned `confirmation_turn` since it was first
//     seen, and no other live hypothesis is a different place (kAmbiguous while one is: two
//     corridors that look alike, told apart only by driving on until one stops fitting). The same
//     place seen from two routes (a corridor two routes share) is one place: their poses agree
//     through a junction between the two routes.
// A frame's failure (no features, nothing checked gives a pose) is not an error: the state says
// kSearching. Errors are bad input only (empty image, non-finite odometry, a hint outside the map).
#pragma once

#include <opencv2/core.hpp>

#include <Eigen/Core>

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/network/map_keyframe_cache.h"
#include "homography_teach_repeat/network/place_index.h"
#include "homography_teach_repeat/network/route_map.h"
#include "homography_teach_repeat/teach_repeat/keyframe_estimators.h"
#include "homography_teach_repeat/teach_repeat/repeat_estimate.h"

namespace homography_teach_repeat {

struct RelocalizationOptions {
  int candidates = 10;             // keyframes the place index proposes per frame
  int checks_per_frame = 3;        // of proposed keyframes (hypotheses are checked besides)
  int confirmations = 3;           // frames the place must be supported in
  double confirmation_distance = 0.3;  // [m] driven since the place was first seen, or
  double confirmation_turn = 0.35;     // [rad] turned (in place)
  double gate_distance = 0.3;      // [m] a check agrees with a hypothesis' prediction within this
  double gate_distance_per_metre = 0.1;  // plus this fraction of the distance driven since its last support
  double gate_yaw = 0.15;          // [rad]
  int max_misses = 3;              // frames in a row without support before a hypothesis is dropped
  int max_hypotheses = 4;          // kept (the most supported); each costs a check per frame
  int retry_after_frames = 5;      // a proposed keyframe that failed is not checked again for this many frames
  std::size_t cached_keyframes = 256;  // keyframes kept in memory (MapKeyframeCache)
  double hint_radius = 3.0;        // [m] keyframes around a hint that are checked
  // A check puts the robot within this distance [m] of the keyframe it checked (the teach spacing),
  // or it is no place: a wall seen from metres away gives a pose too loose to tell keyframes of one
  // leg apart (in the simulator's network world two keyframes 2 m apart facing one wall 5 m away
  // stayed rivals; with 1 m a robot in an alcove's opening was placed 0.86 m wrong on a route 2 m
  // behind it that faces the same wall).
  double max_place_distance = 0.5;

  void validate() const;  // throws std::invalid_argument naming the bad field
};

enum class RelocalizationState { kSearching, kTentative, kAmbiguous, kConfirmed };
std::string toString(RelocalizationState state);  // "searching", "tentative", "ambiguous", "confirmed"

struct PlaceHypothesis {
  KeyframeRef keyframe;       // the keyframe it was last supported by
  Pose2D base_pose;           // base_link in the frame of `keyframe.route` (moved with the odometry)
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // of base_pose at its last support (x, y, yaw)
  int inliers = 0;            // of its last support
  int support = 0;            // frames it was supported in
  int misses = 0;             // frames in a row without support
  double driven = 0.0;        // [m] since first seen (odometry)
  double turned = 0.0;        // [rad] since first seen (odometry, absolute)
  double driven_since_support = 0.0;  // [m] since its last support (widens its gate)
};

struct RelocalizationTiming {
  double extraction_ms = 0.0;  // the image's features
  double query_ms = 0.0;       // the place index
  double checks_ms = 0.0;      // loading and checking keyframes
  int checks = 0;              // keyframes checked (hypotheses and proposals)
  int loads = 0;               // of which read from files (not cached)
};

struct Relocalization {
  RelocalizationState state = RelocalizationState::kSearching;
  std::vector<PlaceHypothesis> hypotheses;  // most supported first
  std::optional<PlaceHypothesis> place;     // kConfirmed: the place
  std::string reason;                       // what the state rests on, for logs and diagnostics
  std::vector<std::string> problems;        // keyframes that could not be read this frame (named)
  RelocalizationTiming timing;
};

// A rough place from the user: base_link near `pose` in the frame of `route`.
struct PlaceHint {
  std::string route;
  Pose2D pose;
};

// The hint for a pose given in the map frame (the first route's frame, routeFramesInMap; rviz's
// "2D Pose Estimate"): the route, among those joined to that frame, with the keyframe nearest to
// it, and the pose in that route's frame. nullopt for a non-finite pose or a map without routes.
std::optional<PlaceHint> placeHintFromMapPose(const RouteMap& map, const Pose2D& pose_in_map);

class MapRelocalizer {
 public:
  // `index`: the map's place index (map_place_index.h); may be empty when every search has a hint.
  // kInvalidInput for bad options, a map without routes or without any keyframe plane, or an index
  // of another map's size.
  static Expected<MapRelocalizer> create(const RouteMap& map, std::optional<PlaceIndex> index,
                                         const RepeatOptions& repeat, const RelocalizationOptions& options = {});

  // One frame at odometry pose `odometry` (odom frame). kInvalidInput for an empty image or a
  // non-finite pose; kInvalidInput when there is neither a hint nor an index.
  Expected<Relocalization> update(const cv::Mat& image, const Pose2D& odometry);

  // Searches around `hint` from now on (the hypotheses are kept). kInvalidInput for an unknown
  // route or a non-finite pose.
  Status setHint(const PlaceHint& hint);
  void clearHint() { hint_.reset(); }
  // Forgets the hypotheses and the hint (the robot was carried elsewhere).
  void reset();
  // One feature detection on a noise image of the map camera's size: a process's first detection
  // takes several times as long as the next (fresh memory, docs/design.md "Frame buffers"), so a
  // node does it at start-up rather than in its first frame.
  void warmUp();

  const RouteMap& map() const { return *map_; }
  const MapKeyframeCache& keyframes() const { return cache_; }

 private:
  MapRelocalizer(std::shared_ptr<const RouteMap> map, std::optional<PlaceIndex> index, const RepeatOptions& repeat,
                 const RelocalizationOptions& options);

  // The keyframe's pose for this frame: its taught view, then its learned views, until one gives a
  // pose with covariance; nullopt when none does.
  std::optional<RepeatEstimate> check(const KeyframeRef& ref, const FrameObservations& frame, Relocalization* result);
  // Hypothesis i against targets[i] (its nearest keyframe now); drops those missed too often.
  void checkHypotheses(const FrameObservations& frame, const std::vector<KeyframeRef>& targets, Relocalization* result);
  // Up to checks_per_frame proposals, most similar first, none near a target or another chosen one
  // nor failed in the last retry_after_frames frames.
  Expected<std::vector<KeyframeRef>> selectProposals(const cv::Mat& descriptors, const std::vector<KeyframeRef>& targets,
                                                     RelocalizationTiming* timing);
  void checkProposals(const FrameObservations& frame, const std::vector<KeyframeRef>& selected, Relocalization* result);
  Expected<std::vector<KeyframeRef>> proposals(const cv::Mat& descriptors, RelocalizationTiming* timing) const;
  // The keyframes of `route` nearest to `pose` (distance plus 1 m per radian of heading), nearest first.
  std::vector<KeyframeRef> nearestKeyframes(const std::string& route, const Pose2D& pose, std::size_t count,
                                            double radius) const;
  // Whether a and b are the same place: the same route and poses within the gate, or routes joined
  // by a junction through which their poses agree.
  bool samePlace(const PlaceHypothesis& a, const PlaceHypothesis& b) const;
  // `base_pose` (in ref's route frame) is within max_place_distance of keyframe `ref`.
  bool nearKeyframe(const KeyframeRef& ref, const Pose2D& base_pose) const;
  bool agrees(const Pose2D& predicted, const Pose2D& measured, double driven) const;
  // Sorts the hypotheses and states the verdict into `result`.
  void judge(Relocalization* result);

  std::shared_ptr<const RouteMap> map_;
  std::optional<PlaceIndex> index_;
  RelocalizationOptions options_;
  MapKeyframeCache cache_;
  std::map<std::string, std::unique_ptr<KeyframeEstimator>> estimators_;  // by route
  std::vector<PlaceHypothesis> hypotheses_;
  std::map<std::string, long> failed_at_frame_;        // proposed keyframes that gave no pose
  std::optional<PlaceHint> hint_;
  std::optional<Pose2D> last_odometry_;
  long frame_ = 0;
};

}  // namespace homography_teach_repeat
