#include "rbpf_slam/ros/path_follower_node.h"

#include <cmath>
#include <string>

#include <boost/make_shared.hpp>
#include <geometry_msgs/Twist.h>
#include <nav_msgs/Path.h>
#include <std_msgs/Bool.h>
#include <tf2/exceptions.h>

#include "rbpf_slam/ros/cloud_conversions.h"

#include "rbpf_slam/sim/waypoints_file.h"
#include "rbpf_slam/ros/params.h"

namespace rbpf_slam
{
PathFollowerNode::PathFollowerNode(ros::NodeHandle nh, ros::NodeHandle pnh)
{
  sim::PathFollowerConfig& config = config_;
  std::string drive = "straight", frame = "odom";
  const RosParamSource params(pnh);
  readKey(params, "drive", &drive);
  readKey(params, "speed", &config.speed);
  readKey(params, "lookahead", &config.lookahead);
  readKey(params, "max_angular", &config.max_angular);
  readKey(params, "goal_tolerance", &config.goal_tolerance);
  readKey(params, "frame", &frame);
  readKey(params, "avoid_obstacles", &config.avoid_obstacles);
  readKey(params, "robot_radius", &config.robot_radius);
  readKey(params, "clearance", &config.clearance);
  readKey(params, "min_clearance", &config.min_clearance);
  readKey(params, "max_departure", &config.max_departure);
  readKey(params, "horizon", &config.horizon);
  readKey(params, "max_curvature", &config.max_curvature);
  readKey(params, "obstacle_memory", &config.obstacle_memory);
  readKey(params, "obstacle_range", &config.obstacle_range);
  readKey(params, "obstacle_min_height", &config.obstacle_min_height);
  readKey(params, "obstacle_max_height", &config.obstacle_max_height);
  readKey(params, "obstacle_min_extent", &config.obstacle_min_extent);
  readKey(params, "base_frame", &base_frame_);
  readKey(params, "level_with_imu", &level_with_imu_);
  warnUnknownKeys(params);
  std::string error;
  std::vector<Eigen::Vector2d> path = sim::namedDrive(drive, &error);
  if (path.empty())
    throw invalidParameter(pnh, "drive", error);
  requirePositive(pnh, "speed", config.speed);
  requirePositive(pnh, "lookahead", config.lookahead);
  if (!config.validate(&error))
    throw invalidParameter(pnh, "avoid_obstacles", error);
  follower_.reset(new sim::PathFollower(path, config));
  cmd_pub_ = nh.advertise<geometry_msgs::Twist>("cmd_vel", 10);
  done_pub_ = pnh.advertise<std_msgs::Bool>("done", 1, true);
  path_pub_ = pnh.advertise<nav_msgs::Path>("path", 1, true);
  odom_sub_ = nh.subscribe("odom", 50, &PathFollowerNode::onOdometry, this);
  if (config.avoid_obstacles)
  {
    tf_buffer_.reset(new tf2_ros::Buffer());
    tf_listener_.reset(new tf2_ros::TransformListener(*tf_buffer_));
    if (level_with_imu_)  // first: a cloud may come before the constructor has returned
      imu_sub_ = nh.subscribe("imu/data", 100, &PathFollowerNode::onImu, this);
    cloud_sub_ = nh.subscribe("points", 5, &PathFollowerNode::onCloud, this);
    scan_sub_ = nh.subscribe("scan", 10, &PathFollowerNode::onScan, this);
  }

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
  ROS_INFO("%s: following '%s' (%.1f m) at %.2f m/s on %s%s", pnh.getNamespace().c_str(), drive.c_str(),
           follower_->length(), config.speed, odom_sub_.getTopic().c_str(),
           config.avoid_obstacles ? ", avoiding what the lidar sees" : "");
}

bool PathFollowerNode::mount(const std::string& frame, Eigen::Isometry3d* transform)
{
  const auto it = mounts_.find(frame);
  if (it != mounts_.end())
  {
    *transform = it->second;
    return true;
  }
  geometry_msgs::TransformStamped t;
  try
  {
    t = tf_buffer_->lookupTransform(base_frame_, frame, ros::Time(0));
  }
  catch (const tf2::TransformException& e)
  {
    ROS_WARN_THROTTLE(5.0, "%s: no transform %s -> %s yet (%s); its obstacles are ignored",
                      odom_sub_.getTopic().c_str(), frame.c_str(), base_frame_.c_str(), e.what());
    return false;
  }
  const auto& q = t.transform.rotation;
  const auto& p = t.transform.translation;
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  m.linear() = Eigen::Quaterniond(q.w, q.x, q.y, q.z).normalized().toRotationMatrix();
  m.translation() = Eigen::Vector3d(p.x, p.y, p.z);
  mounts_[frame] = m;  // a sensor's mount is static
  *transform = m;
  return true;
}

void PathFollowerNode::onCloud(const sensor_msgs::PointCloud2::ConstPtr& msg)
{
  Eigen::Isometry3d m;
  if (!mount(msg->header.frame_id, &m))
    return;
  CloudPoints cloud;
  const std::string problem = readCloud(*msg, &cloud);
  if (!problem.empty())
  {
    ROS_WARN_THROTTLE(5.0, "%s: cloud ignored: %s", cloud_sub_.getTopic().c_str(), problem.c_str());
    return;
  }
  Eigen::Matrix3d level = Eigen::Matrix3d::Identity();
  if (level_with_imu_)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (gravity_.ready())
      level = gravity_.levelling();
    else
      ROS_WARN_ONCE("%s: no accelerometer on %s (yet): clouds are taken as level until one comes (the simulator's is "
                    "imu/enabled; ~level_with_imu false for a robot without one)", cloud_sub_.getTopic().c_str(),
                    imu_sub_.getTopic().c_str());
  }
  std::vector<Eigen::Vector3d> points;
  points.reserve(cloud.points.size());
  for (const auto& p : cloud.points)
    points.push_back(level * (m * p.cast<double>()));
  const std::vector<Eigen::Vector2d> obstacles = sim::obstaclesFromCloud(points, config_);
  std::lock_guard<std::mutex> lock(mutex_);
  follower_->addObstacles(msg->header.stamp.toSec(), pose_, obstacles);
}

