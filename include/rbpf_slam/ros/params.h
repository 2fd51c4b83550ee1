#ifndef RBPF_SLAM_ROS_PARAMS_H
#define RBPF_SLAM_ROS_PARAMS_H

#include <cstdint>
#include <string>

#include <ros/ros.h>

namespace rbpf_slam
{
/** @brief Reads `~seed` (an int; negative values are reinterpreted as unsigned). */
inline std::uint64_t readSeed(const ros::NodeHandle& pnh, int default_seed = 0)
{
  int seed = default_seed;
  pnh.param("seed", seed, default_seed);
  return static_cast<std::uint64_t>(static_cast<std::int64_t>(seed));
}

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_PARAMS_H
