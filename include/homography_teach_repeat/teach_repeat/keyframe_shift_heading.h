// The repeat's seasonal heading fix (docs/math.md §4.10, docs/evaluation.md "Heading across
// seasons"): ShiftHeading (mu/shift_heading.h) of the current image against a route keyframe's
// stored image. The hybrid and μ modes take it where a frame has neither a Fast-HD pose nor a μ or
// line fix (RepeatPipeline, docs/nodes/repeat_node.md, "The seasonal heading fix").
//  - The keyframe's image (keyframes/NNNNNN.png, as recorded) and those of its experiences (views
//    learned by earlier repeat runs, docs/route_format.md) are read and described on first use; the
//    features of the `cache_size` most recently used views are kept.
//  - Keypoints are undistorted with the route's calibration before the vote, which runs on angles
//    (the camera's fx), so μ is that of the ideal pinhole camera at the principal point cx.
#pragma once

#include <opencv2/core.hpp>

#include <list>
#include <string>
#include <utility>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/mu/shift_heading.h"
#include "homography_teach_repeat/teach_repeat/route.h"

namespace homography_teach_repeat {

struct KeyframeShiftHeadingOptions {
  ShiftHeadingOptions shift;
  // [grey levels] An image whose grey-level standard deviation (at 1/8 size) is below this has no
  // texture to vote with (a covered lens, a blank wall): describe() refuses it at once instead of
  // building the feature scale space (~0.1 s at 640x480; several times that in a sanitizer build,
  // where it starved repeat_node's camera callback). >= 0.
  double min_texture_std = 4.0;
  int cache_size = 32;  // views (keyframes and experiences) whose features are kept (>= 1; about 0.25 MB each at the defaults)

  void validate() const;  // throws std::invalid_argument naming the bad field
};

// A fix against one of a keyframe's views.
struct ViewShiftFix {
  ShiftHeadingFix fix;
  int experience = 0;  // 0: the taught view; otherwise the experience's id (RouteExperience::id)
  Pose2D view_pose;    // base_link of that view in the route frame (the taught keyframe's pose)
  double view_yaw_variance = 0.0;  // [rad²] of view_pose's yaw (an experience's estimate; 0 taught)
};

class KeyframeShiftHeading {
 public:
  // `route`: its directory and keyframe image files (read later, on use); `camera`: the route's.
  // Throws std::invalid_argument on invalid options.
  KeyframeShiftHeading(const Route& route, const PinholeCamera& camera,
                       const KeyframeShiftHeadingOptions& options = KeyframeShiftHeadingOptions());

  // The features of a current image (grey or colour, 8-bit), undistorted. Status: kInvalidInput for
  // an image of another size than the route's camera, kTooFewPoints for one without texture
  // (min_texture_std), or the extractor's.
  Expected<ShiftFeatures> describe(const cv::Mat& image);
  // μ [px] of the current view against keyframe `keyframe` with its variance and ambiguity.
  // Status: kInvalidInput for a keyframe out of range or an unreadable keyframe image (naming the
  // file; retried on the next call), otherwise ShiftHeading::measure's.
  Expected<ShiftHeadingFix> measure(int keyframe, const ShiftFeatures& current);
  // The same against the taught view and every experience of the keyframe: the unambiguous fix
  // with the most support, else the most supported one. An experience whose image cannot be read
  // is skipped; the status is the taught view's when no view gives a fix.
  Expected<ViewShiftFix> measureViews(int keyframe, const ShiftFeatures& current);

  // The cached features of a keyframe's view (described on first use): `experience` 0 the taught
  // view, e >= 1 the keyframe's experiences[e - 1]. Status as measure()'s for the view's image.
  Expected<const ShiftFeatures*> viewFeatures(int keyframe, int experience);

  int keyframeCount() const { return static_cast<int>(route_.keyframes.size()); }
  int cachedKeyframes() const { return static_cast<int>(cache_.size()); }

 private:
  Status checkKeyframe(int keyframe) const;  // kInvalidInput out of range

  void undistort(ShiftFeatures* features) const;

  Route route_;  // the keyframes' image files
  PinholeCamera camera_;
  KeyframeShiftHeadingOptions options_;
  ShiftHeading shift_heading_;
  std::list<std::pair<std::pair<int, int>, ShiftFeatures>> cache_;  // (keyframe, view); most recent first
};

// What the seasonal heading fix has to work with along a route (route_info, docs/route_audit.md):
// each keyframe's features for it and the vote against the next keyframe's image (the previous
// one's for the last keyframe of an open route), the view of a robot a keyframe spacing away.
struct ShiftHeadingAudit {
  int keyframe = 0;
  int features = 0;           // upright AKAZE + BRIEF in the keyframe image
  int neighbour = -1;         // the keyframe voted against (-1: none, a route of one keyframe)
  int support = 0;            // the vote's support against it (0: no vote, see problem)
  bool ambiguous = false;
  std::string problem;        // why there is no vote (an unreadable image, too few matches)
};
std::vector<ShiftHeadingAudit> auditShiftHeading(const Route& route, const PinholeCamera& camera,
                                                 const KeyframeShiftHeadingOptions& options = {});

}  // namespace homography_teach_repeat
