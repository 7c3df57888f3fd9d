// IntegrityMonitor: OK / DEGRADED / LOST from the covariance's bounds, the refused fixes, the
// innovations and the time since the last fix; options validated naming the parameter.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "homography_teach_repeat/localization/integrity_monitor.h"

using namespace homography_teach_repeat;

namespace {

Eigen::Matrix3d covariance(double position_sigma, double heading_sigma) {
  return Eigen::Vector3d(position_sigma * position_sigma, position_sigma * position_sigma,
                         heading_sigma * heading_sigma)
      .asDiagonal();
}

bool mentions(const IntegrityReport& report, const std::string& text) {
  return report.reason.find(text) != std::string::npos;
}

}  // namespace

TEST(IntegrityMonitor, BoundsOfTheCovarianceDecideTheLevel) {
  IntegrityMonitor monitor;
  monitor.addFix(10.0, true, 3.0, 3, 80);
  // 95 % position bound = 2.4477 σ: 0.1 m σ is 0.245 m (OK), 0.15 m is 0.37 m (> 0.3 DEGRADED),
  // 0.5 m is 1.22 m (> 1.0 LOST).
  const IntegrityReport ok = monitor.assess(10.1, covariance(0.1, 0.01));
  EXPECT_EQ(ok.level, IntegrityLevel::kOk) << ok.reason;
  EXPECT_NEAR(ok.position_bound, 2.4477 * 0.1, 1e-4);
  EXPECT_NEAR(ok.heading_bound, 1.96 * 0.01, 1e-6);
  EXPECT_NEAR(ok.nis_per_dof, 1.0, 1e-12);
  EXPECT_EQ(ok.inliers, 80);
  const IntegrityReport wide = monitor.assess(10.1, covariance(0.15, 0.01));
  EXPECT_EQ(wide.level, IntegrityLevel::kDegraded);
  EXPECT_TRUE(mentions(wide, "degraded_position_bound")) << wide.reason;
  const IntegrityReport lost = monitor.assess(10.1, covariance(0.5, 0.01));
  EXPECT_EQ(lost.level, IntegrityLevel::kLost);
  EXPECT_TRUE(mentions(lost, "lost_position_bound")) << lost.reason;
  // Heading: 5° and 20° bounds (σ 3° → 5.9°, σ 11° → 21.6°).
  EXPECT_EQ(monitor.assess(10.1, covariance(0.01, 3.0 * M_PI / 180.0)).level, IntegrityLevel::kDegraded);
  EXPECT_EQ(monitor.assess(10.1, covariance(0.01, 11.0 * M_PI / 180.0)).level, IntegrityLevel::kLost);
  // The larger principal axis counts, not the diagonal: a correlated covariance.
  Eigen::Matrix3d correlated = covariance(0.09, 0.01);
  correlated(0, 1) = correlated(1, 0) = 0.9 * 0.09 * 0.09;
  EXPECT_NEAR(positionBound95(correlated), 2.4477 * 0.09 * std::sqrt(1.9), 1e-4);
  EXPECT_EQ(monitor.assess(10.1, correlated).level, IntegrityLevel::kDegraded);
  // No pose at all.
  const IntegrityReport none = monitor.assess(10.1, std::nullopt);
  EXPECT_EQ(none.level, IntegrityLevel::kLost);
  EXPECT_TRUE(mentions(none, "no pose"));
}

