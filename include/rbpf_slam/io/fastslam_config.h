#ifndef RBPF_SLAM_IO_FASTSLAM_CONFIG_H
#define RBPF_SLAM_IO_FASTSLAM_CONFIG_H

#include "rbpf_slam/core/trunk_slam/trunk_slam_config.h"
#include "rbpf_slam/io/param_source.h"

namespace rbpf_slam
{
namespace io
{
/**
 * @brief Reads the filter's configuration (the filter keys of config/fastslam.yaml: every field of
 * core::TrunkSlamConfig under its own name, the motion noise as `motion/alpha1` ... `motion/alpha4`, `seed`)
 * over the values in @p config; absent keys keep them.
 * @throws std::runtime_error naming the key for a wrong type or, after reading, an invalid value.
 */
void readFastSlamConfig(const ParamSource& params, core::TrunkSlamConfig* config);

}  // namespace io
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_IO_FASTSLAM_CONFIG_H
