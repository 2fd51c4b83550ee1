#include "rbpf_slam/core/fastslam/landmark_ekf.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace rbpf_slam
{
namespace core
{
void updateLandmarkPosition(Landmark* l, const Eigen::Matrix2d& H, const Eigen::Matrix2d& s_inv,
                            const Eigen::Vector2d& v, const Eigen::Matrix2d& R)
{
  const Eigen::Matrix2d K = l->covariance * H.transpose() * s_inv;
  l->mean += K * v;
  // Joseph form keeps the covariance symmetric and positive.
  const Eigen::Matrix2d IKH = Eigen::Matrix2d::Identity() - K * H;
  l->covariance = IKH * l->covariance * IKH.transpose() + K * R * K.transpose();
}

void fuseLandmarkRadius(Landmark* l, const LandmarkObservation& o)
{
  if (!(o.radius_variance > 0.0))
    return;
  if (l->visit_observations == 0 || !(l->visit_radius_variance > 0.0))
  {
    l->visit_radius = o.radius;
    l->visit_radius_variance = o.radius_variance;
  }
  else
  {
    const double gv = l->visit_radius_variance / (l->visit_radius_variance + o.radius_variance);
    l->visit_radius += gv * (o.radius - l->visit_radius);
    l->visit_radius_variance *= (1.0 - gv);
  }
  ++l->visit_observations;
  if (l->radius_variance <= 0.0 || l->observations == 0)
  {
    l->radius = o.radius;
    l->radius_variance = o.radius_variance;
    return;
  }
  const double g = l->radius_variance / (l->radius_variance + o.radius_variance);
  l->radius += g * (o.radius - l->radius);
  l->radius_variance *= (1.0 - g);
}

Landmark landmarkFromObservation(const LandmarkObservation& o, const Pose2& sensor, const Eigen::Matrix2d& R)
{
  Landmark l;
  const double a = sensor.theta + o.bearing;
  l.mean = Eigen::Vector2d(sensor.x + o.range * std::cos(a), sensor.y + o.range * std::sin(a));
  Eigen::Matrix2d G;  // d(landmark) / d(range, bearing)
  G << std::cos(a), -o.range * std::sin(a), std::sin(a), o.range * std::cos(a);
  l.covariance = G * R * G.transpose();
  l.radius = o.radius;
  l.radius_variance = std::max(0.0, o.radius_variance);  // 0: the radius is not known yet
  l.visit_radius = o.radius;
  l.visit_radius_variance = l.radius_variance;
  l.visit_observations = 1;
  return l;
}

}  // namespace core
}  // namespace rbpf_slam
