// RouteFollower and what stands in the way (docs/nodes/controller_node.md): the speed
// limit from the obstacles along the arc the base drives, and the lane that passes beside them.
#include "homography_teach_repeat/control/route_follower.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

namespace homography_teach_repeat {

namespace {

// A point (base_link frame) against the arc the base drives with curvature `curvature` [1/m, > 0
// to the left] from its centre: how far along the arc [m] the base is beside it, and how far it is
// off the arc [m, > 0 to the left]. Points behind the base (the straight corridor: x <= 0; on an
// arc: more than half a circle on) have no distance along. docs/nodes/controller_node.md.
struct ArcCoordinates {
  std::optional<double> along;
  double off = 0.0;
};

ArcCoordinates arcCoordinates(const Eigen::Vector2d& point, double curvature) {
  constexpr double kStraight = 1e-6;  // [1/m]: a radius of 1000 km
  if (std::abs(curvature) < kStraight) {
    return {point.x() > 0.0 ? std::optional<double>(point.x()) : std::nullopt, point.y()};
  }
  const double radius = 1.0 / std::abs(curvature), side = curvature > 0.0 ? 1.0 : -1.0;
  // In a frame mirrored for a right turn the centre is on the left, (0, radius), and the base
  // drives counter-clockwise round it from the angle -pi/2.
  const Eigen::Vector2d from_centre(point.x(), side * point.y() - radius);
  const double turned = std::atan2(from_centre.x(), -from_centre.y());  // from (0, -radius), ccw
  ArcCoordinates result;
  result.off = side * (radius - from_centre.norm());
  if (turned > 0.0) result.along = radius * turned;
  return result;
}

}  // namespace

double RouteFollower::obstacleSpeedLimit(const std::vector<Eigen::Vector2d>& obstacles, const Lane* lane,
                                         std::string* reason) const {
  const double v_max = options_.controller.max_linear_velocity;
  const double r = options_.robot_radius;
  if (!(r > 0.0)) return v_max;
  // The corridor is the band the base sweeps along the arc it is commanded onto (the straight
  // corridor ahead when it drives straight): turning out of a corner it is not held back by someone
  // standing beside the leg it leaves (the room's guard, 0.65 m off the route, stood straight ahead
  // of the turning robot: 3-4 s of creeping per lap). At standstill the arc of the turn it starts.
  const VelocityCommand& command = controller_.state();
  const double curvature = command.angular / std::max(command.linear, kArcSpeedFloor * v_max);
  double gap = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector2d& o : obstacles) {
    if (lane == nullptr) {  // along the arc of the command the base drives
      const ArcCoordinates at = arcCoordinates(o, curvature);
      if (at.along && std::abs(at.off) < r) gap = std::min(gap, *at.along - r);
      continue;
    }
    // Passing beside: everything the base sweeps moving over from where it is to the lane and
    // along it (a person stepping towards the route while the robot has not yet moved over is in
    // its way: the gallery's visitor came within 0.18 m when only the lane itself was checked).
    // Pure pursuit has moved it over within about a lookahead; a point `ahead` on is checked
    // against the band from the lane to where the robot would be had it moved over only half as
    // fast (a visitor 0.8 m ahead and 0.29 m beside a robot 0.11 m off the line held it 4 s).
    const Eigen::Vector2d at = lane->coordinates(pose_.transformPoint(o));
    const double ahead = at.x(), lateral = at.y();
    const double moved_over = std::clamp(ahead / (2.0 * options_.pass_lookahead), 0.0, 1.0);
    const double slowest = lane->robot_lateral + moved_over * (lane->offset - lane->robot_lateral);
    const double low = std::min(slowest, lane->offset) - r, high = std::max(slowest, lane->offset) + r;
    if (ahead > 0.0 && lateral > low && lateral < high) gap = std::min(gap, ahead - r);
  }
  const double fraction = std::clamp(
      (gap - options_.obstacle_stop_gap) / (options_.obstacle_slow_gap - options_.obstacle_stop_gap), 0.0, 1.0);
  // No figure in the reason: controller_node publishes its state on every change.
  if (fraction < 1.0) *reason = fraction > 0.0 ? "slowed down: something in the way" : "waiting: something in the way";
  return fraction * v_max;
}

