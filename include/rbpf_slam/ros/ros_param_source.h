#ifndef RBPF_SLAM_ROS_ROS_PARAM_SOURCE_H
#define RBPF_SLAM_ROS_ROS_PARAM_SOURCE_H

#include <set>
#include <stdexcept>
#include <string>

#include <ros/ros.h>

#include "rbpf_slam/io/param_source.h"

namespace rbpf_slam
{
/**
 * @brief The ROS parameter server (under a node handle's namespace) as a ParamSource. Remembers every key asked
 * for, so that the keys nobody asked for (typos) can be named (warnUnknownKeys in params.h).
 */
class RosParamSource : public io::ParamSource
{
public:
  explicit RosParamSource(const ros::NodeHandle& nh) : nh_(nh) {}
  bool get(const std::string& key, double* value) const override
  {
    asked_.insert(key);
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
  bool get(const std::string& key, int* value) const override
  {
    // roscpp would round a number with a fraction (30.5 particles become 31): only a whole number is an integer.
    asked_.insert(key);
    XmlRpc::XmlRpcValue v;
    if (!nh_.getParam(key, v))
      return false;
    if (v.getType() != XmlRpc::XmlRpcValue::TypeInt)
      throw std::runtime_error(nh_.resolveName(key) + " must be an integer");
    *value = static_cast<int>(v);
    return true;
  }
  bool get(const std::string& key, bool* value) const override { return typed(key, value, "true or false"); }
  bool get(const std::string& key, std::string* value) const override { return typed(key, value, "a string"); }
  bool get(const std::string& key, std::vector<std::string>* value) const
  {
    return typed(key, value, "a list of strings");
  }
  /** @brief Marks @p key (and every key below it) as known without reading it. */
  void markUsed(const std::string& key) const { asked_.insert(key); }
  const std::set<std::string>& asked() const { return asked_; }
  const ros::NodeHandle& nodeHandle() const { return nh_; }

private:
  template <typename T>
  bool typed(const std::string& key, T* value, const char* what) const
  {
    asked_.insert(key);
    if (!nh_.hasParam(key))
      return false;
    if (!nh_.getParam(key, *value))
      throw std::runtime_error(nh_.resolveName(key) + " must be " + what);
    return true;
  }
  ros::NodeHandle nh_;
  mutable std::set<std::string> asked_;
};

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_ROS_PARAM_SOURCE_H
