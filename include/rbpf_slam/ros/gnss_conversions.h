#ifndef RBPF_SLAM_ROS_GNSS_CONVERSIONS_H
#define RBPF_SLAM_ROS_GNSS_CONVERSIONS_H

#include <cmath>
#include <string>

#include <sensor_msgs/NavSatFix.h>

#include "rbpf_slam/core/forest_map/gnss.h"

namespace rbpf_slam
{
/// [m] per axis: the error taken for a fix whose covariance is of type UNKNOWN (a plain receiver's worst case).
constexpr double kUnknownGpsSigma = 10.0;

/**
 * @brief A NavSatFix as the core's fix: stamp, latitude, longitude, altitude, and the horizontal part of its ENU
 * covariance. A status below STATUS_FIX is no fix; a covariance of type UNKNOWN is taken as @p unknown_sigma [m]
 * per axis (receivers that say nothing of their error are not taken as exact); a covariance of type
 * APPROXIMATED or DIAGONAL_KNOWN keeps its diagonal only.
 */
inline core::GnssFix toGnssFix(const sensor_msgs::NavSatFix& msg, double unknown_sigma)
{
  core::GnssFix f;
  f.stamp = msg.header.stamp.toSec();
  f.valid = msg.status.status >= sensor_msgs::NavSatStatus::STATUS_FIX;
  f.latitude = msg.latitude;
  f.longitude = msg.longitude;
  f.altitude = std::isfinite(msg.altitude) ? msg.altitude : 0.0;
  const auto& c = msg.position_covariance;
  switch (msg.position_covariance_type)
  {
    case sensor_msgs::NavSatFix::COVARIANCE_TYPE_KNOWN:
      f.covariance << c[0], c[1], c[3], c[4];
      break;
    case sensor_msgs::NavSatFix::COVARIANCE_TYPE_APPROXIMATED:
    case sensor_msgs::NavSatFix::COVARIANCE_TYPE_DIAGONAL_KNOWN:
      f.covariance << c[0], 0.0, 0.0, c[4];
      break;
    default:
      f.covariance = unknown_sigma * unknown_sigma * Eigen::Matrix2d::Identity();
  }
  return f;
}

/** @brief The core's fix as a NavSatFix (GPS service; covariance of type DIAGONAL_KNOWN, or KNOWN when correlated). */
inline sensor_msgs::NavSatFix::Ptr toNavSatFix(const core::GnssFix& fix, const std::string& frame,
                                               const ros::Time& stamp, double vertical_factor)
{
  sensor_msgs::NavSatFix::Ptr msg(new sensor_msgs::NavSatFix);
  msg->header.stamp = stamp;
  msg->header.frame_id = frame;
  msg->status.status = fix.valid ? sensor_msgs::NavSatStatus::STATUS_FIX : sensor_msgs::NavSatStatus::STATUS_NO_FIX;
  msg->status.service = sensor_msgs::NavSatStatus::SERVICE_GPS;
  msg->latitude = fix.latitude;
  msg->longitude = fix.longitude;
  msg->altitude = fix.altitude;
  msg->position_covariance = { fix.covariance(0, 0), fix.covariance(0, 1), 0.0, fix.covariance(1, 0),
                               fix.covariance(1, 1), 0.0, 0.0, 0.0,
                               vertical_factor * vertical_factor * 0.5 * fix.covariance.trace() };
  msg->position_covariance_type = fix.covariance(0, 1) == 0.0 ? sensor_msgs::NavSatFix::COVARIANCE_TYPE_DIAGONAL_KNOWN :
                                                                 sensor_msgs::NavSatFix::COVARIANCE_TYPE_KNOWN;
  return msg;
}

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_GNSS_CONVERSIONS_H
