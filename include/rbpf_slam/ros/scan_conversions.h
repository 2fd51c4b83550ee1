#ifndef RBPF_SLAM_ROS_SCAN_CONVERSIONS_H
#define RBPF_SLAM_ROS_SCAN_CONVERSIONS_H

#include <cmath>
#include <string>

#include <sensor_msgs/LaserScan.h>

#include "rbpf_slam/core/grid/occupancy_grid.h"
#include "rbpf_slam/core/extraction/trunk_detector.h"
#include "rbpf_slam/core/trunk_slam/trunk_slam_pipeline.h"

namespace rbpf_slam
{
/** @brief Empty when a scan's layout is usable, else why not (no ranges, bad angles, NaN limits). */
inline std::string scanLayoutProblem(const sensor_msgs::LaserScan& msg)
{
  if (msg.ranges.empty())
    return "scan has no ranges";
  if (!std::isfinite(msg.angle_min) || !std::isfinite(msg.angle_increment) || msg.angle_increment == 0.0f)
    return "scan has a non-finite or zero angle_increment / angle_min";
  if (std::isnan(msg.range_min) || std::isnan(msg.range_max))
    return "scan has NaN range_min / range_max";
  return "";
}

/**
 * @brief A LaserScan as the core's ScanData (ranges copied as they are: the core applies REP-117).
 * @return empty when the scan is usable, else why not (no ranges, angle_increment not finite or zero,
 * range_min/range_max not finite where given); the caller warns and drops it.
 */
inline std::string toScanData(const sensor_msgs::LaserScan& msg, core::ScanData* scan)
{
  const std::string why = scanLayoutProblem(msg);
  if (!why.empty())
    return why;
  scan->ranges = msg.ranges;
  scan->angle_min = msg.angle_min;
  scan->angle_increment = msg.angle_increment;
  scan->range_min = msg.range_min;
  scan->range_max = msg.range_max > 0.0f ? static_cast<double>(msg.range_max) : 1e9;
  return "";
}

/**
 * @brief A LaserScan as the trunk detector's PlanarScan (ranges as they are: the detector applies REP-117).
 * @return empty when usable, else why not: no ranges, non-finite or zero angle_increment / angle_min, NaN limits,
 * or no beam that is a measurement (every one NaN, -Inf, 0 or below range_min; +Inf is "nothing in range" and
 * counts). The caller warns and drops it: a dropped scan is no observation.
 */
inline std::string toPlanarScan(const sensor_msgs::LaserScan& msg, core::PlanarScan* scan)
{
  const std::string why = scanLayoutProblem(msg);
  if (!why.empty())
    return why;
  bool any = false;
  for (const float r : msg.ranges)
    if ((std::isfinite(r) && r > 0.0f && r >= msg.range_min) || (std::isinf(r) && r > 0.0f))
    {
      any = true;
      break;
    }
  if (!any)
    return "no beam of " + std::to_string(msg.ranges.size()) + " is a measurement (all NaN, -Inf, 0 or below range_min)";
  scan->ranges = msg.ranges;
  scan->angle_min = msg.angle_min;
  scan->angle_increment = msg.angle_increment;
  scan->range_min = msg.range_min;
  scan->range_max = msg.range_max;
  return "";
}

/**
 * @brief How long a scan took from its first beam to its last [s]: time_increment apart; 0 when the driver does
 * not say (every beam at the stamp).
 */
inline double scanPeriod(const sensor_msgs::LaserScan& msg)
{
  return core::scanPeriod(static_cast<double>(msg.time_increment), msg.ranges.size());
}

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_SCAN_CONVERSIONS_H
