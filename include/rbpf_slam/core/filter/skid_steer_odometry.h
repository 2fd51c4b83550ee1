#ifndef RBPF_SLAM_CORE_FILTER_SKID_STEER_ODOMETRY_H
#define RBPF_SLAM_CORE_FILTER_SKID_STEER_ODOMETRY_H

#include <string>
#include <vector>

#include "rbpf_slam/core/filter/pose2.h"

namespace rbpf_slam
{
namespace core
{
/** @brief Dead reckoning of a skid-steer robot from wheel encoders, optionally with a gyro for heading. */
struct SkidSteerConfig
{
  /// [m] effective track: skid steering turns less than the wheel geometry says, so this is wider than the
  /// real track (ESE 650: 1.85 x the mean of 311.15 and 476.25 mm, the data README's estimate).
  double effective_track = 0.7283;
  /// How much of each heading increment comes from the gyro: 0 = encoders only, 1 = gyro only.
  double imu_weight = 0.0;
  /// A period with both wheel increments below this [m] counts as standing still: its gyro readings
  /// estimate the gyro's bias (running mean).
  double still_distance = 1e-6;

  std::string validate() const;
};

/**
 * @brief Integrates wheel increments (Δs = (e_R + e_L) / 2, Δθ = (e_R - e_L) / w_eff, midpoint heading) and,
 * with imu_weight > 0, blends the gyro's integrated yaw rate (bias-corrected) into each heading increment.
 */
class SkidSteerOdometry
{
public:
  explicit SkidSteerOdometry(const SkidSteerConfig& config = SkidSteerConfig());

  /**
   * @brief Wheel travel since the previous call [m] (left, right), read at @p stamp [s].
   * @return false (and nothing changes) when the stamp goes backwards or an input is not finite.
   */
  bool addEncoders(double stamp, double left, double right);
  /**
   * @brief Cumulative wheel angles [rad] of a four-wheel robot, front right, front left, rear right, rear left (the
   * order of the ESE 650 logs' JointState), read at @p stamp; the wheels' travel since the previous reading is their
   * change times @p wheel_radius [m], each side the mean of its two wheels (addEncoders). The first reading only sets
   * the reference.
   * @return empty, or why the reading was refused (and nothing changes): fewer than four angles, an angle not
   * finite, or the stamp not after the previous.
   */
  std::string addWheelAngles(double stamp, const std::vector<double>& angles, double wheel_radius);
  /** @brief A gyro yaw rate [rad/s] measured at @p stamp; false when refused (backwards, not finite). */
  bool addGyro(double stamp, double yaw_rate);

  const Pose2& pose() const { return pose_; }
  double stamp() const { return encoder_stamp_; }
  /** @brief The current gyro bias estimate [rad/s]. */
  double gyroBias() const { return bias_count_ > 0 ? bias_sum_ / bias_count_ : 0.0; }

private:
  SkidSteerConfig config_;
  Pose2 pose_;
  std::vector<double> wheel_angles_;  // the last reading of addWheelAngles (empty before the first)
  double encoder_stamp_ = -1e300;
  double gyro_stamp_ = -1e300;
  double gyro_rate_ = 0.0;
  bool have_gyro_ = false;
  double gyro_angle_ = 0.0;  // integrated raw gyro since the last encoder read [rad]
  double gyro_time_ = 0.0;   // time covered by gyro_angle_ [s]
  double bias_sum_ = 0.0;
  long bias_count_ = 0;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FILTER_SKID_STEER_ODOMETRY_H
