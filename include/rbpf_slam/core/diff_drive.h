#ifndef RBPF_SLAM_CORE_DIFF_DRIVE_H
#define RBPF_SLAM_CORE_DIFF_DRIVE_H

#include <string>

#include "rbpf_slam/core/pose2.h"
#include "rbpf_slam/core/random.h"
#include "rbpf_slam/core/velocity_noise.h"

namespace rbpf_slam
{
namespace core
{
/** @brief True kinematics of a diff-drive / skid-steer robot. */
struct RobotConfig
{
  double track_width = 1.2;        ///< [m] distance between the left and right wheels
  double turn_slip = 0.1;          ///< [-] skid steering: true yaw rate = (vr - vl) / (track * (1 + slip))
  double max_linear_accel = 1.0;   ///< [m/s^2] the robot follows commands within these limits
  double max_angular_accel = 2.0;  ///< [rad/s^2]
};

/**
 * @brief What the wheel encoders see. The measured travel of each wheel is
 * scale_side * true_travel + N(0, sigma^2 * |true_travel|): a scale mismatch between sides (the
 * systematic part that makes dead reckoning curve) and a random walk (the per-wheel noise).
 */
struct OdometryConfig
{
  double left_scale = 1.0025;   ///< [-] measured / true travel, left wheel
  double right_scale = 0.9975;  ///< [-] right wheel
  double wheel_sigma = 0.01;    ///< [m/sqrt(m)] random-walk noise of each wheel's travel
  double track_width = 1.2;     ///< [m] the track the odometry integrates with (nominal)
  double rate = 50.0;           ///< [Hz]
  double latency = 0.03;        ///< [s] delivered this long after its measurement time (stamped with the latter)

  bool validate(std::string* error) const;
};

/** @brief The robot's true planar state and its wheel odometry. */
class DiffDriveRobot
{
public:
  DiffDriveRobot(const RobotConfig& robot, const OdometryConfig& odometry, const Pose2& start, Random* random);

  /** @brief Advances by @p dt towards @p command (acceleration-limited); integrates wheel travel. */
  void step(const VelocityCommand& command, double dt);

  /** @brief True pose in the world. */
  const Pose2& pose() const { return pose_; }
  /** @brief True body velocity (linear, angular). */
  const VelocityCommand& velocity() const { return velocity_; }

  /**
   * @brief Reads the encoders: integrates the measured wheel travel since the last read into the
   * odometry pose (frame odom, starting at identity) and returns it.
   */
  Pose2 readOdometry(double* linear_velocity, double* angular_velocity, double dt_since_last);

private:
  RobotConfig robot_;
  OdometryConfig odometry_;
  Random* random_;
  Pose2 pose_;
  VelocityCommand velocity_;
  double left_travel_ = 0.0;   ///< true travel since the last odometry read [m]
  double right_travel_ = 0.0;
  Pose2 odom_pose_;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_DIFF_DRIVE_H
