#include "rbpf_slam/core/diff_drive.h"

#include <algorithm>
#include <cmath>

namespace rbpf_slam
{
namespace core
{
bool OdometryConfig::validate(std::string* error) const
{
  auto fail = [&](const std::string& what) {
    if (error)
      *error = what;
    return false;
  };
  if (!(left_scale > 0.0) || !(right_scale > 0.0))
    return fail("odometry wheel scales must be > 0");
  if (!(wheel_sigma >= 0.0))
    return fail("odometry wheel_sigma must be >= 0");
  if (!(track_width > 0.0))
    return fail("odometry track_width must be > 0");
  if (!(rate > 0.0))
    return fail("odometry rate must be > 0");
  if (!(latency >= 0.0))
    return fail("odometry latency must be >= 0");
  return true;
}

DiffDriveRobot::DiffDriveRobot(const RobotConfig& robot, const OdometryConfig& odometry, const Pose2& start,
                               Random* random)
  : robot_(robot), odometry_(odometry), random_(random), pose_(start)
{
}

void DiffDriveRobot::step(const VelocityCommand& command, double dt)
{
  const double max_dv = robot_.max_linear_accel * dt, max_dw = robot_.max_angular_accel * dt;
  velocity_.linear += std::max(-max_dv, std::min(max_dv, command.linear - velocity_.linear));
  velocity_.angular += std::max(-max_dw, std::min(max_dw, command.angular - velocity_.angular));

  // The wheels turn as the drive demands for the commanded yaw rate on the effective (slipping)
  // track; the body turns at the commanded rate. Encoders see the wheels, not the body.
  const double effective_track = robot_.track_width * (1.0 + robot_.turn_slip);
  const double vl = velocity_.linear - 0.5 * velocity_.angular * effective_track;
  const double vr = velocity_.linear + 0.5 * velocity_.angular * effective_track;
  left_travel_ += vl * dt;
  right_travel_ += vr * dt;

  const double ds = velocity_.linear * dt, dth = velocity_.angular * dt;
  const double mid = pose_.theta + 0.5 * dth;
  pose_.x += ds * std::cos(mid);
  pose_.y += ds * std::sin(mid);
  pose_.theta = wrapAngle(pose_.theta + dth);
}

Pose2 DiffDriveRobot::readOdometry(double* linear_velocity, double* angular_velocity, double dt_since_last)
{
  auto measure = [&](double travel, double scale) {
    return scale * travel + random_->gaussian(odometry_.wheel_sigma * std::sqrt(std::abs(travel)));
  };
  const double l = measure(left_travel_, odometry_.left_scale);
  const double r = measure(right_travel_, odometry_.right_scale);
  left_travel_ = right_travel_ = 0.0;
  const double ds = 0.5 * (l + r), dth = (r - l) / odometry_.track_width;
  const double mid = odom_pose_.theta + 0.5 * dth;
  odom_pose_.x += ds * std::cos(mid);
  odom_pose_.y += ds * std::sin(mid);
  odom_pose_.theta = wrapAngle(odom_pose_.theta + dth);
  if (dt_since_last > 0.0)
  {
    *linear_velocity = ds / dt_since_last;
    *angular_velocity = dth / dt_since_last;
  }
  else
  {
    *linear_velocity = *angular_velocity = 0.0;
  }
  return odom_pose_;
}

}  // namespace core
}  // namespace rbpf_slam
