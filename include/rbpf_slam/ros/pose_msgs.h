#ifndef RBPF_SLAM_ROS_POSE_MSGS_H
#define RBPF_SLAM_ROS_POSE_MSGS_H

#include <cmath>

#include <string>

#include <Eigen/Eigenvalues>
#include <geometry_msgs/Pose.h>
#include <geometry_msgs/PoseArray.h>
#include <geometry_msgs/TransformStamped.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/Quaternion.h>
#include <nav_msgs/Path.h>
#include <ros/time.h>

#include "rbpf_slam/core/filter/pose2.h"

namespace rbpf_slam
{
/** @brief Heading (yaw about z) of a quaternion. */
inline double yawOf(const geometry_msgs::Quaternion& q)
{
  return std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
}

/**
 * @brief Why @p q is no orientation ("" when it is one): not finite, or not of unit length within 10 % (a driver
 * that fills nothing in sends all zeros, whose yaw would silently be 0).
 */
inline std::string quaternionProblem(const geometry_msgs::Quaternion& q)
{
  const double n = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (!std::isfinite(n))
    return "not finite";
  if (std::abs(n - 1.0) > 0.1)
    return "not a unit quaternion (length " + std::to_string(n) + ")";
  return "";
}

/** @brief The rotation by @p yaw about z. */
inline geometry_msgs::Quaternion quaternionOfYaw(double yaw)
{
  geometry_msgs::Quaternion q;
  q.z = std::sin(0.5 * yaw);
  q.w = std::cos(0.5 * yaw);
  return q;
}

/** @brief The planar part of @p p: x, y and the yaw of its orientation. */
inline core::Pose2 planarPose(const geometry_msgs::Pose& p)
{
  return core::Pose2(p.position.x, p.position.y, yawOf(p.orientation));
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

/**
 * @brief The pose estimate with its covariance (x, y, yaw in the 6x6 row-major layout). Identical particles
 * give a covariance whose smallest eigenvalues are rounding noise, sometimes negative: clamped to 0 so that
 * consumers (rviz's ellipse) can take square roots.
 */
inline geometry_msgs::PoseWithCovarianceStamped poseWithCovariance(const ros::Time& stamp, const std::string& frame,
                                                                   const core::Pose2& mean,
                                                                   const Eigen::Matrix3d& covariance)
{
  geometry_msgs::PoseWithCovarianceStamped m;
  m.header.stamp = stamp;
  m.header.frame_id = frame;
  m.pose.pose = toPoseMsg(mean);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(0.5 * (covariance + covariance.transpose()));
  const Eigen::Matrix3d c =
      eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
  const int idx[3] = { 0, 1, 5 };
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      m.pose.covariance[idx[i] * 6 + idx[j]] = c(i, j);
  return m;
}

/** @brief The particles' poses as a PoseArray (any container of items with a `pose` member). */
template <typename Particles>
geometry_msgs::PoseArray particleCloud(const ros::Time& stamp, const std::string& frame, const Particles& particles)
{
  geometry_msgs::PoseArray m;
  m.header.stamp = stamp;
  m.header.frame_id = frame;
  m.poses.reserve(particles.size());
  for (const auto& p : particles)
    m.poses.push_back(toPoseMsg(p.pose));
  return m;
}

/** @brief Appends @p pose to @p path (restamped), dropping the oldest poses beyond @p max_poses. */
/** @brief The planar transform @p parent -> @p child (e.g. map -> odom, REP-105) as a TF message. */
inline geometry_msgs::TransformStamped planarTransform(const ros::Time& stamp, const std::string& parent,
                                                      const std::string& child, const core::Pose2& pose)
{
  geometry_msgs::TransformStamped tf;
  tf.header.stamp = stamp;
  tf.header.frame_id = parent;
  tf.child_frame_id = child;
  tf.transform.translation.x = pose.x;
  tf.transform.translation.y = pose.y;
  tf.transform.rotation = quaternionOfYaw(pose.theta);
  return tf;
}

inline void appendToPath(nav_msgs::Path* path, const ros::Time& stamp, const std::string& frame,
                         const core::Pose2& pose, int max_poses)
{
  geometry_msgs::PoseStamped ps;
  ps.header.stamp = stamp;
  ps.header.frame_id = frame;
  ps.pose = toPoseMsg(pose);
  path->header.stamp = stamp;
  path->header.frame_id = frame;
  path->poses.push_back(ps);
  while (path->poses.size() > static_cast<std::size_t>(max_poses > 0 ? max_poses : 1))
    path->poses.erase(path->poses.begin());
}

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_POSE_MSGS_H
