#ifndef RBPF_SLAM_CORE_FILTER_POSE2_H
#define RBPF_SLAM_CORE_FILTER_POSE2_H

#include <cmath>

namespace rbpf_slam
{
namespace core
{
/** @brief Wraps an angle to (-pi, pi]. */
inline double wrapAngle(double a)
{
  a = std::remainder(a, 2.0 * M_PI);  // [-pi, pi]
  return a <= -M_PI ? a + 2.0 * M_PI : a;
}

/** @brief A planar pose (REP-103: metres, radians, counter-clockwise heading). */
struct Pose2
{
  double x = 0.0;
  double y = 0.0;
  double theta = 0.0;

  Pose2() = default;
  Pose2(double x_, double y_, double theta_) : x(x_), y(y_), theta(theta_) {}

  /** @brief this ⊕ other: @p other expressed in this pose's frame, returned in the parent frame. */
  Pose2 operator*(const Pose2& o) const
  {
    const double c = std::cos(theta), s = std::sin(theta);
    return Pose2(x + c * o.x - s * o.y, y + s * o.x + c * o.y, wrapAngle(theta + o.theta));
  }

  Pose2 inverse() const
  {
    const double c = std::cos(theta), s = std::sin(theta);
    return Pose2(-c * x - s * y, s * x - c * y, wrapAngle(-theta));
  }

  /** @brief A point given in this pose's frame, in the parent frame. */
  void transformPoint(double px, double py, double* ox, double* oy) const
  {
    const double c = std::cos(theta), s = std::sin(theta);
    *ox = x + c * px - s * py;
    *oy = y + s * px + c * py;
  }
};

/** @brief The pose of @p b in the frame of @p a: a^-1 ⊕ b. */
inline Pose2 between(const Pose2& a, const Pose2& b) { return a.inverse() * b; }

/** @brief Linear interpolation of position and shortest-arc interpolation of heading, s in [0, 1]. */
inline Pose2 interpolate(const Pose2& a, const Pose2& b, double s)
{
  return Pose2(a.x + s * (b.x - a.x), a.y + s * (b.y - a.y), wrapAngle(a.theta + s * wrapAngle(b.theta - a.theta)));
}

/** @brief A sensor on base_link: planar pose and height (for the lever arm on a tilted body). */
struct SensorMount
{
  double x = 0.0, y = 0.0, z = 0.0, yaw = 0.0;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FILTER_POSE2_H