std::optional<RouteFollower::Lane> RouteFollower::passingLane(const std::vector<Eigen::Vector2d>& obstacles) {
  const double r = options_.robot_radius;
  const std::optional<double> kept = pass_lane_;
  pass_lane_.reset();
  if (!(options_.pass_offset > 0.0) || !(r > 0.0) || next_ == 0 || obstacles.empty()) return std::nullopt;
  const Pose2D& goal = goals_[static_cast<std::size_t>(sequence_[next_])];
  const Pose2D& previous = goals_[static_cast<std::size_t>(sequence_[next_ - 1])];
  Lane lane;
  lane.origin = Eigen::Vector2d(previous.x, previous.y);
  lane.along = Eigen::Vector2d(goal.x - previous.x, goal.y - previous.y);
  if (lane.along.norm() < options_.corner_radius) return std::nullopt;  // a turn in place
  lane.along.normalize();
  lane.left = Eigen::Vector2d(-lane.along.y(), lane.along.x());
  const Eigen::Vector2d robot_at = lane.coordinates(Eigen::Vector2d(pose_.x, pose_.y));  // robot_along still 0
  lane.robot_along = robot_at.x();
  lane.robot_lateral = robot_at.y();
  // The lateral offsets from the route's line of the points the robot passes from here to the end
  // of its slow-down distance and the lookahead (it moves over before it has to slow down).
  // Something is in the way when it is near the line or in the robot's own band (a robot a few
  // centimetres off the line, turning out of a corner, waited 4 s for the room's visitor pausing
  // 0.4 m beside the line: the line itself was clear, and the potential field turns far too gently
  // to get back onto it).
  std::vector<double> beside;
  bool in_the_way = false;
  const double clearance = r + options_.pass_clearance;
  for (const Eigen::Vector2d& o : obstacles) {
    const Eigen::Vector2d at = lane.coordinates(pose_.transformPoint(o));
    const double ahead = at.x(), lateral = at.y();
    if (ahead < -r || ahead > 2.0 * r + options_.obstacle_slow_gap + options_.pass_lookahead) continue;
    beside.push_back(lateral);
    in_the_way = in_the_way || std::abs(lateral) < clearance || std::abs(lateral - lane.robot_lateral) < r;
  }
  if (!in_the_way) return std::nullopt;
  // Towards a corner the robot must reach the goal within corner_tolerance to turn there: a lane
  // at most half of it off the line.
  const double tolerance = toleranceOf(next_);
  const double max_offset =
      tolerance < options_.controller.goal_tolerance ? std::min(options_.pass_offset, 0.5 * tolerance) : options_.pass_offset;
  auto free = [&](double offset) {
    if (std::abs(offset) > max_offset + 1e-9) return false;
    return std::none_of(beside.begin(), beside.end(),
                        [&](double l) { return std::abs(l - offset) < clearance - 1e-9; });
  };
  // The lane kept while it stays free, else the free one nearest the line (the line itself first).
  std::optional<double> best;
  if (kept && free(*kept)) {
    best = kept;
  } else {
    std::vector<double> offsets{0.0};
    for (const double l : beside) {
      offsets.push_back(l + clearance);
      offsets.push_back(l - clearance);
    }
    for (const double offset : offsets) {
      if (free(offset) && (!best || std::abs(offset) < std::abs(*best))) best = offset;
    }
  }
  if (!best) return std::nullopt;  // no lane: the corridor cap makes it wait
  pass_lane_ = lane.offset = *best;
  return lane;
}

}  // namespace homography_teach_repeat
