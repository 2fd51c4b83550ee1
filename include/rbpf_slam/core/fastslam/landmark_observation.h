#ifndef RBPF_SLAM_CORE_FASTSLAM_LANDMARK_OBSERVATION_H
#define RBPF_SLAM_CORE_FASTSLAM_LANDMARK_OBSERVATION_H

#include <cmath>

#include <Eigen/Core>

#include "rbpf_slam/core/filter/pose2.h"

namespace rbpf_slam
{
namespace core
{
/** @brief One range-bearing observation of a landmark centre, in the sensor frame. */
struct LandmarkObservation
{
  double range = 0.0;    ///< [m]
  double bearing = 0.0;  ///< [rad]
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();  ///< of (range, bearing)
  double radius = 0.0;           ///< [m] observed trunk radius (0: unknown)
  double radius_variance = 0.0;  ///< [m^2] (0: unknown, the radius is not used)
  int id = -1;                   ///< the landmark's id when the detector knows it (known association), else -1
};

using Matrix23d = Eigen::Matrix<double, 2, 3>;

/**
 * @brief Range-bearing measurement model: the (range [m], bearing [rad]) of the point @p l (map frame) seen
 * from the sensor pose @p s, and in @p H its Jacobian with respect to the point.
 */
inline Eigen::Vector2d predictRangeBearing(const Eigen::Vector2d& l, const Pose2& s, Eigen::Matrix2d* H)
{
  const double dx = l.x() - s.x, dy = l.y() - s.y;
  const double q = dx * dx + dy * dy;
  const double r = std::sqrt(q);
  *H << dx / r, dy / r, -dy / q, dx / q;
  return Eigen::Vector2d(r, wrapAngle(std::atan2(dy, dx) - s.theta));
}

/**
 * @brief Jacobian of the range-bearing of a landmark with respect to the base pose (x, y, theta), from its
 * Jacobian @p Hm with respect to the landmark, with the sensor at @p sensor on base_link: with respect to the
 * sensor position it is -Hm, with respect to the sensor heading (0, -1), and the sensor moves with the base's
 * heading by its lever arm.
 */
inline Matrix23d rangeBearingPoseJacobian(const Eigen::Matrix2d& Hm, const Pose2& base, const Pose2& sensor)
{
  const double c = std::cos(base.theta), s = std::sin(base.theta);
  const double dsx = -s * sensor.x - c * sensor.y, dsy = c * sensor.x - s * sensor.y;
  Matrix23d Hx;
  Hx.col(0) = -Hm.col(0);
  Hx.col(1) = -Hm.col(1);
  Hx.col(2) = -Hm.col(0) * dsx - Hm.col(1) * dsy + Eigen::Vector2d(0.0, -1.0);
  return Hx;
}

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FASTSLAM_LANDMARK_OBSERVATION_H
