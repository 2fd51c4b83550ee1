#include "rbpf_slam/ros/path_follower_node.h"

#include <cmath>
#include <string>

#include <boost/make_shared.hpp>
#include <geometry_msgs/Twist.h>
#include <nav_msgs/Path.h>
#include <std_msgs/Bool.h>

#include "rbpf_slam/sim/waypoints_file.h"
#include "rbpf_slam/ros/params.h"

namespace rbpf_slam
{
PathFollowerNode::PathFollowerNode(ros::NodeHandle nh, ros::NodeHandle pnh)
{
  core::PathFollowerConfig config;
  std::string drive = "straight", frame = "odom";
  const RosParamSource params(pnh);
  readKey(params, "drive", &drive);
  readKey(params, "speed", &config.speed);
  readKey(params, "lookahead", &config.lookahead);
  readKey(params, "max_angular", &config.max_angular);
  readKey(params, "goal_tolerance", &config.goal_tolerance);
  readKey(params, "frame", &frame);
  warnUnknownKeys(params);
  std::string error;
  std::vector<Eigen::Vector2d> path = io::namedDrive(drive, &error);
  if (path.empty())
    throw invalidParameter(pnh, "drive", error);
  requirePositive(pnh, "speed", config.speed);
  requirePositive(pnh, "lookahead", config.lookahead);
  follower_.reset(new core::PathFollower(path, config));
  cmd_pub_ = nh.advertise<geometry_msgs::Twist>("cmd_vel", 10);
  done_pub_ = pnh.advertise<std_msgs::Bool>("done", 1, true);
  path_pub_ = pnh.advertise<nav_msgs::Path>("path", 1, true);
  odom_sub_ = nh.subscribe("odom", 50, &PathFollowerNode::onOdometry, this);

  nav_msgs::Path msg;
  msg.header.frame_id = frame;
  for (const auto& p : path)
  {
    geometry_msgs::PoseStamped pose;
    pose.header.frame_id = frame;
    pose.pose.position.x = p.x();
    pose.pose.position.y = p.y();
    pose.pose.orientation.w = 1.0;
    msg.poses.push_back(pose);
  }
  path_pub_.publish(msg);
  std_msgs::Bool done;
  done.data = false;
  done_pub_.publish(done);
  ROS_INFO("%s: following '%s' (%.1f m) at %.2f m/s on %s", pnh.getNamespace().c_str(), drive.c_str(),
           follower_->length(), config.speed, odom_sub_.getTopic().c_str());
}

void PathFollowerNode::onOdometry(const nav_msgs::Odometry::ConstPtr& msg)
{
  const auto& q = msg->pose.pose.orientation;
  const double yaw = std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
  if (!std::isfinite(msg->pose.pose.position.x) || !std::isfinite(msg->pose.pose.position.y) || !std::isfinite(yaw))
  {
    ROS_WARN_THROTTLE(5.0, "%s: odometry with NaN/Inf pose ignored; commanding a stop", odom_sub_.getTopic().c_str());
    cmd_pub_.publish(boost::make_shared<const geometry_msgs::Twist>());
    return;
  }
  const core::VelocityCommand cmd =
      follower_->command(core::Pose2(msg->pose.pose.position.x, msg->pose.pose.position.y, yaw));
  auto twist = boost::make_shared<geometry_msgs::Twist>();
  twist->linear.x = cmd.linear;
  twist->angular.z = cmd.angular;
  cmd_pub_.publish(geometry_msgs::Twist::ConstPtr(twist));
  if (follower_->done() && !announced_done_)
  {
    std_msgs::Bool done;
    done.data = true;
    done_pub_.publish(done);
    announced_done_ = true;
    ROS_INFO("%s: reached the end of the path", odom_sub_.getTopic().c_str());
  }
}

}  // namespace rbpf_slam
