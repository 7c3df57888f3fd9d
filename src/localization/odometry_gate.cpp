#include "homography_teach_repeat/localization/odometry_gate.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace homography_teach_repeat {
namespace {

bool finitePose(const Pose2D& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.yaw); }

}  // namespace

void OdometryGateOptions::validate() const {
  auto check = [](double value, bool strictly_positive, const char* name) {
    if (!std::isfinite(value) || value < 0.0 || (strictly_positive && value == 0.0)) {
      throw std::invalid_argument(std::string("odometry gate: ") + name + " must be finite and " +
                                  (strictly_positive ? "> 0" : ">= 0"));
    }
  };
  check(position_tolerance, true, "position_tolerance");
  check(heading_tolerance, true, "heading_tolerance");
  check(drift_fraction, false, "drift_fraction");
  check(heading_drift_per_metre, false, "heading_drift_per_metre");
  check(rotation_drift_fraction, false, "rotation_drift_fraction");
  if (switch_after < 1) throw std::invalid_argument("odometry gate: switch_after must be >= 1");
  check(window, true, "window");
}

OdometryGate::OdometryGate(const OdometryGateOptions& options) : options_(options) { options_.validate(); }

void OdometryGate::reset() {
  switched_ = false;
  accepted_.clear();
  candidate_.reset();
  candidates_ = 0;
}

double OdometryGate::excess(const Anchor& anchor, const Pose2D& visual, const Pose2D& odometry,
                            std::string* description) const {
  const Pose2D motion = anchor.odometry.inverse().compose(odometry);
  const Pose2D predicted = anchor.visual.compose(motion);
  const double travelled = std::hypot(motion.x, motion.y);
  const double position_error = std::hypot(visual.x - predicted.x, visual.y - predicted.y);
  const double heading_error = std::abs(wrapToPi(visual.yaw - predicted.yaw));
  const double position_allowance = options_.position_tolerance + options_.drift_fraction * travelled;
  const double heading_allowance = options_.heading_tolerance + options_.heading_drift_per_metre * travelled +
                                   options_.rotation_drift_fraction * std::abs(motion.yaw);
  if (description != nullptr) {
    char text[200];
    std::snprintf(text, sizeof(text),
                  "%.2f m / %.1f deg from what odometry predicts (allowed %.2f m / %.1f deg after %.2f m, "
                  "%.1f deg of odometry motion)",
                  position_error, heading_error * 180.0 / M_PI, position_allowance,
                  heading_allowance * 180.0 / M_PI, travelled, std::abs(motion.yaw) * 180.0 / M_PI);
    *description = text;
  }
  return std::max(position_error / position_allowance, heading_error / heading_allowance) - 1.0;
}

void OdometryGate::accept(const Anchor& anchor) {
  accepted_.push_back(anchor);
  if (accepted_.size() > 300) accepted_.pop_front();  // e.g. a long turn in place
  // Keep the oldest accepted pose that is still within `window` of odometry travel.
  while (accepted_.size() > 1) {
    const Pose2D& second = accepted_[1].odometry;
    if (std::hypot(second.x - anchor.odometry.x, second.y - anchor.odometry.y) < options_.window) break;
    accepted_.pop_front();
  }
}

Status OdometryGate::agrees(const Pose2D& visual, const Pose2D& odometry) const {
  if (!finitePose(visual) || !finitePose(odometry)) {
    return Status(StatusCode::kInvalidInput, "odometry gate: non-finite visual or odometry pose");
  }
  if (accepted_.empty()) return Status::ok();
  std::string disagreement;
  if (excess(accepted_.back(), visual, odometry, &disagreement) <= 0.0 &&
      excess(accepted_.front(), visual, odometry, &disagreement) <= 0.0) {
    return Status::ok();
  }
  return Status(StatusCode::kNoConsensus, "visual pose refused: " + disagreement);
}

Status OdometryGate::check(const Pose2D& visual, const Pose2D& odometry) {
  switched_ = false;
  Status verdict = agrees(visual, odometry);
  if (verdict.code() == StatusCode::kInvalidInput) return verdict;
  const Anchor current{visual, odometry};
  if (verdict.isOk()) {
    accept(current);
    candidate_.reset();
    candidates_ = 0;
    return verdict;
  }
  // Refused: does it continue the run of refused poses?
  // (Compared with the first pose of the run, so that a run creeping away frame by frame does not
  // count as agreeing.)
  if (candidate_ && excess(*candidate_, visual, odometry, nullptr) <= 0.0) {
    ++candidates_;
  } else {
    candidate_ = current;
    candidates_ = 1;
  }
  if (candidates_ >= options_.switch_after) {
    accepted_.clear();
    accept(current);
    candidate_.reset();
    candidates_ = 0;
    switched_ = true;
    return Status::ok();
  }
  return verdict;
}

}  // namespace homography_teach_repeat
