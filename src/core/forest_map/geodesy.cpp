#include "rbpf_slam/core/forest_map/geodesy.h"

#include <cmath>

namespace rbpf_slam
{
namespace core
{
namespace
{
constexpr double kDeg = M_PI / 180.0;
}  // namespace

LocalTangentPlane::LocalTangentPlane(const GeoPoint& origin) : origin_(origin)
{
  const double a = 6378137.0, f = 1.0 / 298.257223563, e2 = f * (2.0 - f);
  const double lat0 = origin.latitude * kDeg;
  const double s = std::sin(lat0);
  const double w = std::sqrt(1.0 - e2 * s * s);
  meridian_ = a * (1.0 - e2) / (w * w * w) + origin.altitude;
  parallel_ = (a / w + origin.altitude) * std::cos(lat0);
}

Eigen::Vector2d LocalTangentPlane::toEastNorth(double latitude, double longitude) const
{
  double dlon = longitude - origin_.longitude;
  dlon -= 360.0 * std::round(dlon / 360.0);
  return Eigen::Vector2d(dlon * kDeg * parallel_, (latitude - origin_.latitude) * kDeg * meridian_);
}

GeoPoint LocalTangentPlane::toGeo(const Eigen::Vector2d& east_north, double altitude) const
{
  GeoPoint g;
  g.latitude = origin_.latitude + east_north.y() / meridian_ / kDeg;
  g.longitude = origin_.longitude + east_north.x() / parallel_ / kDeg;
  g.longitude -= 360.0 * std::round(g.longitude / 360.0);
  g.altitude = altitude;
  return g;
}

GeoPoint anchoredToGeo(const GeoAnchor& anchor, double x, double y)
{
  const LocalTangentPlane plane(GeoPoint{ anchor.latitude, anchor.longitude, anchor.altitude });
  const double c = std::cos(anchor.yaw), s = std::sin(anchor.yaw);
  return plane.toGeo(Eigen::Vector2d(c * x - s * y, s * x + c * y), anchor.altitude);
}

Eigen::Vector2d geoToAnchored(const GeoAnchor& anchor, double latitude, double longitude)
{
  const LocalTangentPlane plane(GeoPoint{ anchor.latitude, anchor.longitude, anchor.altitude });
  const Eigen::Vector2d en = plane.toEastNorth(latitude, longitude);
  const double c = std::cos(anchor.yaw), s = std::sin(anchor.yaw);
  return Eigen::Vector2d(c * en.x() + s * en.y(), -s * en.x() + c * en.y());
}

}  // namespace core
}  // namespace rbpf_slam
