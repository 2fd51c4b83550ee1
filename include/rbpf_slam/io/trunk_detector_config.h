#ifndef RBPF_SLAM_IO_TRUNK_DETECTOR_CONFIG_H
#define RBPF_SLAM_IO_TRUNK_DETECTOR_CONFIG_H

#include "rbpf_slam/core/extraction/trunk_detector.h"
#include "rbpf_slam/io/param_source.h"

namespace rbpf_slam
{
namespace io
{
/**
 * @brief Reads the trunk detector's configuration (the detector keys of config/trunk_extraction.yaml:
 * every field of core::TrunkDetectorConfig under its own name, `method` as "circle" or "centroid", `seed`)
 * over the values in @p config; absent keys keep them.
 * @throws std::runtime_error naming the key for a wrong type or an unknown method, or, after reading, an
 * invalid value.
 */
void readTrunkDetectorConfig(const ParamSource& params, core::TrunkDetectorConfig* config);

}  // namespace io
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_IO_TRUNK_DETECTOR_CONFIG_H
