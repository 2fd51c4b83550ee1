#include "rbpf_slam/ros/noise_relay.h"

#include <cmath>
#include <string>

#include <boost/make_shared.hpp>

#include "rbpf_slam/ros/params.h"

namespace rbpf_slam
{
NoiseRelay::NoiseRelay(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh)
{
  sim::VelocityNoiseConfig config;
  const RosParamSource params(pnh);
  readKey(params, "linear_sigma_abs", &config.linear_sigma_abs);
  readKey(params, "linear_sigma_rel", &config.linear_sigma_rel);
  readKey(params, "angular_sigma_abs", &config.angular_sigma_abs);
  readKey(params, "angular_sigma_rel", &config.angular_sigma_rel);
  readKey(params, "max_linear", &config.max_linear);
  readKey(params, "max_angular", &config.max_angular);
  bool stamped = false;
  readKey(params, "stamped", &stamped);
  const std::uint64_t seed = readSeed(params);
  warnUnknownKeys(params);

  std::string error;
  if (!config.validate(&error))
    throw std::runtime_error("invalid parameter: " + error);
  model_.reset(new sim::VelocityNoiseModel(config, seed));

  if (stamped)
  {
    pub_ = nh_.advertise<geometry_msgs::TwistStamped>("cmd_vel_noisy", 10);
    sub_ = nh_.subscribe("cmd_vel", 10, &NoiseRelay::onTwistStamped, this);
  }
  else
  {
    pub_ = nh_.advertise<geometry_msgs::Twist>("cmd_vel_noisy", 10);
    sub_ = nh_.subscribe("cmd_vel", 10, &NoiseRelay::onTwist, this);
  }
  ROS_INFO("%s: relaying %s -> %s (%s), sigma linear %.3f m/s + %.1f %%, angular %.3f rad/s + %.1f %%, seed %llu",
           pnh.getNamespace().c_str(), sub_.getTopic().c_str(), pub_.getTopic().c_str(),
           stamped ? "TwistStamped" : "Twist", config.linear_sigma_abs, 100.0 * config.linear_sigma_rel,
           config.angular_sigma_abs, 100.0 * config.angular_sigma_rel, static_cast<unsigned long long>(seed));
}

bool NoiseRelay::perturb(const geometry_msgs::Twist& in, geometry_msgs::Twist* out)
{
  const double values[] = { in.linear.x, in.linear.y, in.linear.z, in.angular.x, in.angular.y, in.angular.z };
  for (double v : values)
  {
    if (!std::isfinite(v))
    {
      ROS_WARN_THROTTLE(5.0, "%s: dropping a velocity command with a NaN or Inf field", sub_.getTopic().c_str());
      return false;
    }
  }
  *out = in;
  const sim::VelocityCommand noisy = model_->apply({ in.linear.x, in.angular.z });
  out->linear.x = noisy.linear;
  out->angular.z = noisy.angular;
  return true;
}

void NoiseRelay::onTwist(const geometry_msgs::Twist::ConstPtr& msg)
{
  // Nobody listens: skip the work (and the random draws) entirely.
  if (pub_.getNumSubscribers() == 0)
    return;
  auto out = boost::make_shared<geometry_msgs::Twist>();
  if (perturb(*msg, out.get()))
    pub_.publish(geometry_msgs::Twist::ConstPtr(out));
}

void NoiseRelay::onTwistStamped(const geometry_msgs::TwistStamped::ConstPtr& msg)
{
  if (pub_.getNumSubscribers() == 0)
    return;
  auto out = boost::make_shared<geometry_msgs::TwistStamped>();
  out->header = msg->header;
  if (perturb(msg->twist, &out->twist))
    pub_.publish(geometry_msgs::TwistStamped::ConstPtr(out));
}

}  // namespace rbpf_slam
