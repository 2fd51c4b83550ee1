#ifndef RBPF_SLAM_ROS_SCAN_CONVERSIONS_H
#define RBPF_SLAM_ROS_SCAN_CONVERSIONS_H

#include <cmath>
#include <string>

#include <sensor_msgs/LaserScan.h>

#include "rbpf_slam/core/occupancy_grid.h"

namespace rbpf_slam
{
/**
 * @brief A LaserScan as the core's ScanData (ranges copied as they are: the core applies REP-117).
 * @return empty when the scan is usable, else why not (no ranges, angle_increment not finite or zero,
 * range_min/range_max not finite where given); the caller warns and drops it.
 */
inline std::string toScanData(const sensor_msgs::LaserScan& msg, core::ScanData* scan)
{
  if (msg.ranges.empty())
    return "scan has no ranges";
  if (!std::isfinite(msg.angle_min) || !std::isfinite(msg.angle_increment) || msg.angle_increment == 0.0f)
    return "scan has a non-finite or zero angle_increment / angle_min";
  if (std::isnan(msg.range_min) || std::isnan(msg.range_max))
    return "scan has NaN range_min / range_max";
  scan->ranges = msg.ranges;
  scan->angle_min = msg.angle_min;
  scan->angle_increment = msg.angle_increment;
  scan->range_min = msg.range_min;
  scan->range_max = msg.range_max > 0.0f ? static_cast<double>(msg.range_max) : 1e9;
  return "";
}

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_SCAN_CONVERSIONS_H
