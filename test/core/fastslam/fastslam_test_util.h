// Helpers of the FastSLAM gtests: exact observations and a filter without motion noise.
#ifndef RBPF_SLAM_TEST_CORE_FASTSLAM_TEST_UTIL_H
#define RBPF_SLAM_TEST_CORE_FASTSLAM_TEST_UTIL_H

#include <cmath>

#include "rbpf_slam/core/fastslam/fastslam.h"

namespace rbpf_slam
{
namespace test
{
/** An exact observation of world point (x, y) from sensor pose s, with the stated noise and trunk radius. */
inline core::LandmarkObservation observe(const core::Pose2& s, double x, double y, double sigma_r = 0.02,
                                         double sigma_b = 0.003, double radius = 0.2)
{
  core::LandmarkObservation o;
  const double dx = x - s.x, dy = y - s.y;
  o.range = std::hypot(dx, dy);
  o.bearing = core::wrapAngle(std::atan2(dy, dx) - s.theta);
  o.covariance << sigma_r * sigma_r, 0, 0, sigma_b * sigma_b;
  o.radius = radius;
  o.radius_variance = 0.01 * 0.01;
  return o;
}

/** A filter of @p particles without motion noise, whose landmarks are confirmed at their first sighting
 * and which counts every update as a look from a new view. */
inline core::FastSlamConfig quietConfig(int particles = 1)
{
  core::FastSlamConfig c;
  c.particles = particles;
  c.motion.alpha1 = c.motion.alpha2 = c.motion.alpha3 = c.motion.alpha4 = 0.0;
  c.confirm_observations = 1;
  // Every update a look from a new view: these tests place the sensor by hand and test one look's arithmetic (the
  // view rule has its own tests in test_landmark_evidence.cpp and test_pipelines.cpp).
  c.evidence_view_change = 0.0;
  return c;
}
}  // namespace test
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_TEST_CORE_FASTSLAM_TEST_UTIL_H
