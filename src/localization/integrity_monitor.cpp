#include "homography_teach_repeat/localization/integrity_monitor.h"

#include <Eigen/Eigenvalues>

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

namespace homography_teach_repeat {
namespace {

// sqrt of the 95 % quantiles of χ² with 2 and 1 degrees of freedom.
constexpr double kPosition95 = 2.4477;
constexpr double kHeading95 = 1.9600;
constexpr double kDegreesPerRadian = 180.0 / M_PI;

void requireOrdered(double degraded, double lost, const char* degraded_name, const char* lost_name) {
  if (!std::isfinite(degraded) || !(degraded > 0.0)) {
    throw std::invalid_argument(std::string("integrity_") + degraded_name + " must be finite and > 0");
  }
  if (!std::isfinite(lost) || lost < degraded) {
    throw std::invalid_argument(std::string("integrity_") + lost_name + " must be finite and >= integrity_" + degraded_name);
  }
}

std::string format(const char* pattern, double a, double b) {
  char text[200];
  std::snprintf(text, sizeof(text), pattern, a, b);
  return text;
}

}  // namespace

std::string toString(IntegrityLevel level) {
  switch (level) {
    case IntegrityLevel::kOk: return "OK";
    case IntegrityLevel::kDegraded: return "DEGRADED";
    case IntegrityLevel::kLost: return "LOST";
  }
  return "LOST";
}

void IntegrityOptions::validate() const {
  requireOrdered(degraded_position_bound, lost_position_bound, "degraded_position_bound", "lost_position_bound");
  requireOrdered(degraded_heading_bound, lost_heading_bound, "degraded_heading_bound", "lost_heading_bound");
  requireOrdered(degraded_time_without_fix, lost_time_without_fix, "degraded_time_without_fix",
                 "lost_time_without_fix");
  if (nis_window < 1) throw std::invalid_argument("integrity_nis_window must be >= 1");
  if (!std::isfinite(degraded_nis) || !(degraded_nis > 0.0)) {
    throw std::invalid_argument("integrity_degraded_nis must be finite and > 0");
  }
  if (degraded_refused_in_a_row < 1) throw std::invalid_argument("integrity_degraded_refused_in_a_row must be >= 1");
  if (lost_refused_in_a_row < degraded_refused_in_a_row) {
    throw std::invalid_argument("integrity_lost_refused_in_a_row must be >= integrity_degraded_refused_in_a_row");
  }
  if (degraded_min_inliers < 0) throw std::invalid_argument("integrity_degraded_min_inliers must be >= 0");
}

double positionBound95(const Eigen::Matrix3d& covariance) {
  if (!covariance.allFinite()) return std::numeric_limits<double>::infinity();
  const Eigen::Matrix2d position = covariance.topLeftCorner<2, 2>();
  const double largest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(position, Eigen::EigenvaluesOnly).eigenvalues()(1);
  return kPosition95 * std::sqrt(std::max(0.0, largest));
}

double headingBound95(const Eigen::Matrix3d& covariance) {
  if (!std::isfinite(covariance(2, 2))) return std::numeric_limits<double>::infinity();
  return kHeading95 * std::sqrt(std::max(0.0, covariance(2, 2)));
}

IntegrityMonitor::IntegrityMonitor(const IntegrityOptions& options) : options_(options) { options_.validate(); }

void IntegrityMonitor::reset() {
  nis_per_dof_.clear();
  refused_in_a_row_ = 0;
  last_refused_stamp_ = std::numeric_limits<double>::quiet_NaN();
  last_accepted_stamp_.reset();
  last_inliers_ = 0;
}

void IntegrityMonitor::addFix(double stamp, bool accepted, std::optional<double> nis, int dof, int inliers) {
  if (nis && std::isfinite(*nis) && dof > 0) {
    nis_per_dof_.push_back(*nis / dof);
    while (static_cast<int>(nis_per_dof_.size()) > options_.nis_window) nis_per_dof_.pop_front();
  }
  if (!accepted) {
    if (stamp != last_refused_stamp_) ++refused_in_a_row_;  // one count per frame
    last_refused_stamp_ = stamp;
    return;
  }
  if (stamp != last_refused_stamp_) refused_in_a_row_ = 0;
  if (std::isfinite(stamp)) last_accepted_stamp_ = stamp;
  last_inliers_ = inliers;
}

IntegrityReport IntegrityMonitor::assess(double stamp, const std::optional<Eigen::Matrix3d>& covariance,
                                         double distance_without_fix) const {
  IntegrityReport report;
  report.refused_in_a_row = refused_in_a_row_;
  report.distance_without_fix = distance_without_fix;
  report.inliers = last_inliers_;
  if (last_accepted_stamp_ && std::isfinite(stamp)) report.time_without_fix = std::max(0.0, stamp - *last_accepted_stamp_);
  if (!nis_per_dof_.empty()) {
    double sum = 0.0;
    for (const double v : nis_per_dof_) sum += v;
    report.nis_count = static_cast<int>(nis_per_dof_.size());
    report.nis_per_dof = sum / report.nis_count;
  }
  if (covariance) {
    report.position_bound = positionBound95(*covariance);
    report.heading_bound = headingBound95(*covariance);
  }
  const IntegrityOptions& o = options_;
  // LOST: no pose, or one too uncertain or too old to drive on, or lasting disagreement.
  std::string lost;
  if (!covariance) {
    lost = "no pose";
  } else if (report.position_bound > o.lost_position_bound) {
    lost = format("position uncertain: 95 %% bound %.2f m > lost_position_bound %.2f m", report.position_bound,
                  o.lost_position_bound);
  } else if (report.heading_bound > o.lost_heading_bound) {
    lost = format("heading uncertain: 95 %% bound %.1f deg > lost_heading_bound %.1f deg",
                  report.heading_bound * kDegreesPerRadian, o.lost_heading_bound * kDegreesPerRadian);
  } else if (report.time_without_fix > o.lost_time_without_fix) {
    lost = std::isfinite(report.time_without_fix)
               ? format("no accepted fix for %.1f s (lost_time_without_fix %.1f s)", report.time_without_fix,
                        o.lost_time_without_fix)
               : "no accepted fix yet";
  } else if (refused_in_a_row_ >= o.lost_refused_in_a_row) {
    lost = format("%.0f fixes refused in a row (lost_refused_in_a_row %.0f): vision and the filter disagree",
                  refused_in_a_row_, o.lost_refused_in_a_row);
  }
  if (!lost.empty()) {
    report.level = IntegrityLevel::kLost;
    report.reason = lost;
    return report;
  }
  std::string degraded;
  if (report.position_bound > o.degraded_position_bound) {
    degraded = format("position: 95 %% bound %.2f m > degraded_position_bound %.2f m", report.position_bound,
                      o.degraded_position_bound);
  } else if (report.heading_bound > o.degraded_heading_bound) {
    degraded = format("heading: 95 %% bound %.1f deg > degraded_heading_bound %.1f deg",
                      report.heading_bound * kDegreesPerRadian, o.degraded_heading_bound * kDegreesPerRadian);
  } else if (refused_in_a_row_ >= o.degraded_refused_in_a_row) {
    degraded = format("%.0f fix(es) refused in a row (degraded_refused_in_a_row %.0f): vision disagrees with the filter",
                      refused_in_a_row_, o.degraded_refused_in_a_row);
  } else if (report.nis_count > 0 && report.nis_per_dof > o.degraded_nis) {
    degraded = format("innovations too large: NIS per degree of freedom %.1f over the last fixes > degraded_nis %.1f",
                      report.nis_per_dof, o.degraded_nis);
  } else if (report.time_without_fix > o.degraded_time_without_fix) {
    degraded = format("no accepted fix for %.1f s (degraded_time_without_fix %.1f s)", report.time_without_fix,
                      o.degraded_time_without_fix);
  } else if (o.degraded_min_inliers > 0 && last_inliers_ < o.degraded_min_inliers) {
    degraded = format("last fix with %.0f inliers (degraded_min_inliers %.0f)", last_inliers_, o.degraded_min_inliers);
  }
  report.level = degraded.empty() ? IntegrityLevel::kOk : IntegrityLevel::kDegraded;
  report.reason = degraded;
  return report;
}

}  // namespace homography_teach_repeat
