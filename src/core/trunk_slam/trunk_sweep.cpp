#include "rbpf_slam/core/trunk_slam/trunk_sweep.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>

namespace rbpf_slam
{
namespace core
{
double evidenceShare(const FastSlamConfig& config, const std::vector<TrunkObservation>& trunks,
                     const Pose2& sensor_motion)
{
  if (!(config.evidence_view_change > 0.0))
    return 1.0;
  std::vector<double> ranges;
  ranges.reserve(trunks.size());
  for (const TrunkObservation& t : trunks)
    if (std::isfinite(t.center.x()) && std::isfinite(t.center.y()))
      ranges.push_back(t.center.norm());
  if (ranges.empty())
    return 1.0;
  const auto mid = ranges.begin() + static_cast<std::ptrdiff_t>(ranges.size() / 2);
  std::nth_element(ranges.begin(), mid, ranges.end());
  const double view = config.evidence_view_change;
  return std::min(1.0, std::hypot(sensor_motion.x, sensor_motion.y) / (view * std::max(*mid, 1e-3)));
}

int fuseSkippedLooks(std::vector<LandmarkObservation>* obs, const Pose2& sensor,
                     const std::vector<std::vector<LookPoint>>& skipped, double gate)
{
  int fused = 0;
  for (LandmarkObservation& o : *obs)
  {
    const double c = std::cos(o.bearing), s = std::sin(o.bearing);
    Eigen::Matrix2d J;  // d(x, y) / d(range, bearing) in the sensor frame
    J << c, -o.range * s, s, o.range * c;
    double sx = 0.0, sy = 0.0;
    sensor.transformPoint(o.range * c, o.range * s, &sx, &sy);
    const Eigen::Vector2d q(sx, sy);
    const Eigen::Matrix2d rot = Eigen::Rotation2Dd(sensor.theta).toRotationMatrix();
    // Two looks of one trunk differ by at most both their errors.
    const Eigen::Matrix2d both = 2.0 * rot * J * o.covariance * J.transpose() * rot.transpose();
    const Eigen::Matrix2d both_inv = both.inverse();
    if (!both_inv.allFinite())
      continue;
    Eigen::Vector2d sum = q;
    double radius_sum = o.radius;
    int n = 1;
    for (const std::vector<LookPoint>& sweep : skipped)
    {
      const LookPoint* best = nullptr;
      double best_d2 = gate;
      for (const LookPoint& l : sweep)
      {
        if (o.id >= 0 && l.id >= 0 && o.id != l.id)
          continue;
        const Eigen::Vector2d v = l.position - q;
        const double d2 = v.dot(both_inv * v);
        if (d2 < best_d2)
        {
          best_d2 = d2;
          best = &l;
        }
      }
      if (!best)
        continue;
      sum += best->position;
      radius_sum += best->radius;
      ++n;
    }
    if (n == 1)
      continue;
    fused += n - 1;
    double mx = 0.0, my = 0.0;
    const Eigen::Vector2d mean = sum / n;
    sensor.inverse().transformPoint(mean.x(), mean.y(), &mx, &my);
    o.range = std::hypot(mx, my);
    o.bearing = std::atan2(my, mx);
    o.radius = radius_sum / n;
  }
  return fused;
}

TrunkDetectorConfig withMountHeight(TrunkDetectorConfig config, double mount_z)
{
  if (!(config.sensor_height > 0.0) && std::isfinite(mount_z) && mount_z > 0.0)
    config.sensor_height = mount_z;
  return config;
}

double scanPeriod(double time_increment, std::size_t beams)
{
  if (!(std::isfinite(time_increment) && time_increment > 0.0) || beams < 2)
    return 0.0;
  return time_increment * static_cast<double>(beams - 1);
}

SweepGeometry scanGeometry(const PlanarScan& scan)
{
  SweepGeometry g;
  g.start_angle = scan.angle_min;
  g.span = std::max(1e-9, std::abs(scan.angle_increment) *
                              static_cast<double>(scan.ranges.size() > 1 ? scan.ranges.size() - 1 : 1));
  return g;
}

SensorScope scanScope(const PlanarScan& scan, const TrunkDetectorConfig& config)
{
  SensorScope s;
  const double last = scan.angle_min + scan.angle_increment * static_cast<double>(
                                           scan.ranges.empty() ? 0 : scan.ranges.size() - 1);
  s.fov_min = std::min(scan.angle_min, last);
  s.fov_max = std::max(scan.angle_min, last);
  s.min_range = std::max(std::isfinite(scan.range_min) ? scan.range_min : 0.0, config.min_range);
  s.max_range = std::isfinite(scan.range_max) && scan.range_max > 0.0 ? std::min(scan.range_max, config.max_range)
                                                                      : config.max_range;
  s.detection_probability = config.detection_probability;
  return s;
}

SensorScope sweepScope(const TrunkDetectorConfig& config, double reach)
{
  SensorScope s;
  s.fov_min = -M_PI;
  s.fov_max = M_PI;
  s.min_range = config.min_range;
  s.max_range = std::isfinite(reach) && reach > 0.0 ? std::min(reach, config.max_range) : config.max_range;
  s.detection_probability = config.detection_probability;
  return s;
}

std::vector<LandmarkObservation> sweepObservations(const std::vector<TrunkObservation>& trunks, double stamp,
                                                   double period, double tilt_roll, double tilt_pitch,
                                                   const SensorMount& mount, const OdometryBuffer& odometry,
                                                   double t_ref, const SweepGeometry& geometry)
{
  const Pose2 mount_pose(mount.x, mount.y, mount.yaw);
  const Eigen::Vector2d lever = mount.z * Eigen::Vector2d(std::tan(tilt_pitch), -std::tan(tilt_roll));
  const Pose2 sensor_ref = odometry.at(t_ref) * mount_pose;
  const Pose2 sensor_ref_inv = sensor_ref.inverse();
  std::vector<LandmarkObservation> obs;
  obs.reserve(trunks.size());
  for (const auto& t0 : trunks)
  {
    TrunkObservation t = t0;
    t.center += lever;
    t.range = t.center.norm();
    t.bearing = std::atan2(t.center.y(), t.center.x());
    double turned = t.bearing - geometry.start_angle;  // counter-clockwise from the sweep's first bearing
    turned -= 2.0 * M_PI * std::floor(turned / (2.0 * M_PI));
    const double t_obs = stamp + period * std::min(1.0, turned / geometry.span);
    const Pose2 sensor_obs = odometry.at(t_obs) * mount_pose;
    double wx = 0.0, wy = 0.0, mx = 0.0, my = 0.0;
    sensor_obs.transformPoint(t.center.x(), t.center.y(), &wx, &wy);
    sensor_ref_inv.transformPoint(wx, wy, &mx, &my);
    TrunkObservation moved = t;
    moved.center = Eigen::Vector2d(mx, my);
    const Eigen::Matrix2d R = Eigen::Rotation2Dd(sensor_obs.theta - sensor_ref.theta).toRotationMatrix();
    moved.covariance = R * t.covariance * R.transpose();
    obs.push_back(toLandmarkObservation(moved));
  }
  return obs;
}

std::vector<LookPoint> sweepLooks(const TrunkSweep& sw, const OdometryBuffer& odometry, double t_mid)
{
  const Pose2 sensor_mid = odometry.at(t_mid) * Pose2(sw.mount.x, sw.mount.y, sw.mount.yaw);
  std::vector<LookPoint> looks;
  for (const LandmarkObservation& o : sweepObservations(sw.trunks, sw.stamp, sw.period, sw.tilt_roll, sw.tilt_pitch,
                                                        sw.mount, odometry, t_mid, sw.geometry))
  {
    LookPoint l;
    sensor_mid.transformPoint(o.range * std::cos(o.bearing), o.range * std::sin(o.bearing), &l.position.x(),
                              &l.position.y());
    l.radius = o.radius;
    l.id = o.id;
    looks.push_back(l);
  }
  return looks;
}

TrunkSweep detectSweep(TrunkDetector* detector, double stamp, double period,
                       const std::vector<Eigen::Vector3f>& points, const SensorMount& mount)
{
  if (!(detector->config().sensor_height > 0.0) && mount.z > 0.0)  // as the extraction nodelet does from TF
    detector->setConfig(withMountHeight(detector->config(), mount.z));
  TrunkDetectorStats stats;
  TrunkSweep sweep;
  sweep.stamp = stamp;
  sweep.period = period;
  sweep.mount = mount;
  sweep.trunks = detector->detect(points, Eigen::Matrix3d::Identity(), &stats);
  sweep.scope = sweepScope(detector->config(), stats.reach);
  sweep.reach_shortfall = reachShortfall(detector->config(), stats);
  sweep.tilt_roll = stats.tilt_roll;
  sweep.tilt_pitch = stats.tilt_pitch;
  return sweep;
}

TrunkSweep detectScanSweep(TrunkDetector* detector, double stamp, double period, const PlanarScan& scan,
                           const SensorMount& mount)
{
  TrunkSweep sweep;
  sweep.stamp = stamp;
  sweep.period = period;
  sweep.mount = mount;
  sweep.trunks = detector->detectScan(scan);
  sweep.geometry = scanGeometry(scan);
  sweep.scope = scanScope(scan, detector->config());
  return sweep;
}

void zeroUnknownTiming(TrunkSweep* sweep)
{
  if (!std::isfinite(sweep->period) || sweep->period < 0.0)
    sweep->period = 0.0;
  if (!std::isfinite(sweep->tilt_roll))
    sweep->tilt_roll = 0.0;
  if (!std::isfinite(sweep->tilt_pitch))
    sweep->tilt_pitch = 0.0;
}

}  // namespace core
}  // namespace rbpf_slam