void PathFollowerNode::onScan(const sensor_msgs::LaserScan::ConstPtr& msg)
{
  Eigen::Isometry3d m;
  if (!mount(msg->header.frame_id, &m))
    return;
  const Eigen::Vector3d x = m.linear().col(0);
  const core::Pose2 mount2(m.translation().x(), m.translation().y(), std::atan2(x.y(), x.x()));
  const std::vector<Eigen::Vector2d> obstacles = sim::obstaclesFromScan(
      msg->ranges, msg->angle_min, msg->angle_increment, msg->range_min, msg->range_max, mount2, config_);
  std::lock_guard<std::mutex> lock(mutex_);
  follower_->addObstacles(msg->header.stamp.toSec(), pose_, obstacles);
}

void PathFollowerNode::onImu(const sensor_msgs::Imu::ConstPtr& msg)
{
  Eigen::Vector3d f(msg->linear_acceleration.x, msg->linear_acceleration.y, msg->linear_acceleration.z);
  Eigen::Isometry3d m;
  if (!msg->header.frame_id.empty() && msg->header.frame_id != base_frame_)
  {
    if (!mount(msg->header.frame_id, &m))
      return;
    f = m.linear() * f;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (!gravity_.add(msg->header.stamp.toSec(), f))
    ROS_WARN_THROTTLE(5.0, "%s: accelerometer sample ignored (not finite, or not near 1 g: %.2f m/s^2)",
                      imu_sub_.getTopic().c_str(), f.norm());
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
  sim::VelocityCommand cmd;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    pose_ = core::Pose2(msg->pose.pose.position.x, msg->pose.pose.position.y, yaw);
    cmd = follower_->command(pose_);
  }
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
