// Satellite fixes for the gtests of the GNSS anchor, its fusion and their faults.
#ifndef RBPF_SLAM_TEST_CORE_GNSS_TEST_UTIL_H
#define RBPF_SLAM_TEST_CORE_GNSS_TEST_UTIL_H

#include "rbpf_slam/core/forest_map/geodesy.h"
#include "rbpf_slam/core/forest_map/gnss.h"

namespace rbpf_slam
{
namespace test
{
/** A valid fix at @p g, stamped @p stamp [s], with the receiver's default 1 m standard deviation east and north. */
inline core::GnssFix validFix(const core::GeoPoint& g, double stamp)
{
  core::GnssFix fix;
  fix.valid = true;
  fix.stamp = stamp;
  fix.latitude = g.latitude;
  fix.longitude = g.longitude;
  fix.altitude = g.altitude;
  return fix;
}
}  // namespace test
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_TEST_CORE_GNSS_TEST_UTIL_H
