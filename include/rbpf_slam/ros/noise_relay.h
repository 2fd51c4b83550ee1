#ifndef RBPF_SLAM_ROS_NOISE_RELAY_H
#define RBPF_SLAM_ROS_NOISE_RELAY_H

#include <memory>

#include <geometry_msgs/Twist.h>
#include <geometry_msgs/TwistStamped.h>
#include <ros/ros.h>

#include "rbpf_slam/sim/velocity_noise.h"

namespace rbpf_slam
{
/**
 * @brief Relays velocity commands with Gaussian noise added (simulated motor noise).
 *
 * Subscribes `cmd_vel` and publishes `cmd_vel_noisy`, both relative to @p nh, as
 * geometry_msgs/Twist or (with `~stamped: true`) geometry_msgs/TwistStamped. Only linear.x and
 * angular.z (the diff-drive command) are perturbed; every other field passes through unchanged.
 */
class NoiseRelay
{
public:
  /** @brief Reads `~` parameters from @p pnh; on invalid ones logs an error and stays idle. */
  NoiseRelay(ros::NodeHandle nh, ros::NodeHandle pnh);

  /** @brief False when the parameters were invalid and nothing was subscribed. */
  bool ok() const { return static_cast<bool>(model_); }

private:
  void onTwist(const geometry_msgs::Twist::ConstPtr& msg);
  void onTwistStamped(const geometry_msgs::TwistStamped::ConstPtr& msg);
  /** @brief Fills @p out; false (message dropped, with a warning) for a non-finite command. */
  bool perturb(const geometry_msgs::Twist& in, geometry_msgs::Twist* out);

  ros::NodeHandle nh_;
  ros::Subscriber sub_;
  ros::Publisher pub_;
  std::unique_ptr<sim::VelocityNoiseModel> model_;
};

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_NOISE_RELAY_H
