// Whether the published pose can be trusted right now (docs/math.md §7.2, docs/reliability.md):
// OK, DEGRADED (drive slowly: the pose may be more than the bound off, or vision disagrees with
// the filter) or LOST (do not drive on it), with the reason and the numbers it was decided from:
//  - the pose's own 95 % bounds from its covariance: position 2.45 σ of the larger axis (χ², 2
//    degrees of freedom), heading 1.96 σ. An honest covariance makes "the bound is above 0.3 m"
//    the statement "the pose may be more than 0.3 m off";
//  - the filter's consistency: the mean normalized innovation squared per degree of freedom of
//    the last `nis_window` fixes (1 for a consistent filter), and the fixes refused in a row (the
//    odometry gate, the μ innovation gate: vision and the filter disagree, one of them is wrong);
//  - the time and the odometry distance since the last accepted fix;
//  - the last fix's inliers.
// The monitor is ROS-free; repeat_node publishes its report on ~integrity and in its diagnostics,
// the controller slows down on DEGRADED and stops on LOST.
#pragma once

#include <Eigen/Core>

#include <deque>
#include <limits>
#include <optional>
#include <string>

namespace homography_teach_repeat {

enum class IntegrityLevel { kOk = 0, kDegraded = 1, kLost = 2 };
// "OK", "DEGRADED", "LOST".
std::string toString(IntegrityLevel level);

struct IntegrityOptions {
  // Position: the 95 % bound [m] above which the pose is DEGRADED / LOST (0 < degraded <= lost).
  double degraded_position_bound = 0.3;
  double lost_position_bound = 1.0;
  // Heading: the 95 % bound [rad] (0 < degraded <= lost).
  double degraded_heading_bound = 0.0873;  // 5°
  double lost_heading_bound = 0.349;       // 20°
  // Consistency: the fixes in the window (>= 1), the mean NIS per degree of freedom above which
  // the pose is DEGRADED (> 0; a consistent filter averages 1), and the refused fixes in a row
  // that make it DEGRADED (>= 1) and LOST (>= degraded_refused_in_a_row).
  int nis_window = 10;
  double degraded_nis = 4.0;
  int degraded_refused_in_a_row = 1;
  int lost_refused_in_a_row = 30;
  // Time [s] since the last accepted fix (0 < degraded <= lost): a safeguard for a covariance that
  // grows too slowly while the pose is bridged on odometry. Not shorter: bridged poses whose bounds
  // are small are right (the simulator's room with the camera covered for 1.5 m a lap: at 2 s, 9 %
  // of the right poses were flagged). The controller slows down while bridging on its own.
  double degraded_time_without_fix = 10.0;
  double lost_time_without_fix = 30.0;
  // An accepted fix with fewer inliers makes the pose DEGRADED (>= 0; 0: never).
  int degraded_min_inliers = 0;

  void validate() const;  // throws std::invalid_argument naming the bad field
};

struct IntegrityReport {
  IntegrityLevel level = IntegrityLevel::kLost;
  std::string reason;  // empty when OK
  double position_bound = std::numeric_limits<double>::infinity();  // [m], 95 %
  double heading_bound = std::numeric_limits<double>::infinity();   // [rad], 95 %
  double nis_per_dof = std::numeric_limits<double>::quiet_NaN();    // mean over the window; NaN: no NIS
  int nis_count = 0;                                                // fixes with a NIS in the window
  int refused_in_a_row = 0;
  double time_without_fix = std::numeric_limits<double>::infinity();      // [s]
  double distance_without_fix = std::numeric_limits<double>::quiet_NaN();  // [m]; NaN: unknown
  int inliers = 0;  // of the last accepted fix
};

class IntegrityMonitor {
 public:
  explicit IntegrityMonitor(const IntegrityOptions& options = {});  // validates

  // A fix tried at `stamp` [s]: accepted or refused; its normalized innovation squared over `dof`
  // components (nullopt: the mode has none, e.g. fast_hd without a filter); its inliers. A frame
  // with a refused fix counts as refused even when another fix of it (same stamp) was accepted: a μ
  // fix taken does not answer a Fast-HD pose that disagrees by half a metre.
  void addFix(double stamp, bool accepted, std::optional<double> nis, int dof, int inliers);
  // The verdict at `stamp` on a pose with `covariance` (x, y, yaw; nullopt: no pose, or no
  // covariance), `distance_without_fix` [m] of odometry since the last accepted fix (NaN: unknown).
  IntegrityReport assess(double stamp, const std::optional<Eigen::Matrix3d>& covariance,
                         double distance_without_fix = std::numeric_limits<double>::quiet_NaN()) const;
  // Forget everything (a new run).
  void reset();
  const IntegrityOptions& options() const { return options_; }

 private:
  IntegrityOptions options_;
  std::deque<double> nis_per_dof_;  // of the last fixes with a NIS, newest last
  int refused_in_a_row_ = 0;
  double last_refused_stamp_ = std::numeric_limits<double>::quiet_NaN();
  std::optional<double> last_accepted_stamp_;
  int last_inliers_ = 0;
};

// The 95 % bounds of a (x, y, yaw) covariance: position 2.45 σ of the larger principal axis,
// heading 1.96 σ; infinite for a non-finite covariance.
double positionBound95(const Eigen::Matrix3d& covariance);
double headingBound95(const Eigen::Matrix3d& covariance);

}  // namespace homography_teach_repeat
