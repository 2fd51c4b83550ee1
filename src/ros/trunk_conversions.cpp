#include "rbpf_slam/ros/trunk_conversions.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>

#include <boost/make_shared.hpp>
#include <geometry_msgs/Point.h>

#include <Eigen/Eigenvalues>

namespace rbpf_slam
{
namespace
{
std::uint8_t toMsgMethod(core::TrunkMethod method)
{
  switch (method)
  {
    case core::TrunkMethod::kCentroid:
      return rbpf_slam::Trunk::METHOD_CENTROID;
    case core::TrunkMethod::kCircle:
      return rbpf_slam::Trunk::METHOD_CIRCLE;
    case core::TrunkMethod::kArc:
      return rbpf_slam::Trunk::METHOD_ARC;
  }
  return rbpf_slam::Trunk::METHOD_CIRCLE;
}

/** @brief An upright cylinder of @p diameter and @p height centred at (x, y, z), in @p alpha. */
visualization_msgs::Marker cylinder(const std_msgs::Header& header, const std::string& ns, int id, double x, double y,
                                    double z, double diameter, double height, float alpha)
{
  visualization_msgs::Marker m;
  m.header = header;
  m.ns = ns;
  m.id = id;
  m.type = visualization_msgs::Marker::CYLINDER;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.position.x = x;
  m.pose.position.y = y;
  m.pose.position.z = z;
  m.pose.orientation.w = 1.0;
  m.scale.x = m.scale.y = diameter;
  m.scale.z = height;
  m.color.a = alpha;
  return m;
}

visualization_msgs::Marker deleteAll(const ros::Time& stamp, const std::string& frame)
{
  visualization_msgs::Marker clear;
  clear.header.stamp = stamp;
  clear.header.frame_id = frame;
  clear.action = visualization_msgs::Marker::DELETEALL;
  return clear;
}
}  // namespace

rbpf_slam::Trunk toMsg(const core::TrunkObservation& t)
{
  rbpf_slam::Trunk m;
  m.center.x = t.center.x();
  m.center.y = t.center.y();
  m.center.z = t.height;
  m.radius = t.radius;
  m.radius_variance = t.radius_variance;
  m.range = t.range;
  m.bearing = t.bearing;
  m.covariance[0] = t.covariance(0, 0);
  m.covariance[1] = t.covariance(0, 1);
  m.covariance[2] = t.covariance(1, 0);
  m.covariance[3] = t.covariance(1, 1);
  m.num_points = static_cast<std::uint32_t>(std::max(0, t.num_points));
  m.num_inliers = static_cast<std::uint32_t>(std::max(0, t.num_inliers));
  m.score = static_cast<float>(t.score);
  m.method = toMsgMethod(t.method);
  m.id = -1;
  return m;
}

core::TrunkObservation fromMsg(const rbpf_slam::Trunk& trunk)
{
  core::TrunkObservation t;
  t.center = Eigen::Vector2d(trunk.center.x, trunk.center.y);
  t.height = trunk.center.z;
  t.radius = trunk.radius;
  t.radius_variance = trunk.radius_variance;
  t.range = t.center.norm();
  t.bearing = std::atan2(t.center.y(), t.center.x());
  t.covariance << trunk.covariance[0], trunk.covariance[1], trunk.covariance[2], trunk.covariance[3];
  t.num_points = static_cast<int>(trunk.num_points);
  t.num_inliers = static_cast<int>(trunk.num_inliers);
  t.score = trunk.score;
  t.id = trunk.id >= 0 ? trunk.id : -1;
  switch (trunk.method)
  {
    case rbpf_slam::Trunk::METHOD_CENTROID:
      t.method = core::TrunkMethod::kCentroid;
      break;
    case rbpf_slam::Trunk::METHOD_ARC:
      t.method = core::TrunkMethod::kArc;
      break;
    default:  // circle, and given observations: their radius (with a variance) is used
      t.method = core::TrunkMethod::kCircle;
  }
  return t;
}

rbpf_slam::TrunkArray::Ptr toSweepMsg(const std_msgs::Header& header, const std::vector<core::TrunkObservation>& trunks,
                                      const core::SensorScope& scope, double sweep_period,
                                      const core::SweepGeometry* geometry, double tilt_roll, double tilt_pitch)
{
  auto out = boost::make_shared<rbpf_slam::TrunkArray>();
  out->header = header;
  // What the sensor could see: 0 where it is not known (NaN would not survive every consumer).
  const auto known = [](double v) { return std::isfinite(v) ? v : 0.0; };
  out->min_range = known(scope.min_range);
  out->max_range = known(scope.max_range);
  out->fov_min = known(scope.fov_min);
  out->fov_max = known(scope.fov_max);
  out->detection_probability = known(scope.detection_probability);
  out->sweep_period = sweep_period;
  if (geometry)
  {
    out->sweep_start_angle = geometry->start_angle;
    out->sweep_span = geometry->span;
  }
  out->tilt_roll = tilt_roll;
  out->tilt_pitch = tilt_pitch;
  out->trunks.reserve(trunks.size());
  for (const auto& t : trunks)
    out->trunks.push_back(toMsg(t));
  return out;
}

core::SensorScope scopeFromMsg(const rbpf_slam::TrunkArray& msg)
{
  core::SensorScope s;
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (positive(msg.max_range))
  {
    // A sensor that states its range states its near limit too (0: it sees from its origin on).
    s.max_range = msg.max_range;
    if (std::isfinite(msg.min_range) && msg.min_range >= 0.0 && msg.min_range < msg.max_range)
      s.min_range = msg.min_range;
  }
  else if (positive(msg.min_range))
    s.min_range = msg.min_range;
  if (std::isfinite(msg.fov_min) && std::isfinite(msg.fov_max) && msg.fov_max > msg.fov_min)
  {
    s.fov_min = msg.fov_min;
    s.fov_max = msg.fov_max;
  }
  if (positive(msg.detection_probability) && msg.detection_probability <= 1.0)
    s.detection_probability = msg.detection_probability;
  return s;
}

bool trunkIsReadable(const core::TrunkObservation& o)
{
  if (!o.center.allFinite() || !o.covariance.allFinite() || !std::isfinite(o.radius) ||
      !std::isfinite(o.radius_variance))
    return false;
  if (o.radius < 0.0 || o.radius_variance < 0.0)
    return false;
  // A covariance: symmetric, with variances >= 0 and a determinant >= 0 (to the rounding of its numbers).
  const Eigen::Matrix2d& c = o.covariance;
  const double scale = std::max({ std::abs(c(0, 0)), std::abs(c(1, 1)), std::abs(c(0, 1)), 1e-300 });
  return c(0, 0) >= 0.0 && c(1, 1) >= 0.0 && std::abs(c(0, 1) - c(1, 0)) <= 1e-9 * scale &&
         c(0, 0) * c(1, 1) - c(0, 1) * c(1, 0) >= -1e-9 * scale * scale;
}

std::size_t toTrunkSweep(const rbpf_slam::TrunkArray& msg, const core::Pose2& sensor, double sensor_height,
                         core::TrunkSweep* sweep)
{
  sweep->stamp = msg.header.stamp.toSec();
  // Every trunk is carried to the sweep's middle from its own instant (sweep_period, sweep_start_angle, sweep_span)
  // and moved by the lever arm of the tilt the extractor removed (tilt_roll, tilt_pitch, the sensor's height on
  // base_link); 0 = all trunks at the stamp, no tilt, a spinning lidar's sweep.
  sweep->period = msg.sweep_period;
  sweep->tilt_roll = msg.tilt_roll;
  sweep->tilt_pitch = msg.tilt_pitch;
  if (std::isfinite(msg.sweep_span) && msg.sweep_span > 0.0 && std::isfinite(msg.sweep_start_angle))
  {
    sweep->geometry.start_angle = msg.sweep_start_angle;
    sweep->geometry.span = msg.sweep_span;
  }
  sweep->mount.x = sensor.x;
  sweep->mount.y = sensor.y;
  sweep->mount.yaw = sensor.theta;
  sweep->mount.z = sensor_height;
  sweep->scope = scopeFromMsg(msg);
  sweep->trunks.clear();
  sweep->trunks.reserve(msg.trunks.size());
  std::size_t bad = 0;
  for (const auto& trunk : msg.trunks)
  {
    const core::TrunkObservation o = fromMsg(trunk);
    if (!trunkIsReadable(o))
    {
      ++bad;
      continue;
    }
    sweep->trunks.push_back(o);
  }
  // What the array left out unreadable may have been a tree: no tree counts as missed in it.
  sweep->scope.complete = bad == 0;
  return bad;
}

rbpf_slam::TrunkArray::Ptr toLandmarkArray(const ros::Time& stamp, const std::string& frame,
                                           const core::LandmarkMap& map)
{
  auto array = boost::make_shared<rbpf_slam::TrunkArray>();
  array->header.stamp = stamp;
  array->header.frame_id = frame;
  for (std::size_t i = 0; i < map.size(); ++i)
  {
    const core::Landmark& l = map[i];
    rbpf_slam::Trunk t;
    t.center.x = l.mean.x();
    t.center.y = l.mean.y();
    t.radius = l.radius;
    t.radius_variance = l.radius_variance;
    t.range = l.mean.norm();
    t.bearing = std::atan2(l.mean.y(), l.mean.x());
    t.covariance[0] = l.covariance(0, 0);
    t.covariance[1] = l.covariance(0, 1);
    t.covariance[2] = l.covariance(1, 0);
    t.covariance[3] = l.covariance(1, 1);
    t.num_points = static_cast<std::uint32_t>(std::max(0, l.observations));
    t.score = l.provisional ? 0.5f : 1.0f;
    t.method = rbpf_slam::Trunk::METHOD_GIVEN;
    t.id = l.id;
    array->trunks.push_back(t);
  }
  return array;
}

visualization_msgs::MarkerArray::Ptr trunkMarkers(const rbpf_slam::TrunkArray& trunks, double band_height)
{
  auto msg = boost::make_shared<visualization_msgs::MarkerArray>();
  visualization_msgs::Marker clear;
  clear.header = trunks.header;
  clear.action = visualization_msgs::Marker::DELETEALL;
  msg->markers.push_back(clear);
  int id = 0;
  for (const auto& t : trunks.trunks)
  {
    visualization_msgs::Marker m = cylinder(trunks.header, "trunks", id, t.center.x, t.center.y, t.center.z,
                                            std::max(0.02, 2.0 * t.radius), band_height, 0.8f);
    switch (t.method)
    {
      case rbpf_slam::Trunk::METHOD_CENTROID:  // orange
        m.color.r = 1.0f;
        m.color.g = 0.5f;
        break;
      case rbpf_slam::Trunk::METHOD_CIRCLE:  // green
        m.color.r = 0.1f;
        m.color.g = 0.8f;
        m.color.b = 0.1f;
        break;
      case rbpf_slam::Trunk::METHOD_ARC:  // blue
        m.color.r = 0.2f;
        m.color.g = 0.4f;
        m.color.b = 1.0f;
        break;
      default:  // grey
        m.color.r = m.color.g = m.color.b = 0.6f;
    }
    msg->markers.push_back(m);

    visualization_msgs::Marker label;
    label.header = trunks.header;
    label.ns = "trunk_labels";
    label.id = id;
    label.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
    label.action = visualization_msgs::Marker::ADD;
    label.pose.position = t.center;
    label.pose.position.z += 0.5 * band_height + 0.25;
    label.pose.orientation.w = 1.0;
    label.scale.z = 0.25;
    label.color.r = label.color.g = label.color.b = label.color.a = 1.0f;
    char text[32];
    std::snprintf(text, sizeof(text), "%.1f cm", 100.0 * t.radius);
    label.text = text;
    msg->markers.push_back(label);
    ++id;
  }
  return msg;
}

visualization_msgs::Marker::Ptr scopeMarker(const ros::Time& stamp, const std::string& base_frame,
                                            const core::VisibilityScope& c, const core::Pose2& sensor)
{
  auto m = boost::make_shared<visualization_msgs::Marker>();
  m->header.frame_id = base_frame;  // at the update's stamp: it moves with the robot
  m->header.stamp = stamp;
  m->ns = "visibility_scope";
  m->type = visualization_msgs::Marker::LINE_LIST;
  m->action = visualization_msgs::Marker::ADD;
  m->pose.orientation.w = 1.0;
  m->scale.x = 0.06;
  m->color.r = 0.3f;
  m->color.g = 0.8f;
  m->color.b = 1.0f;
  m->color.a = 1.0f;  // opaque: a flat colour rviz draws exactly
  const double fov = std::min(std::max(c.fov_max - c.fov_min, 0.0), 2.0 * M_PI);
  const double first = c.fov_min;
  const int n = 120;
  auto point = [&](double range, double bearing) {
    geometry_msgs::Point p;
    p.x = sensor.x + range * std::cos(sensor.theta + bearing);
    p.y = sensor.y + range * std::sin(sensor.theta + bearing);
    p.z = 0.05;
    return p;
  };
  for (const double range : { c.min_range, c.max_range })
    for (int k = 0; k < n; ++k)
    {
      m->points.push_back(point(range, first + fov * k / n));
      m->points.push_back(point(range, first + fov * (k + 1) / n));
    }
  if (fov < 2.0 * M_PI - 1e-6)
    for (const double side : { first, first + fov })
    {
      m->points.push_back(point(c.min_range, side));
      m->points.push_back(point(c.max_range, side));
    }
  return m;
}

visualization_msgs::MarkerArray::Ptr landmarkMarkers(const ros::Time& stamp, const std::string& frame,
                                                     const core::LandmarkMap& map)
{
  auto markers = boost::make_shared<visualization_msgs::MarkerArray>();
  const visualization_msgs::Marker clear = deleteAll(stamp, frame);
  markers->markers.push_back(clear);
  for (std::size_t i = 0; i < map.size(); ++i)
  {
    const core::Landmark& l = map[i];
    visualization_msgs::Marker m = cylinder(clear.header, "landmarks", l.id, l.mean.x(), l.mean.y(), 1.0,
                                            std::max(0.02, 2.0 * l.radius), 2.0, 0.8f);
    if (l.provisional)  // yellow
    {
      m.color.r = 1.0f;
      m.color.g = 0.85f;
    }
    else  // brown-green
    {
      m.color.r = 0.2f;
      m.color.g = 0.7f;
      m.color.b = 0.2f;
    }
    markers->markers.push_back(m);

    // 2-sigma ellipse of the centre's covariance.
    visualization_msgs::Marker e;
    e.header = clear.header;
    e.ns = "landmark_covariance";
    e.id = l.id;
    e.type = visualization_msgs::Marker::LINE_STRIP;
    e.action = visualization_msgs::Marker::ADD;
    e.pose.orientation.w = 1.0;
    e.scale.x = 0.02;
    e.color = m.color;
    e.color.a = 1.0f;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(0.5 * (l.covariance + l.covariance.transpose()));
    const Eigen::Vector2d ev = eig.eigenvalues().cwiseMax(0.0).cwiseSqrt() * 2.0;
    const Eigen::Matrix2d axes = eig.eigenvectors();
    for (int k = 0; k <= 36; ++k)
    {
      const double a = 2.0 * M_PI * k / 36.0;
      const Eigen::Vector2d p = l.mean + axes * Eigen::Vector2d(ev.x() * std::cos(a), ev.y() * std::sin(a));
      geometry_msgs::Point q;
      q.x = p.x();
      q.y = p.y();
      q.z = 0.05;
      e.points.push_back(q);
    }
    markers->markers.push_back(e);
  }
  return markers;
}

visualization_msgs::Marker loopMarker(const ros::Time& stamp, const std::string& frame, const core::LoopEvent& loop,
                                      int id, double z)
{
  visualization_msgs::Marker m;
  m.header.stamp = stamp;
  m.header.frame_id = frame;
  m.ns = "loops";
  m.id = id;
  m.type = visualization_msgs::Marker::LINE_LIST;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.scale.x = 0.15;
  const bool closed = loop.kind == core::LoopEvent::Kind::kClosed;
  m.color.r = closed ? 0.1f : 0.9f;
  m.color.g = closed ? 0.8f : 0.1f;
  m.color.b = 0.1f;
  m.color.a = 1.0f;
  for (const auto& link : loop.links)
  {
    geometry_msgs::Point a, b;
    a.x = link.first.x();
    a.y = link.first.y();
    b.x = link.second.x();
    b.y = link.second.y();
    a.z = b.z = z;
    m.points.push_back(a);
    m.points.push_back(b);
  }
  return m;
}

visualization_msgs::MarkerArray::Ptr changeMarkers(const ros::Time& stamp, const std::string& frame,
                                                   const std::vector<core::TreeChange>& changes)
{
  auto markers = boost::make_shared<visualization_msgs::MarkerArray>();
  const visualization_msgs::Marker clear = deleteAll(stamp, frame);
  markers->markers.push_back(clear);
  for (const core::TreeChange& c : changes)
  {
    if (c.kind == core::ChangeKind::kChanged)
      continue;
    const double dbh = c.kind == core::ChangeKind::kFelled ? c.dbh_before : c.dbh_after;
    visualization_msgs::Marker m = cylinder(clear.header, core::toString(c.kind), c.id, c.center.x(), c.center.y(), 1.5,
                                            std::max(0.3, std::isfinite(dbh) ? dbh + 0.2 : 0.3), 3.0, 0.6f);
    if (c.kind == core::ChangeKind::kFelled)
      m.color.r = 1.0f;
    else
    {
      m.color.g = 0.4f;
      m.color.b = 1.0f;
    }
    markers->markers.push_back(m);
  }
  return markers;
}

}  // namespace rbpf_slam
