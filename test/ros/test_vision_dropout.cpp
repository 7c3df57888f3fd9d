// Vision drops out while the robot repeats a route in hybrid mode (issue 23), end to end in the
// simulator (test/launch/vision_dropout.test, vision_lost.test). Judged by the simulator's ground
// truth and what the nodes publish, in simulated time:
//  - expect "finish": the camera is covered for 3.2 m; the run still finishes within 0.10 m and 2°
//    of the start pose, the integrity was not OK while the camera saw nothing;
//  - expect "abort": the camera is covered for good; the repeat_route goal is aborted with the
//    reason within stop_abort_timeout (+ 3 s) of the LOST that lasted, and the robot then stands;
//  - both: no linear command while the pose is flagged LOST (beyond a 0.15 s grace for messages
//    crossing each other).
#include <gtest/gtest.h>

#include <actionlib/client/simple_action_client.h>
#include <geometry_msgs/Twist.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <std_msgs/String.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "homography_teach_repeat/Integrity.h"
#include "homography_teach_repeat/RepeatRouteAction.h"
#include "homography_teach_repeat/teach_repeat/route.h"
#include "node_test_helpers.h"

using namespace homography_teach_repeat;

namespace {

constexpr double kGrace = 0.15;  // [s] a command computed before the LOST report arrived

struct Timed {
  double time = 0.0;  // arrival, ROS (simulated) time
  double linear = 0.0, angular = 0.0;
  int level = 0;
  std::string fixes;
};

class VisionDropoutTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto route = loadRoute(private_nh_.param<std::string>("route_directory", ""));
    ASSERT_TRUE(route) << route.status().message();
    start_ = route->keyframes.front().pose;
    truth_sub_ = nh_.subscribe<nav_msgs::Odometry>("ground_truth", 50, [this](const auto& m) {
      const auto& q = m->pose.pose.orientation;
      truth_ = Pose2D(m->pose.pose.position.x, m->pose.pose.position.y, 2.0 * std::atan2(q.z, q.w));
      truth_speed_ = std::hypot(m->twist.twist.linear.x, m->twist.twist.angular.z);
    });
    command_sub_ = nh_.subscribe<geometry_msgs::Twist>("cmd_vel", 50, [this](const auto& m) {
      Timed c;
      c.time = ros::Time::now().toSec();
      c.linear = m->linear.x;
      c.angular = m->angular.z;
      commands_.push_back(c);
    });
    integrity_sub_ = nh_.subscribe<Integrity>("repeat_node/integrity", 50, [this](const auto& m) {
      Timed t;
      t.time = ros::Time::now().toSec();
      t.level = m->level;
      t.fixes = m->fixes;
      integrity_.push_back(t);
      if (m->level == Integrity::LOST && first_lost_ < 0.0) {
        first_lost_ = t.time;
        std::printf("first LOST at %.2f s: %s\n", t.time, m->reason.c_str());
      }
      // The start of the LOST run in effect (a report of another level ends a run).
      if (m->level != Integrity::LOST) {
        lost_since_ = -1.0;
      } else if (lost_since_ < 0.0) {
        lost_since_ = t.time;
      }
    });
    state_sub_ = nh_.subscribe<std_msgs::String>("controller_node/state", 10, [this](const auto& m) { state_ = m->data; });
  }

  // The integrity level in effect at `time` (the last report that arrived before it; -1: none).
  int levelAt(double time) const {
    int level = -1;
    for (const Timed& t : integrity_) {
      if (t.time > time) break;
      level = t.level;
    }
    return level;
  }

  // Linear commands while LOST was in effect both at the command and `kGrace` before it.
  int linearCommandsWhileLost() const {
    int violations = 0;
    for (const Timed& c : commands_) {
      if (std::abs(c.linear) > 1e-9 && levelAt(c.time) == Integrity::LOST && levelAt(c.time - kGrace) == Integrity::LOST) {
        ++violations;
        if (violations <= 5) std::printf("linear command %.3f m/s at %.2f s while LOST\n", c.linear, c.time);
      }
    }
    return violations;
  }

  ros::NodeHandle nh_, private_nh_{"~"};
  Pose2D start_, truth_;
  double truth_speed_ = 0.0;
  double first_lost_ = -1.0;
  double lost_since_ = -1.0;
  std::vector<Timed> commands_, integrity_;
  std::string state_;
  ros::Subscriber truth_sub_, command_sub_, integrity_sub_, state_sub_;
};

}  // namespace

