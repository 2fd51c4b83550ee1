#ifndef RBPF_SLAM_ROS_PARAMS_H
#define RBPF_SLAM_ROS_PARAMS_H

#include <cmath>
#include <cstdint>
#include <exception>
#include <stdexcept>
#include <string>
#include <vector>

#include <ros/ros.h>

#include "rbpf_slam/ros/ros_param_source.h"

namespace rbpf_slam
{
// Every node reads its parameters through one RosParamSource and refuses to start (throws from its
// constructor, so the nodelet fails to load and a node exits non-zero) on a value of the wrong type or out of
// range, naming the key; keys that nothing read are warned by name (warnUnknownKeys).

/**
 * @brief The node's clock for the stamp rule's future test [s]: ros::Time::now(), or NaN while simulated time has
 * not started (no /clock yet), so that the first messages of a bag played with --clock are not taken as early.
 */
inline double clockForStamps()
{
  const ros::Time now = ros::Time::now();
  return now.isZero() ? NAN : now.toSec();
}

/** @brief Reads `~seed` (an int; negative values are reinterpreted as unsigned). */
inline std::uint64_t readSeed(const RosParamSource& params, int default_seed = 0)
{
  int seed = default_seed;
  params.get("seed", &seed);
  return static_cast<std::uint64_t>(static_cast<std::int64_t>(seed));
}

/** @brief Reads one key if present; a value of the wrong type throws naming the key. */
template <typename T>
void readKey(const RosParamSource& params, const std::string& key, T* value)
{
  params.get(key, value);
}

inline std::runtime_error invalidParameter(const ros::NodeHandle& pnh, const std::string& key, const std::string& what)
{
  return std::runtime_error("invalid parameter " + pnh.resolveName(key) + ": " + what);
}

/** @brief Frame names must not be empty. */
inline void requireFrame(const ros::NodeHandle& pnh, const char* key, const std::string& frame)
{
  if (frame.empty())
    throw invalidParameter(pnh, key, "must not be empty");
}

inline void requireNonNegative(const ros::NodeHandle& pnh, const char* key, double value)
{
  if (!(std::isfinite(value) && value >= 0.0))
    throw invalidParameter(pnh, key, "must be a finite number >= 0, not " + std::to_string(value));
}

inline void requirePositive(const ros::NodeHandle& pnh, const char* key, double value)
{
  if (!(std::isfinite(value) && value > 0.0))
    throw invalidParameter(pnh, key, "must be a finite number > 0, not " + std::to_string(value));
}

/** @brief The parameters both SLAM nodes share: REP-105 frames, map -> odom publication, path length, time jumps. */
struct SlamRosConfig
{
  std::string map_frame = "map";
  std::string odom_frame = "odom";
  std::string base_frame = "base_link";
  double transform_tolerance = 0.1;   ///< [s] map -> odom is stamped this far after the update
  bool publish_tf = true;
  int max_path_poses = 5000;          ///< oldest poses of `path` are dropped beyond this (it is sent whole)
  double time_jump_threshold = 1.0;   ///< [s] see core::StampGate: a larger jump back restarts the filter
  /// [s] wall time a sensor message waits for odometry that covers its stamp; then it is processed with the newest
  /// odometry (warned). The same policy in both SLAM nodes (core::PipelineTiming::odometry_wait).
  double odom_timeout = 0.5;
};

/** @brief Reads and checks the SlamRosConfig keys (a bad value throws, naming the key). */
inline void readSlamRosConfig(const RosParamSource& params, SlamRosConfig* c)
{
  const ros::NodeHandle& pnh = params.nodeHandle();
  readKey(params, "map_frame", &c->map_frame);
  readKey(params, "odom_frame", &c->odom_frame);
  readKey(params, "base_frame", &c->base_frame);
  readKey(params, "transform_tolerance", &c->transform_tolerance);
  readKey(params, "publish_tf", &c->publish_tf);
  readKey(params, "max_path_poses", &c->max_path_poses);
  readKey(params, "time_jump_threshold", &c->time_jump_threshold);
  readKey(params, "odom_timeout", &c->odom_timeout);
  requireNonNegative(pnh, "transform_tolerance", c->transform_tolerance);
  requireNonNegative(pnh, "odom_timeout", c->odom_timeout);
  requirePositive(pnh, "time_jump_threshold", c->time_jump_threshold);
  if (c->max_path_poses < 1)
    throw invalidParameter(pnh, "max_path_poses", "must be >= 1");
  requireFrame(pnh, "map_frame", c->map_frame);
  requireFrame(pnh, "odom_frame", c->odom_frame);
  requireFrame(pnh, "base_frame", c->base_frame);
}

/**
 * @brief A core configuration read with its io reader (e.g. io::readFastSlamConfig), and `~seed`. A wrong type
 * or an invalid value throws, naming the key: a node never starts half-configured or on defaults it was not
 * given. The reader's validation (Config::validate()) is called here too.
 */
template <typename Config>
Config readCoreConfig(const RosParamSource& params, void (*reader)(const io::ParamSource&, Config*))
{
  Config c;
  reader(params, &c);
  c.seed = readSeed(params);
  return c;
}

/**
 * @brief Warns, by name, of every private parameter (leaf key under @p params' namespace) that no reader asked
 * for: a misspelt key would otherwise be ignored without a word. A key counts as asked when it, or a key above
 * it, was asked for.
 */
inline std::vector<std::string> warnUnknownKeys(const RosParamSource& params)
{
  std::vector<std::string> unknown;
  std::vector<std::string> names;
  if (!ros::param::getParamNames(names))
    return unknown;
  const std::string ns = params.nodeHandle().getNamespace() + "/";
  for (const std::string& name : names)
  {
    if (name.compare(0, ns.size(), ns) != 0)
      continue;
    const std::string key = name.substr(ns.size());
    bool known = false;
    for (std::string k = key; !k.empty() && !known;)
    {
      known = params.asked().count(k) > 0;
      const std::size_t slash = k.rfind('/');
      k = slash == std::string::npos ? std::string() : k.substr(0, slash);
    }
    if (!known)
    {
      unknown.push_back(key);
      ROS_WARN("%s: parameter %s is not one of this node's (misspelt?); ignored", params.nodeHandle().getNamespace().c_str(),
               name.c_str());
    }
  }
  return unknown;
}

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_PARAMS_H
