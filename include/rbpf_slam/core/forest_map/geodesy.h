#ifndef RBPF_SLAM_CORE_FOREST_MAP_GEODESY_H
#define RBPF_SLAM_CORE_FOREST_MAP_GEODESY_H

#include <Eigen/Core>

namespace rbpf_slam
{
namespace core
{
/** @brief A WGS84 position. */
struct GeoPoint
{
  double latitude = 0.0;   ///< [deg]
  double longitude = 0.0;  ///< [deg]
  double altitude = 0.0;   ///< [m] above the ellipsoid
};

/**
 * @brief East and north [m] about a WGS84 point: the tangent plane at @p origin with the ellipsoid's radii of
 * curvature there (meridian and prime vertical). Within a few millimetres of the exact conversion over a
 * kilometre, which is all a stand needs; both directions use the same radii, so a round trip is exact.
 */
class LocalTangentPlane
{
public:
  LocalTangentPlane() = default;
  explicit LocalTangentPlane(const GeoPoint& origin);

  /** @brief [m] east, north of a WGS84 latitude and longitude [deg]. */
  Eigen::Vector2d toEastNorth(double latitude, double longitude) const;
  /** @brief [deg] latitude and longitude of a point @p east_north [m]. */
  GeoPoint toGeo(const Eigen::Vector2d& east_north, double altitude = 0.0) const;
  const GeoPoint& origin() const { return origin_; }

private:
  GeoPoint origin_;
  double meridian_ = 6378137.0;  ///< [m] radius of curvature of the meridian at the origin (plus its height)
  double parallel_ = 6378137.0;  ///< [m] radius of the parallel there (prime vertical times cos latitude)
};

/**
 * @brief Where a planar frame lies on the earth: its origin in WGS84 and the heading of its x axis counter-clockwise
 * from east (REP-103's ENU). Not valid: the frame is local only.
 */
struct GeoAnchor
{
  bool valid = false;
  double latitude = 0.0;   ///< [deg] of the frame's origin
  double longitude = 0.0;  ///< [deg]
  double altitude = 0.0;   ///< [m] above the ellipsoid
  double yaw = 0.0;        ///< [rad] of the frame's x axis from east, counter-clockwise
  double sigma = 0.0;      ///< [m] standard deviation of the origin's position (0: not known)
};

/** @brief [deg] WGS84 latitude and longitude of the point (@p x, @p y) [m] of the frame anchored at @p anchor. */
GeoPoint anchoredToGeo(const GeoAnchor& anchor, double x, double y);
/** @brief The inverse: the frame's point [m] of a WGS84 latitude and longitude [deg]. */
Eigen::Vector2d geoToAnchored(const GeoAnchor& anchor, double latitude, double longitude);

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FOREST_MAP_GEODESY_H
