#ifndef RBPF_SLAM_SIM_DIFF_DRIVE_H
#define RBPF_SLAM_SIM_DIFF_DRIVE_H

#include <cmath>
#include <memory>
#include <string>

#include "rbpf_slam/core/filter/pose2.h"
#include "rbpf_slam/core/filter/random.h"
#include "rbpf_slam/sim/velocity_noise.h"

namespace rbpf_slam
{
namespace sim
{
/** @brief Which kinematics the simulated robot has. */
enum class RobotModel
{
  kDiffDrive,  ///< skid-steer / diff-drive (DiffDriveRobot); footprint a circle around base_link
  kAckermann,  ///< car with front-wheel steering (AckermannRobot); base_link at the rear axle's centre
};

/** @brief Parses "diff_drive" or "ackermann"; false for anything else. */
bool parseRobotModel(const std::string& name, RobotModel* model);
const char* robotModelName(RobotModel model);

/**
 * @brief True kinematics of the robot. The diff-drive keys apply to RobotModel::kDiffDrive, the car keys to
 * RobotModel::kAckermann; max_linear_accel to both.
 */
struct RobotConfig
{
  RobotModel model = RobotModel::kDiffDrive;
  double track_width = 1.2;        ///< [m] distance between the left and right wheels
  double turn_slip = 0.1;          ///< [-] skid steering: true yaw rate = (vr - vl) / (track * (1 + slip))
  double max_linear_accel = 1.0;   ///< [m/s^2] the robot follows commands within these limits
  double max_angular_accel = 2.0;  ///< [rad/s^2]
  double footprint_radius = 0.6;   ///< [m] diff drive: the circle around base_link that collides

  // Car (kinematic bicycle at the rear axle).
  double wheelbase = 2.8;                     ///< [m] rear axle to front axle
  double max_steer = 35.0 * M_PI / 180.0;     ///< [rad] steering angle limit (either side)
  double max_steer_rate = 30.0 * M_PI / 180.0; ///< [rad/s] how fast the steering follows its command
  double length = 4.5;                        ///< [m] body (the rectangle that collides)
  double width = 1.8;                         ///< [m]
  double rear_overhang = 0.85;                ///< [m] body behind the rear axle

  bool validate(std::string* error) const;
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
  /// Car: rear-wheel speed encoder, measured travel = speed_scale * true + N(0, speed_sigma^2 |true|), and a
  /// steering-angle encoder, measured = true + steer_bias + N(0, steer_sigma^2) at each read; the odometry turns
  /// by measured travel * tan(measured angle) / wheelbase.
  double speed_scale = 1.02;                   ///< [-]
  double speed_sigma = 0.01;                   ///< [m/sqrt(m)]
  double steer_bias = 0.5 * M_PI / 180.0;      ///< [rad]
  double steer_sigma = 0.1 * M_PI / 180.0;     ///< [rad] white noise of each read
  double wheelbase = 2.8;                      ///< [m] nominal wheelbase the odometry integrates with
  double rate = 50.0;           ///< [Hz]
  double latency = 0.03;        ///< [s] delivered this long after its measurement time (stamped with the latter)

  bool validate(std::string* error) const;
};

/** @brief A simulated robot: its true planar state and its odometry. */
class Robot
{
public:
  virtual ~Robot() = default;

  /** @brief Advances by @p dt towards @p command (acceleration-limited); integrates what the encoders see. */
  virtual void step(const VelocityCommand& command, double dt) = 0;
  /** @brief True pose in the world. */
  virtual const core::Pose2& pose() const = 0;
  /** @brief True body velocity (linear, angular). */
  virtual const VelocityCommand& velocity() const = 0;
  /** @brief Halts at once (a collision): zero velocity, the pose stays. */
  virtual void halt() = 0;
  /**
   * @brief Reads the encoders: integrates the measured travel since the last read into the odometry pose
   * (frame odom, starting at identity) and returns it.
   */
  virtual core::Pose2 readOdometry(double* linear_velocity, double* angular_velocity, double dt_since_last) = 0;

protected:
  /**
   * @brief What every odometry read ends with: moves @p odom by the measured arc (@p ds along the heading halfway
   * through the turn @p dth), sets the velocities over @p dt (0 for dt <= 0) and returns the new pose.
   */
  static core::Pose2 integrateOdometry(double ds, double dth, double dt, core::Pose2* odom, double* linear_velocity,
                                       double* angular_velocity);
};

/** @brief The robot of @p robot.model. @p random must outlive it. */
std::unique_ptr<Robot> makeRobot(const RobotConfig& robot, const OdometryConfig& odometry, const core::Pose2& start,
                                 core::Random* random);

/** @brief A diff-drive / skid-steer robot and its wheel odometry. */
class DiffDriveRobot : public Robot
{
public:
  DiffDriveRobot(const RobotConfig& robot, const OdometryConfig& odometry, const core::Pose2& start,
                 core::Random* random);

  void step(const VelocityCommand& command, double dt) override;
  const core::Pose2& pose() const override { return pose_; }
  const VelocityCommand& velocity() const override { return velocity_; }
  void halt() override { velocity_ = VelocityCommand(); }
  core::Pose2 readOdometry(double* linear_velocity, double* angular_velocity, double dt_since_last) override;

private:
  RobotConfig robot_;
  OdometryConfig odometry_;
  core::Random* random_;
  core::Pose2 pose_;
  VelocityCommand velocity_;
  double left_travel_ = 0.0;   ///< true travel since the last odometry read [m]
  double right_travel_ = 0.0;
  core::Pose2 odom_pose_;
};

}  // namespace sim
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_SIM_DIFF_DRIVE_H
