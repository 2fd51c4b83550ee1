#ifndef RBPF_SLAM_CORE_VISIBILITY_SCOPE_H
#define RBPF_SLAM_CORE_VISIBILITY_SCOPE_H

#include <cmath>

#include <Eigen/Core>

#include "rbpf_slam/core/pose2.h"

namespace rbpf_slam
{
namespace core
{
/**
 * @brief Where the sensor sees landmarks: a ring [min_range, max_range] within a field of view centred on the
 * sensor's x axis. Landmarks inside are expected to be observed (a miss counts against them); landmarks just
 * outside may still take an observation (their predictions are uncertain) but are never missed.
 */
struct VisibilityScope
{
  /// [m] A landmark predicted this far outside the ring may still take an observation: the prediction from a
  /// particle's pose is off by up to decimetres, so the trunk it stands for may be just inside.
  static constexpr double kCandidateRangeMargin = 0.5;
  /// [rad] The same at the field of view's edges (about 6 degrees).
  static constexpr double kCandidateBearingMargin = 0.1;
  /// [m] Widens the map query by rounding's worth, so that it returns every landmark of the candidate test.
  static constexpr double kQuerySlack = 1e-6;

  double min_range = 1.0;                    ///< [m]
  double max_range = 12.0;                   ///< [m]
  double field_of_view = 6.283185307179586;  ///< [rad], centred on the sensor's x axis

  VisibilityScope() = default;
  VisibilityScope(double min_range_, double max_range_, double field_of_view_)
    : min_range(min_range_), max_range(max_range_), field_of_view(field_of_view_)
  {
  }

  /** @brief Radius [m] around the sensor within which every candidate lies (for LandmarkMap::near()). */
  double candidateReach() const { return max_range + kCandidateRangeMargin + kQuerySlack; }

  /** @brief A landmark predicted at @p z = (range, bearing) may take an observation (scope plus margins). */
  bool admitsCandidate(const Eigen::Vector2d& z) const
  {
    return !(z.x() < min_range - kCandidateRangeMargin || z.x() > max_range + kCandidateRangeMargin ||
             std::abs(z.y()) > 0.5 * field_of_view + kCandidateBearingMargin);
  }

  /** @brief @p range [m] lies in the ring (an observation there may start a landmark). */
  bool inRange(double range) const { return !(range < min_range || range > max_range); }

  /** @brief A landmark predicted at @p z = (range, bearing) should be seen: inside the ring and the view. */
  bool contains(const Eigen::Vector2d& z) const
  {
    return !(z.x() < min_range || z.x() > max_range || std::abs(z.y()) > 0.5 * field_of_view);
  }

  /** @brief Predicted beyond the far edge of the ring but within the field of view (leaving the scope). */
  bool beyondFarEdge(const Eigen::Vector2d& z) const
  {
    return z.x() > max_range && std::abs(z.y()) <= 0.5 * field_of_view;
  }
};

/// [m] A trunk hides another only if it stands clearly in front: its centre at least the two radii plus this
/// nearer. A near-duplicate at almost the same place must not hide its twin, which has to be missed to go.
constexpr double kOcclusionDepthMargin = 0.1;
/// [m] Half-width of a trunk's shadow beyond its radius: both predictions are uncertain, and a trunk whose edge
/// is barely uncovered is not reliably detected.
constexpr double kOcclusionShadowMargin = 0.15;

/**
 * @brief Occlusion: whether a trunk predicted at (@p range, @p bearing) with radius @p radius lies in the
 * shadow of a trunk predicted at (@p front_range, @p front_bearing) with radius @p front_radius (same sensor
 * pose; ranges [m], bearings [rad]).
 */
inline bool occludedBy(double range, double bearing, double radius, double front_range, double front_bearing,
                       double front_radius)
{
  if (front_range >= range - (radius + front_radius + kOcclusionDepthMargin))
    return false;
  const double half = (front_radius + kOcclusionShadowMargin) / front_range;
  return std::abs(wrapAngle(front_bearing - bearing)) < half;
}

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_VISIBILITY_SCOPE_H
