#ifndef RBPF_SLAM_ROS_PATH_FOLLOWER_NODE_H
#define RBPF_SLAM_ROS_PATH_FOLLOWER_NODE_H

#include <map>
#include <memory>
#include <mutex>
#include <string>

#include <Eigen/Geometry>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include "rbpf_slam/sim/path_follower.h"

namespace rbpf_slam
{
/**
 * @brief Drives a path by pure pursuit on the robot's own odometry: one `cmd_vel` (Twist) for every
 * `odom` message, so a simulator in lockstep can wait for it. Publishes `~done` (latched) at the end.
 * With `~avoid_obstacles` (default true), its local planner steers around what the lidar sees: the 3D cloud on
 * `points` and the planar scan on `scan`, put on base_link by TF (the sensor's mount, looked up once per frame).
 * With `~level_with_imu` (default true) the cloud is levelled by the roll and pitch of the accelerometer on
 * `imu/data` (sensor_msgs/Imu, its linear acceleration, averaged over 1 s), as the simulated follower's is: on a
 * slope a trunk seen 1.8 m up lies 0.13 m from its foot in the tilted body's x-y.
 */
class PathFollowerNode
{
public:
  PathFollowerNode(ros::NodeHandle nh, ros::NodeHandle pnh);

private:
  void onOdometry(const nav_msgs::Odometry::ConstPtr& msg);
  void onCloud(const sensor_msgs::PointCloud2::ConstPtr& msg);
  void onScan(const sensor_msgs::LaserScan::ConstPtr& msg);
  void onImu(const sensor_msgs::Imu::ConstPtr& msg);
  /** @brief The mount of sensor frame @p frame on base_link (false until TF has it). */
  bool mount(const std::string& frame, Eigen::Isometry3d* transform);

  std::mutex mutex_;  ///< the follower, between the odometry and the sensor callbacks
  sim::PathFollowerConfig config_;
  std::string base_frame_ = "base_link";
  core::Pose2 pose_;  ///< the latest odometry pose
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::map<std::string, Eigen::Isometry3d> mounts_;
  ros::Subscriber odom_sub_, cloud_sub_, scan_sub_, imu_sub_;
  bool level_with_imu_ = true;
  sim::GravityLevel gravity_;  ///< under mutex_
  ros::Publisher cmd_pub_, done_pub_, path_pub_;
  std::unique_ptr<sim::PathFollower> follower_;
  bool announced_done_ = false;
};

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_PATH_FOLLOWER_NODE_H
