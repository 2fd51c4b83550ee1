#ifndef RBPF_SLAM_ROS_PARAMS_H
#define RBPF_SLAM_ROS_PARAMS_H

#include <cstdint>
#include <string>

#include <exception>

#include <ros/ros.h>

#include "rbpf_slam/ros/ros_param_source.h"

namespace rbpf_slam
{
/** @brief Reads `~seed` (an int; negative values are reinterpreted as unsigned). */
inline std::uint64_t readSeed(const ros::NodeHandle& pnh, int default_seed = 0)
{
  int seed = default_seed;
  pnh.param("seed", seed, default_seed);
  return static_cast<std::uint64_t>(static_cast<std::int64_t>(seed));
}

/** @brief Reads one key; a value of the wrong type is reported (naming the key) and @p value kept. */
template <typename T>
void readKey(const RosParamSource& params, const std::string& key, T* value)
{
  try
  {
    params.get(key, value);
  }
  catch (const std::exception& e)
  {
    ROS_ERROR("%s; keeping %s at its default", e.what(), key.c_str());
  }
}

/** @brief Frame names must not be empty: an empty one is reported (naming the key) and @p fallback used. */
inline void requireFrame(const ros::NodeHandle& pnh, const char* key, std::string* frame, const std::string& fallback)
{
  if (!frame->empty())
    return;
  ROS_ERROR("%s must not be empty; using %s", pnh.resolveName(key).c_str(), fallback.c_str());
  *frame = fallback;
}

/**
 * @brief A core configuration read from the private parameters with its io reader (e.g.
 * io::readFastSlamConfig), and `~seed`. A wrong type or an invalid value is reported (naming the key) and
 * the whole configuration falls back to its defaults, so a nodelet never starts half-configured.
 */
template <typename Config>
Config readCoreConfig(const ros::NodeHandle& pnh, void (*reader)(const io::ParamSource&, Config*), const char* what)
{
  Config c;
  try
  {
    reader(RosParamSource(pnh), &c);
  }
  catch (const std::exception& e)
  {
    ROS_ERROR("%s: %s; using the default %s configuration", pnh.getNamespace().c_str(), e.what(), what);
    c = Config();
  }
  c.seed = readSeed(pnh);
  return c;
}

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_PARAMS_H
