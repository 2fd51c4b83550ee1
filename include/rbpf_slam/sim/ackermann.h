#ifndef RBPF_SLAM_SIM_ACKERMANN_H
#define RBPF_SLAM_SIM_ACKERMANN_H

#include "rbpf_slam/sim/diff_drive.h"

namespace rbpf_slam
{
namespace sim
{
/**
 * @brief A car: front-wheel steering, the kinematic bicycle model at the rear axle (base_link is the rear axle's
 * centre on the ground), a rear-wheel speed encoder and a steering-angle encoder.
 *
 * It takes the same velocity commands as the diff-drive robot: the steering angle that gives the commanded yaw
 * rate at the commanded speed, delta = atan(omega * wheelbase / v), clamped to max_steer (below 0.05 m/s the
 * steering stays where it is). Speed follows its command within max_linear_accel, steering within
 * max_steer_rate. True motion: x' = v cos(theta), y' = v sin(theta), theta' = v tan(delta) / wheelbase.
 *
 * Odometry (OdometryConfig): the travel of the rear wheels measured with speed_scale and a random walk of
 * speed_sigma, the steering angle read at each odometry read with steer_bias and noise steer_sigma; the odometry
 * turns by measured travel * tan(measured angle) / odometry wheelbase.
 */
class AckermannRobot : public Robot
{
public:
  AckermannRobot(const RobotConfig& robot, const OdometryConfig& odometry, const core::Pose2& start,
                 core::Random* random);

  void step(const VelocityCommand& command, double dt) override;
  const core::Pose2& pose() const override { return pose_; }
  const VelocityCommand& velocity() const override { return velocity_; }
  void halt() override;
  core::Pose2 readOdometry(double* linear_velocity, double* angular_velocity, double dt_since_last) override;

  /** @brief True steering angle [rad] (positive turns left). */
  double steering() const { return steer_; }

private:
  RobotConfig robot_;
  OdometryConfig odometry_;
  core::Random* random_;
  core::Pose2 pose_;
  VelocityCommand velocity_;
  double speed_ = 0.0;        ///< [m/s] rear axle
  double steer_ = 0.0;        ///< [rad]
  double steer_target_ = 0.0; ///< [rad] the last command's angle (kept while the command's speed is about 0)
  double travel_ = 0.0;       ///< true rear-axle travel since the last odometry read [m]
  core::Pose2 odom_pose_;
};

}  // namespace sim
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_SIM_ACKERMANN_H
