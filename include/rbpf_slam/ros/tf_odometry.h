#ifndef RBPF_SLAM_ROS_TF_ODOMETRY_H
#define RBPF_SLAM_ROS_TF_ODOMETRY_H

#include <string>

#include <ros/time.h>
#include <tf2_ros/buffer.h>

#include "rbpf_slam/core/filter/pose2.h"

namespace rbpf_slam
{
/**
 * @brief Wheel odometry from TF (`odom -> base_link`, any chain between them) as poses at given stamps, for a
 * pipeline whose sensor messages wait for odometry (core::SensorPipeline): the grid node's odometry source.
 */
class TfOdometry
{
public:
  TfOdometry(const tf2_ros::Buffer* buffer, std::string odom_frame, std::string base_frame)
    : buffer_(buffer), odom_frame_(std::move(odom_frame)), base_frame_(std::move(base_frame))
  {
  }

  /** @brief What TF holds for a stamp. */
  enum class Answer
  {
    kFound,    ///< the pose at the stamp (interpolated by TF)
    kNotYet,   ///< no odometry after the stamp yet: it may still come
    kNever,    ///< odometry after the stamp is there, yet none at it: older than TF keeps, or in a gap
  };
  /** @brief The planar pose of base_link in odom at @p stamp; @p error says why not. */
  Answer at(const ros::Time& stamp, core::Pose2* pose, std::string* error) const;

private:
  const tf2_ros::Buffer* buffer_;
  std::string odom_frame_, base_frame_;
};

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_TF_ODOMETRY_H
