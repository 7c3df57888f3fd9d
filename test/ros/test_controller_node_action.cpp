// controller_node's action server (repeat_route) and dynamic_reconfigure.
#include <gtest/gtest.h>

#include <actionlib/client/simple_action_client.h>
#include <dynamic_reconfigure/Reconfigure.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/Twist.h>
#include <ros/ros.h>
#include <std_msgs/String.h>

#include <cmath>
#include <string>
#include <vector>

#include "homography_teach_repeat/RepeatRouteAction.h"
#include "homography_teach_repeat/teach_repeat/route.h"
#include "node_test_helpers.h"

using namespace homography_teach_repeat;
using Client = actionlib::SimpleActionClient<RepeatRouteAction>;

namespace {

class ControllerActionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string directory;
    ASSERT_TRUE(ros::NodeHandle("~").getParam("route", directory));
    const auto route = loadRoute(directory);
    ASSERT_TRUE(route.isOk()) << route.status().toString();
    for (const auto& k : route->keyframes) keyframes_.push_back(k.pose);
    pose_pub_ = nh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", 5);
    cmd_sub_ = nh_.subscribe<geometry_msgs::Twist>("cmd_vel", 10, [this](const auto& m) {
      command_ = *m;
      ++commands_;
    });
    state_sub_ = nh_.subscribe<std_msgs::String>("controller_node/state", 10,
                                                 [this](const auto& m) { state_ = m->data; });
    client_ = std::make_unique<Client>(nh_, "repeat_route", false);
    ASSERT_TRUE(test_support::spinUntil(
        [&] { return client_->isServerConnected() && pose_pub_.getNumSubscribers() > 0; }, 30.0));
  }

  void publishPose(const Pose2D& pose) {
    geometry_msgs::PoseWithCovarianceStamped message;
    message.header.stamp = ros::Time::now();
    message.header.frame_id = "map";
    message.pose.pose.position.x = pose.x;
    message.pose.pose.position.y = pose.y;
    message.pose.pose.orientation.z = std::sin(pose.yaw / 2);
    message.pose.pose.orientation.w = std::cos(pose.yaw / 2);
    pose_pub_.publish(message);
  }

  bool waitForResult(double timeout) {
    return test_support::spinUntil([&] { return client_->getState().isDone(); }, timeout);
  }

  ros::NodeHandle nh_;
  std::vector<Pose2D> keyframes_;
  ros::Publisher pose_pub_;
  ros::Subscriber cmd_sub_, state_sub_;
  geometry_msgs::Twist command_;
  int commands_ = 0;
  std::string state_;
  std::unique_ptr<Client> client_;
};

}  // namespace

// autostart false: idle, nothing on cmd_vel. A goal over the whole route: feedback while the
// (simulated) robot is placed at each goal in turn, then SUCCEEDED with reached = true.
TEST_F(ControllerActionTest, IdleThenFollowsAGoalToTheEnd) {
  ASSERT_TRUE(test_support::spinUntil([&] { return !state_.empty(); }, 5.0));
  EXPECT_EQ(state_.rfind("idle", 0), 0u) << state_;
  ros::WallDuration(0.3).sleep();
  ros::spinOnce();
  EXPECT_EQ(commands_, 0);

  RepeatRouteGoal goal;  // empty route_directory: the node's ~route_directory
  goal.start_index = 0;
  goal.end_index = -1;
  goal.laps = 1;
  std::vector<RepeatRouteFeedback> feedback;
  client_->sendGoal(goal, Client::SimpleDoneCallback(), Client::SimpleActiveCallback(),
                    [&](const RepeatRouteFeedbackConstPtr& f) { feedback.push_back(*f); });
  // The robot is wherever the current goal is: every goal is reached in turn.
  ASSERT_TRUE(test_support::spinUntil(
      [&] { return client_->getState().isDone(); }, 30.0,
      [&] {
        const int goal_index = feedback.empty() ? 0 : std::max(0, feedback.back().goal_index);
        publishPose(keyframes_[static_cast<std::size_t>(goal_index)]);
      },
      0.05));
  EXPECT_EQ(client_->getState(), actionlib::SimpleClientGoalState::SUCCEEDED);
  const auto result = client_->getResult();
  EXPECT_TRUE(result->reached);
  EXPECT_EQ(result->reason, "reached");
  EXPECT_DOUBLE_EQ(result->progress, 100.0);
  ASSERT_FALSE(feedback.empty());
  EXPECT_LE(feedback.front().progress, feedback.back().progress);
  // The goals come in order. (The first feedback messages may be published before the client's
  // feedback subscription is connected: under the sanitizer the first one seen was goal 3, the
  // goals within goal_tolerance of the start being reached at once.)
  // goal_index -1: past the last goal.
  int previous = 0;
  for (std::size_t i = 0; i < feedback.size(); ++i) {
    if (feedback[i].goal_index < 0) continue;
    EXPECT_LE(previous, feedback[i].goal_index) << "feedback " << i;
    previous = feedback[i].goal_index;
  }
  EXPECT_GE(feedback.front().goal_index, 0);
  EXPECT_LE(feedback.front().goal_index, 3);
}

