#include "rbpf_slam/core/filter/skid_steer_odometry.h"

#include <cmath>
#include <stdexcept>

namespace rbpf_slam
{
namespace core
{
std::string SkidSteerConfig::validate() const
{
  if (!(std::isfinite(effective_track) && effective_track > 0.0))
    return "effective_track must be > 0";
  if (!(std::isfinite(imu_weight) && imu_weight >= 0.0 && imu_weight <= 1.0))
    return "imu_weight must be in [0, 1]";
  if (!(std::isfinite(still_distance) && still_distance >= 0.0))
    return "still_distance must be >= 0";
  return "";
}

SkidSteerOdometry::SkidSteerOdometry(const SkidSteerConfig& config) : config_(config)
{
  const std::string e = config_.validate();
  if (!e.empty())
    throw std::invalid_argument("skid-steer odometry: " + e);
}

std::string SkidSteerOdometry::addWheelAngles(double stamp, const std::vector<double>& angles, double wheel_radius)
{
  if (angles.size() < 4)
    return "fewer than 4 wheel positions";
  if (!wheel_angles_.empty())
  {
    const auto d = [&](int i) { return (angles[i] - wheel_angles_[i]) * wheel_radius; };
    if (!addEncoders(stamp, 0.5 * (d(1) + d(3)), 0.5 * (d(0) + d(2))))
      return "wheel angles not finite or stamp not after the previous";
  }
  wheel_angles_.assign(angles.begin(), angles.begin() + 4);
  return "";
}

bool SkidSteerOdometry::addGyro(double stamp, double yaw_rate)
{
  if (!std::isfinite(stamp) || !std::isfinite(yaw_rate) || stamp < gyro_stamp_)
    return false;
  // Rectangle rule with the previous reading over the interval up to this one.
  if (have_gyro_)
  {
    const double dt = stamp - gyro_stamp_;
    gyro_angle_ += gyro_rate_ * dt;
    gyro_time_ += dt;
  }
  gyro_stamp_ = stamp;
  gyro_rate_ = yaw_rate;
  have_gyro_ = true;
  return true;
}

bool SkidSteerOdometry::addEncoders(double stamp, double left, double right)
{
  if (!std::isfinite(stamp) || !std::isfinite(left) || !std::isfinite(right) || stamp < encoder_stamp_)
    return false;
  const double ds = 0.5 * (left + right);
  double dtheta = (right - left) / config_.effective_track;
  const bool still = std::abs(left) <= config_.still_distance && std::abs(right) <= config_.still_distance;
  if (gyro_time_ > 0.0)
  {
    if (still)
    {
      // Standing still: what the gyro integrated is its bias.
      bias_sum_ += gyro_angle_ / gyro_time_;
      ++bias_count_;
    }
    if (config_.imu_weight > 0.0)
    {
      const double gyro_dtheta = gyro_angle_ - gyroBias() * gyro_time_;
      dtheta = (1.0 - config_.imu_weight) * dtheta + config_.imu_weight * (still ? 0.0 : gyro_dtheta);
    }
  }
  gyro_angle_ = 0.0;
  gyro_time_ = 0.0;
  const double mid = pose_.theta + 0.5 * dtheta;
  pose_.x += ds * std::cos(mid);
  pose_.y += ds * std::sin(mid);
  pose_.theta = wrapAngle(pose_.theta + dtheta);
  encoder_stamp_ = stamp;
  return true;
}

}  // namespace core
}  // namespace rbpf_slam
