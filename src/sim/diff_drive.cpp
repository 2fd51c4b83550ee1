#include "rbpf_slam/sim/diff_drive.h"

#include <algorithm>
#include <cmath>

#include "rbpf_slam/sim/ackermann.h"

namespace rbpf_slam
{
namespace sim
{
using core::Pose2;
using core::Random;
using core::wrapAngle;

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
  if (!(speed_scale > 0.0) || !(speed_sigma >= 0.0))
    return fail("odometry speed_scale must be > 0 and speed_sigma >= 0");
  if (!std::isfinite(steer_bias) || std::abs(steer_bias) >= 0.5 * M_PI || !(steer_sigma >= 0.0))
    return fail("odometry steer_bias_deg must be within (-90, 90) and steer_sigma_deg >= 0");
  if (!(wheelbase > 0.0))
    return fail("odometry wheelbase must be > 0");
  if (!(rate > 0.0))
    return fail("odometry rate must be > 0");
  if (!(latency >= 0.0))
    return fail("odometry latency must be >= 0");
  return true;
}

bool parseRobotModel(const std::string& name, RobotModel* model)
{
  if (name == "diff_drive")
    *model = RobotModel::kDiffDrive;
  else if (name == "ackermann")
    *model = RobotModel::kAckermann;
  else
    return false;
  return true;
}

const char* robotModelName(RobotModel model)
{
  return model == RobotModel::kAckermann ? "ackermann" : "diff_drive";
}

bool RobotConfig::validate(std::string* error) const
{
  auto fail = [&](const std::string& what) {
    if (error)
      *error = what;
    return false;
  };
  if (!(track_width > 0.0) || !(turn_slip > -1.0))
    return fail("robot track_width must be > 0 and turn_slip > -1");
  if (!(max_linear_accel > 0.0) || !(max_angular_accel > 0.0))
    return fail("robot max_linear_accel and max_angular_accel must be > 0");
  if (!(footprint_radius >= 0.0))
    return fail("robot footprint_radius must be >= 0");
  if (!(wheelbase > 0.0) || !(max_steer > 0.0) || !(max_steer < 0.5 * M_PI) || !(max_steer_rate > 0.0))
    return fail("robot wheelbase must be > 0, max_steer_deg within (0, 90), max_steer_rate_deg > 0");
  if (!(length >= 0.0) || !(width >= 0.0) || !(rear_overhang >= 0.0) || !(rear_overhang <= length))
    return fail("robot length and width must be >= 0, rear_overhang within [0, length]");
  return true;
}

std::unique_ptr<Robot> makeRobot(const RobotConfig& robot, const OdometryConfig& odometry, const Pose2& start,
                                 Random* random)
{
  if (robot.model == RobotModel::kAckermann)
    return std::unique_ptr<Robot>(new AckermannRobot(robot, odometry, start, random));
  return std::unique_ptr<Robot>(new DiffDriveRobot(robot, odometry, start, random));
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
  return integrateOdometry(0.5 * (l + r), (r - l) / odometry_.track_width, dt_since_last, &odom_pose_,
                           linear_velocity, angular_velocity);
}

Pose2 Robot::integrateOdometry(double ds, double dth, double dt, Pose2* odom, double* linear_velocity,
                               double* angular_velocity)
{
  const double mid = odom->theta + 0.5 * dth;
  odom->x += ds * std::cos(mid);
  odom->y += ds * std::sin(mid);
  odom->theta = wrapAngle(odom->theta + dth);
  *linear_velocity = dt > 0.0 ? ds / dt : 0.0;
  *angular_velocity = dt > 0.0 ? dth / dt : 0.0;
  return *odom;
}

}  // namespace sim
}  // namespace rbpf_slam
