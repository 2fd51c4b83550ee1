#ifndef RBPF_SLAM_ROS_ROS_PARAM_SOURCE_H
#define RBPF_SLAM_ROS_ROS_PARAM_SOURCE_H

#include <stdexcept>
#include <string>

#include <ros/ros.h>

#include "rbpf_slam/io/param_source.h"

namespace rbpf_slam
{
/** @brief The ROS parameter server (under a node handle's namespace) as a ParamSource. */
class RosParamSource : public io::ParamSource
{
public:
  explicit RosParamSource(const ros::NodeHandle& nh) : nh_(nh) {}
  bool get(const std::string& key, double* value) const override
  {
    XmlRpc::XmlRpcValue v;
    if (!nh_.getParam(key, v))
      return false;
    if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble)
      *value = static_cast<double>(v);
    else if (v.getType() == XmlRpc::XmlRpcValue::TypeInt)
      *value = static_cast<int>(v);
    else
      throw std::runtime_error(nh_.resolveName(key) + " must be a number");
    return true;
  }
  bool get(const std::string& key, int* value) const override { return typed(key, value, "an integer"); }
  bool get(const std::string& key, bool* value) const override { return typed(key, value, "true or false"); }
  bool get(const std::string& key, std::string* value) const override { return typed(key, value, "a string"); }

private:
  template <typename T>
  bool typed(const std::string& key, T* value, const char* what) const
  {
    if (!nh_.hasParam(key))
      return false;
    if (!nh_.getParam(key, *value))
      throw std::runtime_error(nh_.resolveName(key) + " must be " + what);
    return true;
  }
  ros::NodeHandle nh_;
};

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_ROS_PARAM_SOURCE_H