TEST_F(VisionDropoutTest, RepeatBridgesOrAbortsAsExpected) {
  const std::string expect = private_nh_.param<std::string>("expect", "finish");
  const double timeout = private_nh_.param("timeout", 400.0);
  if (expect == "finish") {
    ASSERT_TRUE(test_support::spinUntil([&] { return state_.rfind("finished", 0) == 0; }, timeout))
        << "controller state after " << timeout << " s: '" << state_ << "'";
    ros::WallDuration(0.5).sleep();
    ros::spinOnce();
    const double end_distance = std::hypot(truth_.x - start_.x, truth_.y - start_.y);
    const double end_heading = std::abs(wrapToPi(truth_.yaw - start_.yaw));
    int without_fix = 0, not_ok = 0;
    for (const Timed& t : integrity_) {
      if (t.fixes.empty()) ++without_fix;
      if (t.level != Integrity::OK) ++not_ok;
    }
    std::printf("vision dropout: end %.3f m / %.2f deg from the start pose; %zu frames, %d without a fix, %d not OK\n",
                end_distance, end_heading * 180.0 / M_PI, integrity_.size(), without_fix, not_ok);
    RecordProperty("end_distance_m", std::to_string(end_distance));
    EXPECT_LT(end_distance, 0.10);
    EXPECT_LT(end_heading, 2.0 * M_PI / 180.0);
    EXPECT_GE(without_fix, 30);  // 3.2 m covered: many frames without a fix were bridged
    EXPECT_GE(not_ok, 10);       // and the integrity said so
  } else {
    using Client = actionlib::SimpleActionClient<RepeatRouteAction>;
    Client client(nh_, "repeat_route", false);
    ASSERT_TRUE(test_support::spinUntil([&] { return client.isServerConnected(); }, 30.0));
    RepeatRouteGoal goal;
    goal.start_index = 1;
    goal.end_index = -1;
    goal.laps = 1;
    client.sendGoal(goal);
    ASSERT_TRUE(test_support::spinUntil([&] { return client.getState().isDone(); }, timeout))
        << "no result after " << timeout << " s; controller: '" << state_ << "'";
    const double ended = ros::Time::now().toSec();
    EXPECT_EQ(client.getState(), actionlib::SimpleClientGoalState::ABORTED) << client.getState().toString();
    const auto result = client.getResult();
    ASSERT_TRUE(result);
    std::printf("vision lost: aborted at %.2f s (first LOST %.2f s, LOST since %.2f s): %s\n", ended, first_lost_,
                lost_since_, result->reason.c_str());
    EXPECT_FALSE(result->reached);
    EXPECT_NE(result->reason.find("LOST"), std::string::npos) << result->reason;
    ASSERT_GT(first_lost_, 0.0) << "never LOST";
    const double stop_abort_timeout = private_nh_.param("stop_abort_timeout", 15.0);
    // From the LOST that lasted: a transient one before it (under the sanitizers a slow frame at the
    // edge of the cover made "camera stopped" for a moment, 2026-12-02) lets the robot move again,
    // and the controller's stop timer starts anew.
    ASSERT_GT(lost_since_, 0.0) << "not LOST at the abort";
    EXPECT_LT(ended - lost_since_, stop_abort_timeout + 3.0);
    // Afterwards the robot stands: zero commands and no motion for 2 s.
    const std::size_t before = commands_.size();
    const double until = ended + 2.0;
    ASSERT_TRUE(test_support::spinUntil([&] { return ros::Time::now().toSec() > until; }, 60.0));
    for (std::size_t i = before; i < commands_.size(); ++i) {
      EXPECT_EQ(commands_[i].linear, 0.0);
      EXPECT_EQ(commands_[i].angular, 0.0);
    }
    EXPECT_LT(truth_speed_, 1e-3);
  }
  EXPECT_EQ(linearCommandsWhileLost(), 0);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_vision_dropout");
  return RUN_ALL_TESTS();
}
