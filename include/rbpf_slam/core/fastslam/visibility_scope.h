#ifndef RBPF_SLAM_CORE_FASTSLAM_VISIBILITY_SCOPE_H
#define RBPF_SLAM_CORE_FASTSLAM_VISIBILITY_SCOPE_H

#include <cmath>

#include <Eigen/Core>

#include "rbpf_slam/core/filter/pose2.h"

namespace rbpf_slam
{
namespace core
{
/**
 * @brief What a sensor (with its detector) says of one sweep: where it could see landmarks and how likely it
 * reports one that is there. A value it does not know is NaN (the filter's configuration or fallback stands in).
 * Bearings are in the sensor frame, counter-clockwise; a full turn is fov_max - fov_min >= 2 pi.
 */
struct SensorScope
{
  double min_range = NAN;              ///< [m]
  double max_range = NAN;              ///< [m]
  double fov_min = NAN;                ///< [rad] first bearing it looks at
  double fov_max = NAN;                ///< [rad] last bearing it looks at
  double detection_probability = NAN;  ///< share of the landmarks inside the scope it reports, in (0, 1]
  /// false: some of the sweep's detections were unreadable and dropped; what it did not report is then no evidence
  /// that a landmark is absent (no landmark counts as missed)
  bool complete = true;
};

/**
 * @brief Where the sensor sees landmarks: a ring [min_range, max_range] within the bearings [fov_min, fov_max]
 * of the sensor frame. Landmarks inside are expected to be observed (a miss counts against them); landmarks just
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

  double min_range = 1.0;   ///< [m]
  double max_range = 12.0;  ///< [m]
  double fov_min = -M_PI;   ///< [rad] in the sensor frame
  double fov_max = M_PI;    ///< [rad]
  double detection_probability = 1.0;  ///< share of the landmarks inside that the sensor reports

  VisibilityScope() = default;
  /** @brief A field of view of @p field_of_view [rad] centred on the sensor's x axis. */
  VisibilityScope(double min_range_, double max_range_, double field_of_view)
    : min_range(min_range_), max_range(max_range_), fov_min(-0.5 * field_of_view), fov_max(0.5 * field_of_view)
  {
  }

  /** @brief The field of view covers every bearing. */
  bool fullTurn() const { return fov_max - fov_min >= 2.0 * M_PI - 1e-9; }
  /** @brief @p bearing [rad] lies within the field of view widened by @p margin [rad] on both sides. */
  bool bearingInside(double bearing, double margin = 0.0) const
  {
    if (fullTurn())
      return true;
    const double mid = 0.5 * (fov_min + fov_max);
    return std::abs(wrapAngle(bearing - mid)) <= 0.5 * (fov_max - fov_min) + margin;
  }

  /** @brief Radius [m] around the sensor within which every candidate lies (for LandmarkMap::near()). */
  double candidateReach() const { return max_range + kCandidateRangeMargin + kQuerySlack; }

  /** @brief A landmark predicted at @p z = (range, bearing) may take an observation (scope plus margins). */
  bool admitsCandidate(const Eigen::Vector2d& z) const
  {
    return !(z.x() < min_range - kCandidateRangeMargin || z.x() > max_range + kCandidateRangeMargin) &&
           bearingInside(z.y(), kCandidateBearingMargin);
  }

  /** @brief @p range [m] lies in the ring (an observation there may start a landmark). */
  bool inRange(double range) const { return !(range < min_range || range > max_range); }

  /**
   * @brief A landmark predicted at @p z = (range, bearing) should be seen: inside the ring and the view, each
   * narrowed by a margin (@p range_margin [m], @p bearing_margin [rad]).
   */
  bool contains(const Eigen::Vector2d& z, double range_margin = 0.0, double bearing_margin = 0.0) const
  {
    return !(z.x() < min_range + range_margin || z.x() > max_range - range_margin) &&
           bearingInside(z.y(), -bearing_margin);
  }

  /** @brief Predicted beyond the far edge of the ring but within the field of view (leaving the scope). */
  bool beyondFarEdge(const Eigen::Vector2d& z) const { return z.x() > max_range && bearingInside(z.y()); }
};

/**
 * @brief The scope of one sweep: each limit the configuration sets (> 0; @p configured) bounds what the sensor
 * says (@p sensor); a limit neither knows takes @p fallback's. The detection probability is the configuration's
 * when set, else the sensor's, else @p fallback's.
 */
inline VisibilityScope effectiveScope(const SensorScope& configured, const SensorScope& sensor,
                                      const VisibilityScope& fallback)
{
  auto known = [](double v) { return std::isfinite(v); };
  VisibilityScope s = fallback;
  const bool sensor_range = known(sensor.max_range) && sensor.max_range > 0.0;
  const bool config_range = known(configured.max_range) && configured.max_range > 0.0;
  if (sensor_range && config_range)
    s.max_range = std::min(sensor.max_range, configured.max_range);
  else if (sensor_range || config_range)
    s.max_range = sensor_range ? sensor.max_range : configured.max_range;
  const bool sensor_min = known(sensor.min_range) && sensor.min_range >= 0.0;
  const bool config_min = known(configured.min_range) && configured.min_range > 0.0;
  if (sensor_min || config_min)
    s.min_range = std::max(sensor_min ? sensor.min_range : 0.0, config_min ? configured.min_range : 0.0);
  if (known(sensor.fov_min) && known(sensor.fov_max) && sensor.fov_max > sensor.fov_min)
  {
    s.fov_min = sensor.fov_min;
    s.fov_max = std::min(sensor.fov_max, sensor.fov_min + 2.0 * M_PI);
  }
  if (known(configured.fov_min) && known(configured.fov_max) && configured.fov_max > configured.fov_min &&
      configured.fov_max - configured.fov_min < 2.0 * M_PI)
  {
    // The configured view (centred on x) bounds the sensor's, when the sensor's is a full turn or overlaps it.
    if (s.fullTurn())
    {
      s.fov_min = configured.fov_min;
      s.fov_max = configured.fov_max;
    }
    else
    {
      s.fov_min = std::max(s.fov_min, configured.fov_min);
      s.fov_max = std::max(s.fov_min, std::min(s.fov_max, configured.fov_max));
    }
  }
  const auto valid_p = [&](double p) { return known(p) && p > 0.0 && p <= 1.0; };
  if (valid_p(configured.detection_probability))
    s.detection_probability = configured.detection_probability;
  else if (valid_p(sensor.detection_probability))
    s.detection_probability = sensor.detection_probability;
  if (!(s.max_range > s.min_range))
    s.max_range = s.min_range + 1e-3;
  return s;
}

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

#endif  // RBPF_SLAM_CORE_FASTSLAM_VISIBILITY_SCOPE_H