TEST(IntegrityMonitor, RefusedFixesInnovationsAndTimeWithoutAFix) {
  IntegrityOptions options;
  options.nis_window = 4;
  options.lost_refused_in_a_row = 3;
  options.degraded_time_without_fix = 2.0;
  options.lost_time_without_fix = 20.0;
  IntegrityMonitor monitor(options);
  const Eigen::Matrix3d small = covariance(0.02, 0.005);
  EXPECT_EQ(monitor.assess(1.0, small).level, IntegrityLevel::kLost);  // no fix yet
  EXPECT_TRUE(mentions(monitor.assess(1.0, small), "no accepted fix yet"));
  monitor.addFix(1.0, true, 2.0, 3, 50);
  EXPECT_EQ(monitor.assess(1.0, small).level, IntegrityLevel::kOk);
  // A refused fix: DEGRADED at once (vision and the filter disagree); an accepted μ fix of the same
  // frame does not clear it, the next frame's accepted fix does.
  monitor.addFix(1.1, false, std::nullopt, 0, 40);
  monitor.addFix(1.1, true, 0.5, 1, 12);
  IntegrityReport refused = monitor.assess(1.1, small);
  EXPECT_EQ(refused.level, IntegrityLevel::kDegraded);
  EXPECT_EQ(refused.refused_in_a_row, 1);
  EXPECT_TRUE(mentions(refused, "refused")) << refused.reason;
  monitor.addFix(1.2, false, std::nullopt, 0, 40);
  monitor.addFix(1.3, false, std::nullopt, 0, 40);
  EXPECT_EQ(monitor.assess(1.3, small).level, IntegrityLevel::kLost);
  monitor.addFix(1.4, true, 3.0, 3, 60);
  EXPECT_EQ(monitor.assess(1.4, small).level, IntegrityLevel::kOk) << monitor.assess(1.4, small).reason;
  // Innovations: the mean NIS per degree of freedom of the last 4 fixes above 4 is DEGRADED.
  monitor.addFix(1.5, true, 60.0, 3, 60);  // window: 2/3, 0.5, 1, 20 -> 5.5 per dof
  const IntegrityReport inconsistent = monitor.assess(1.5, small);
  EXPECT_EQ(inconsistent.level, IntegrityLevel::kDegraded);
  EXPECT_EQ(inconsistent.nis_count, 4);
  EXPECT_NEAR(inconsistent.nis_per_dof, (2.0 / 3.0 + 0.5 + 1.0 + 20.0) / 4.0, 1e-12);
  EXPECT_TRUE(mentions(inconsistent, "degraded_nis")) << inconsistent.reason;
  for (int i = 0; i < 4; ++i) monitor.addFix(1.6 + 0.1 * i, true, 3.0, 3, 60);
  EXPECT_EQ(monitor.assess(1.9, small).level, IntegrityLevel::kOk);
  // Time: DEGRADED after 2 s without a fix, LOST after 20 s.
  EXPECT_EQ(monitor.assess(3.0, small).level, IntegrityLevel::kOk);
  const IntegrityReport old = monitor.assess(4.5, small, 0.7);
  EXPECT_EQ(old.level, IntegrityLevel::kDegraded);
  EXPECT_NEAR(old.time_without_fix, 2.6, 1e-9);
  EXPECT_DOUBLE_EQ(old.distance_without_fix, 0.7);
  EXPECT_EQ(monitor.assess(22.0, small).level, IntegrityLevel::kLost);
  monitor.reset();
  EXPECT_EQ(monitor.assess(22.0, small).level, IntegrityLevel::kLost);
}

TEST(IntegrityMonitor, FewInliersDegradeWhenAsked) {
  IntegrityOptions options;
  options.degraded_min_inliers = 20;
  IntegrityMonitor monitor(options);
  monitor.addFix(1.0, true, std::nullopt, 0, 12);
  const IntegrityReport report = monitor.assess(1.0, covariance(0.01, 0.001));
  EXPECT_EQ(report.level, IntegrityLevel::kDegraded);
  EXPECT_TRUE(mentions(report, "12 inliers")) << report.reason;
  EXPECT_TRUE(std::isnan(report.nis_per_dof));  // no filter: no innovation
}

TEST(IntegrityMonitor, OptionsOutsideTheirRangeNameTheParameter) {
  const auto refused = [](void (*change)(IntegrityOptions&), const std::string& name) {
    IntegrityOptions options;
    change(options);
    try {
      options.validate();
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
      return;
    }
    ADD_FAILURE() << name << " accepted";
  };
  refused([](IntegrityOptions& o) { o.degraded_position_bound = 0.0; }, "integrity_degraded_position_bound");
  refused([](IntegrityOptions& o) { o.lost_position_bound = 0.2; }, "integrity_lost_position_bound");
  refused([](IntegrityOptions& o) { o.degraded_heading_bound = NAN; }, "integrity_degraded_heading_bound");
  refused([](IntegrityOptions& o) { o.lost_time_without_fix = 1.0; }, "integrity_lost_time_without_fix");
  refused([](IntegrityOptions& o) { o.nis_window = 0; }, "integrity_nis_window");
  refused([](IntegrityOptions& o) { o.degraded_nis = -1.0; }, "integrity_degraded_nis");
  refused([](IntegrityOptions& o) { o.degraded_refused_in_a_row = 0; }, "integrity_degraded_refused_in_a_row");
  refused([](IntegrityOptions& o) { o.lost_refused_in_a_row = 0; }, "integrity_lost_refused_in_a_row");
  refused([](IntegrityOptions& o) { o.degraded_min_inliers = -1; }, "integrity_degraded_min_inliers");
  EXPECT_THROW(IntegrityMonitor(IntegrityOptions{0.0}), std::invalid_argument);
  EXPECT_EQ(toString(IntegrityLevel::kDegraded), "DEGRADED");
}
