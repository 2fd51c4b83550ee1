#include "rbpf_slam/sim/ackermann.h"

#include <algorithm>
#include <cmath>

namespace rbpf_slam
{
namespace sim
{
using core::Pose2;
using core::Random;
using core::wrapAngle;

namespace
{
constexpr double kMinSteeringSpeed = 0.05;  ///< [m/s] below this a command's yaw rate says nothing about steering

double clampAbs(double value, double limit)
{
  return std::max(-limit, std::min(limit, value));
}
}  // namespace

AckermannRobot::AckermannRobot(const RobotConfig& robot, const OdometryConfig& odometry, const Pose2& start,
                               Random* random)
  : robot_(robot), odometry_(odometry), random_(random), pose_(start)
{
}

void AckermannRobot::step(const VelocityCommand& command, double dt)
{
  if (std::abs(command.linear) > kMinSteeringSpeed)
    steer_target_ = clampAbs(std::atan(command.angular * robot_.wheelbase / command.linear), robot_.max_steer);
  const double max_dv = robot_.max_linear_accel * dt, max_ds = robot_.max_steer_rate * dt;
  speed_ += clampAbs(command.linear - speed_, max_dv);
  steer_ += clampAbs(steer_target_ - steer_, max_ds);

  const double ds = speed_ * dt;
  const double dth = ds * std::tan(steer_) / robot_.wheelbase;
  const double mid = pose_.theta + 0.5 * dth;
  pose_.x += ds * std::cos(mid);
  pose_.y += ds * std::sin(mid);
  pose_.theta = wrapAngle(pose_.theta + dth);
  travel_ += ds;
  velocity_.linear = speed_;
  velocity_.angular = speed_ * std::tan(steer_) / robot_.wheelbase;
}

void AckermannRobot::halt()
{
  speed_ = 0.0;
  velocity_ = VelocityCommand();
}

Pose2 AckermannRobot::readOdometry(double* linear_velocity, double* angular_velocity, double dt_since_last)
{
  const double ds = odometry_.speed_scale * travel_ +
                    random_->gaussian(odometry_.speed_sigma * std::sqrt(std::abs(travel_)));
  const double steer = steer_ + odometry_.steer_bias + random_->gaussian(odometry_.steer_sigma);
  travel_ = 0.0;
  return integrateOdometry(ds, ds * std::tan(steer) / odometry_.wheelbase, dt_since_last, &odom_pose_,
                           linear_velocity, angular_velocity);
}

}  // namespace sim
}  // namespace rbpf_slam
