// A junction measured from the images (docs/map_format.md, "The folder"): where a keyframe of one
// route and a keyframe of another see the same wall, the second keyframe's stored features are
// localized against the first keyframe as a repeat frame would be (fast_hd: matches, robust
// homography, Fast-HD with the first keyframe's plane, its covariance), which gives the relative
// pose of their base_link frames from the images, not from odometry.
#pragma once

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/network/route_map.h"
#include "homography_teach_repeat/teach_repeat/repeat_estimate.h"

namespace homography_teach_repeat {

// The junction from `from` to `to` with `to_in_from`, its covariance (x, y, yaw in `from`'s
// keyframe frame) and the inliers. `options` are the repeat's (its mode is taken as fast_hd).
// kInvalidInput naming the keyframe when either is not in the map, its files are missing or
// corrupt, or `from` has no plane; the estimator's own status (kTooFewPoints, kNoConsensus, ...)
// when the two views do not overlap enough to give a pose.
Expected<Junction> measureJunction(const RouteMap& map, const KeyframeRef& from, const KeyframeRef& to,
                                   const RepeatOptions& options);

}  // namespace homography_teach_repeat
