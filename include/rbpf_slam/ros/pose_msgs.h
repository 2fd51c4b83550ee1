#ifndef RBPF_SLAM_ROS_POSE_MSGS_H
#define RBPF_SLAM_ROS_POSE_MSGS_H

#include <cmath>

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Quaternion.h>

#include "rbpf_slam/core/pose2.h"

namespace rbpf_slam
{
/** @brief Heading (yaw about z) of a quaternion. */
inline double yawOf(const geometry_msgs::Quaternion& q)
{
  return std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
}

/** @brief The rotation by @p yaw about z. */
inline geometry_msgs::Quaternion quaternionOfYaw(double yaw)
{
  geometry_msgs::Quaternion q;
  q.z = std::sin(0.5 * yaw);
  q.w = std::cos(0.5 * yaw);
  return q;
}

/** @brief A planar pose as a geometry_msgs/Pose (z = 0). */
inline geometry_msgs::Pose toPoseMsg(const core::Pose2& p)
{
  geometry_msgs::Pose m;
  m.position.x = p.x;
  m.position.y = p.y;
  m.orientation = quaternionOfYaw(p.theta);
  return m;
}

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_POSE_MSGS_H