TEST_F(ControllerActionTest, RefusesABadGoal) {
  RepeatRouteGoal goal;
  goal.start_index = 99;
  goal.end_index = -1;
  goal.laps = 1;
  client_->sendGoal(goal);
  ASSERT_TRUE(waitForResult(10.0));
  EXPECT_EQ(client_->getState(), actionlib::SimpleClientGoalState::ABORTED);
  EXPECT_FALSE(client_->getResult()->reached);
  EXPECT_NE(client_->getResult()->reason.find("start_index"), std::string::npos) << client_->getResult()->reason;

  goal.start_index = 0;
  goal.route_directory = "/nonexistent/route";
  client_->sendGoal(goal);
  ASSERT_TRUE(waitForResult(10.0));
  EXPECT_EQ(client_->getState(), actionlib::SimpleClientGoalState::ABORTED);
  EXPECT_NE(client_->getResult()->reason.find("/nonexistent/route"), std::string::npos)
      << client_->getResult()->reason;
}

// The robot drives towards a goal; cancelling preempts the goal and the command is zero.
TEST_F(ControllerActionTest, PreemptionStopsTheRobot) {
  RepeatRouteGoal goal;
  goal.start_index = keyframes_.size() - 1;
  goal.end_index = -1;
  goal.laps = 1;
  client_->sendGoal(goal);
  const Pose2D away(keyframes_.back().x - 2.0, keyframes_.back().y, 0.0);
  ASSERT_TRUE(test_support::spinUntil([&] { return command_.linear.x > 0.05; }, 10.0,
                                      [&] { publishPose(away); }, 0.05));
  client_->cancelGoal();
  ASSERT_TRUE(waitForResult(5.0));
  EXPECT_EQ(client_->getState(), actionlib::SimpleClientGoalState::PREEMPTED);
  ASSERT_TRUE(test_support::spinUntil([&] { return command_.linear.x == 0.0; }, 2.0));
}

// No localization for longer than stop_abort_timeout (1 s here): ABORTED with the reason.
TEST_F(ControllerActionTest, AbortsWhenLocalizationStaysAway) {
  RepeatRouteGoal goal;
  goal.start_index = 0;
  goal.end_index = -1;
  goal.laps = 2;
  client_->sendGoal(goal);
  ASSERT_TRUE(waitForResult(10.0));
  EXPECT_EQ(client_->getState(), actionlib::SimpleClientGoalState::ABORTED);
  EXPECT_NE(client_->getResult()->reason.find("stop_abort_timeout"), std::string::npos)
      << client_->getResult()->reason;
  EXPECT_EQ(command_.linear.x, 0.0);
}

// dynamic_reconfigure: a lower speed limit applies to the running goal.
TEST_F(ControllerActionTest, ReconfiguredSpeedLimitApplies) {
  dynamic_reconfigure::Reconfigure srv;
  dynamic_reconfigure::DoubleParameter limit;
  limit.name = "max_linear_velocity";
  limit.value = 0.1;
  srv.request.config.doubles.push_back(limit);
  ASSERT_TRUE(ros::service::waitForService("controller_node/set_parameters", ros::Duration(10.0)));
  ASSERT_TRUE(ros::service::call("controller_node/set_parameters", srv));
  bool applied = false;
  for (const auto& d : srv.response.config.doubles) {
    if (d.name == "max_linear_velocity") applied = std::abs(d.value - 0.1) < 1e-9;
  }
  EXPECT_TRUE(applied);
  RepeatRouteGoal goal;
  goal.start_index = keyframes_.size() - 1;
  goal.end_index = -1;
  goal.laps = 1;
  client_->sendGoal(goal);
  const Pose2D away(keyframes_.back().x - 3.0, keyframes_.back().y, 0.0);
  double fastest = 0.0;
  test_support::spinUntil([&] { fastest = std::max(fastest, command_.linear.x); return false; }, 3.0,
                          [&] { publishPose(away); }, 0.05);
  EXPECT_GT(fastest, 0.05);
  EXPECT_LE(fastest, 0.1 + 1e-9);
  client_->cancelGoal();
  ASSERT_TRUE(waitForResult(5.0));
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_controller_node_action");
  return RUN_ALL_TESTS();
}
