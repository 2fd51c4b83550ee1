#ifndef RBPF_SLAM_ROS_PATH_FOLLOWER_NODE_H
#define RBPF_SLAM_ROS_PATH_FOLLOWER_NODE_H

#include <memory>

#include <nav_msgs/Odometry.h>
#include <ros/ros.h>

#include "rbpf_slam/sim/path_follower.h"

namespace rbpf_slam
{
/**
 * @brief Drives a path by pure pursuit on the robot's own odometry: one `cmd_vel` (Twist) for every
 * `odom` message, so a simulator in lockstep can wait for it. Publishes `~done` (latched) at the end.
 */
class PathFollowerNode
{
public:
  PathFollowerNode(ros::NodeHandle nh, ros::NodeHandle pnh);

private:
  void onOdometry(const nav_msgs::Odometry::ConstPtr& msg);

  ros::Subscriber odom_sub_;
  ros::Publisher cmd_pub_, done_pub_, path_pub_;
  std::unique_ptr<core::PathFollower> follower_;
  bool announced_done_ = false;
};

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_PATH_FOLLOWER_NODE_H
