// Teaching a route into a map of routes (docs/map_format.md, "Teaching into a map"): the new route
// is recorded by a TeachSession into a folder the map does not name yet; every keyframe it stores is
// also located in the map (MapRelocalizer: the place index and the geometry, confirmed over several
// keyframes and some motion), so that the stretches where the new route runs over taught ground are
// known while teaching — where it leaves a taught route and where it rejoins one. At finish the
// planes are estimated, a junction is measured from the images (junction_measurement.h) at the
// first and the last keyframe of each such stretch (and at the route's last keyframe where its place
// is tentative: a branch that rejoins a taught route just before it ends, before 3 keyframes could
// confirm the place; kept only when the junction measured there puts the two keyframes within
// contact_distance and contact_angle), and the route and its junctions are committed
// to the map (the route by one atomic rewrite of the index, then each junction by another: a crash
// in between leaves the map with the route and without some of its junctions, which loads); the
// place index is rebuilt so that the new route can be relocalized on at once. Teaching a route of
// the map again: its old keyframes are no junction partners (they are replaced).
#pragma once

#include <opencv2/core.hpp>

#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/network/map_relocalizer.h"
#include "homography_teach_repeat/network/route_map.h"
#include "homography_teach_repeat/teach_repeat/teach_session.h"

namespace homography_teach_repeat {

struct MapTeachOptions {
  std::string name;          // of the route in the map (an existing name: the route is taught again)
  TeachOptions teach;        // its route_directory is chosen here (a new folder under routes/)
  RepeatOptions repeat;      // how keyframes are checked against the map and junctions measured
  RelocalizationOptions relocalization;  // retry_after_frames is 0 here (keyframes are sparse frames)
  bool rebuild_index = true;  // rebuild <map>/place_index.yml at finish
  // A located keyframe is on taught ground only within this distance [m] and heading [rad] of the
  // map keyframe it was located by: a wall seen from metres away (across a hall, into an alcove)
  // locates the robot well, but no route switch can be made there (a junction 3 m long was found
  // that way in the simulator's network world before this test).
  double contact_distance = 0.5;
  double contact_angle = 0.35;
};

// The new route's keyframe `keyframe` is at map keyframe `map_keyframe` (a stretch's first or last).
struct MapContact {
  int keyframe = 0;
  KeyframeRef map_keyframe;
};

struct MapTeachReport {
  PlaneEstimationReport planes;
  std::string relative_directory;        // where the route went in the map
  std::vector<Junction> junctions;       // measured and committed
  std::vector<std::string> problems;     // contacts whose junction could not be measured, and why
  std::vector<Junction> dropped;         // the old route's junctions whose keyframe is gone
  bool index_rebuilt = false;
};

class MapTeach {
 public:
  // kInvalidInput for a bad name, a route folder that cannot be created, or what TeachSession
  // refuses. Without `index` (a new map, or none built) the new route is not located in the map
  // (no junction is found; `locating()` says so).
  static Expected<MapTeach> start(const RouteMap& map, std::optional<PlaceIndex> index, const MapTeachOptions& options,
                                  const CameraCalibration& calibration, const Pose2D& camera_mount);

  // TeachSession::offer; a stored keyframe is then located in the map.
  Expected<bool> offer(const cv::Mat& image, const Pose2D& odometry_pose, double stamp);

  // Plane estimation, junction measurement, commit (and the index). kInvalidInput when the route
  // has no keyframe or the commit is refused (the map is then as before).
  Expected<MapTeachReport> finish();

  bool locating() const { return relocalizer_.has_value(); }
  // The map keyframe the last stored keyframe is at (confirmed); empty off the map.
  const std::optional<KeyframeRef>& onMap() const { return on_map_; }
  const std::vector<MapContact>& contacts() const { return contacts_; }
  // The last keyframe's relocalization verdict (for live status), when located.
  const std::optional<Relocalization>& lastLocation() const { return last_location_; }
  const Route& route() const { return session_.route(); }
  const TeachSession& session() const { return session_; }

 private:
  MapTeach(RouteMap map, TeachSession session, std::optional<MapRelocalizer> relocalizer, MapTeachOptions options,
           std::string relative_directory);
  void closeStretch();
  // The last keyframe's contact where its place is tentative (one place, not yet confirmed) and
  // near its keyframe, and no stretch over taught ground ends there already.
  std::optional<MapContact> tentativeEndContact() const;
  // The located place is within contact_distance / contact_angle of its keyframe.
  bool nearItsKeyframe(const PlaceHypothesis& place) const;
  // A pose relative to a map keyframe is within contact_distance and contact_angle of it.
  bool withinContact(const Pose2D& relative) const;

  RouteMap map_;
  TeachSession session_;
  std::optional<MapRelocalizer> relocalizer_;
  MapTeachOptions options_;
  std::string relative_directory_;
  std::vector<MapContact> contacts_;
  std::optional<MapContact> stretch_last_;  // the current stretch's last contact
  std::optional<KeyframeRef> on_map_;
  std::optional<Relocalization> last_location_;
};

}  // namespace homography_teach_repeat
