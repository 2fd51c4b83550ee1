#include "rbpf_slam/core/forest_slam_runner.h"

#include <chrono>
#include <cmath>
#include <deque>

namespace rbpf_slam
{
namespace core
{
namespace
{
/** Odometry pose at time t from the buffer (linear interpolation; clamped at the ends). */
Pose2 odometryAt(const std::deque<OdometrySample>& buf, double t)
{
  if (buf.empty())
    return Pose2();
  if (t <= buf.front().stamp)
    return buf.front().pose;
  for (std::size_t i = 1; i < buf.size(); ++i)
    if (buf[i].stamp >= t)
    {
      const double s = (t - buf[i - 1].stamp) / std::max(1e-12, buf[i].stamp - buf[i - 1].stamp);
      return interpolate(buf[i - 1].pose, buf[i].pose, s);
    }
  return buf.back().pose;
}

double seconds(std::chrono::steady_clock::time_point a)
{
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count();
}
}  // namespace

ForestSlamRunResult runForestSlam(const ForestWorld& world, const ForestSlamRunConfig& config)
{
  ForestSlamRunResult res;
  Scenario scenario(world, config.scenario);
  ForestSimulator& sim = scenario.simulator();
  const SimulatorConfig& sc = sim.config();
  TrunkDetectorConfig dc = config.detector;
  if (dc.sensor_height <= 0.0)
    dc.sensor_height = sc.lidar3d.mount.z;  // what TF says on a robot
  TrunkDetector detector(dc);
  FastSlam filter(config.filter);
  const Pose2 mount(sc.lidar3d.mount.x, sc.lidar3d.mount.y, sc.lidar3d.mount.yaw);
  const double period = 1.0 / sc.lidar3d.rate;
  const Pose2 start = sc.start;

  // The truth (for scoring only): trees at breast height in the start frame.
  const Ground ground(world.ground);
  const Pose2 inv_start = start.inverse();
  for (const auto& t : world.trunks)
  {
    const double bh = 1.3;
    MapPoint mp;
    const Eigen::Vector3d axis = Eigen::Vector3d(t.lean_x, t.lean_y, 1.0).normalized();
    const double s = bh / axis.z();
    inv_start.transformPoint(t.x + s * axis.x(), t.y + s * axis.y(), &mp.position.x(), &mp.position.y());
    mp.radius = t.radius - t.taper * s;
    res.trees.push_back(mp);
  }
  res.tree_seen.assign(res.trees.size(), false);

  struct PendingSweep
  {
    double stamp;
    std::vector<TrunkObservation> trunks;
    Pose2 truth_mid;
  };
  std::deque<PendingSweep> pending;
  std::deque<OdometrySample> odom;
  bool initialized = false;
  Pose2 last_odom_pose;
  SimulatorOutput out;
  std::vector<Eigen::Vector3f> pts;
  while (true)
  {
    out.clear();
    const bool more = scenario.step(&out);
    for (const auto& o : out.odometry)
      odom.push_back(o);
    for (const auto& sw : out.sweeps)
    {
      pts.clear();
      pts.reserve(sw.points.size());
      for (const auto& p : sw.points)
        pts.emplace_back(p.x, p.y, p.z);
      const auto t0 = std::chrono::steady_clock::now();
      PendingSweep ps;
      ps.stamp = sw.stamp;
      TrunkDetectorStats stats;
      ps.trunks = detector.detect(pts, Eigen::Matrix3d::Identity(), &stats);
      // Lever arm: when the body tilts, the sensor on its mast is not above base_link. The detector's
      // levelled frame is centred on the sensor; base_link's origin lies mount_z * (tan pitch, -tan roll)
      // behind it, so the trunks relative to the levelled base are shifted by that much.
      const Eigen::Vector2d lever = sc.lidar3d.mount.z * Eigen::Vector2d(std::tan(stats.tilt_pitch), -std::tan(stats.tilt_roll));
      for (auto& t : ps.trunks)
      {
        t.center += lever;
        t.range = t.center.norm();
        t.bearing = std::atan2(t.center.y(), t.center.x());
      }
      res.seconds_extraction += seconds(t0);
      ps.truth_mid = between(start, sim.poseAt(sw.stamp + 0.5 * period));
      pending.push_back(std::move(ps));
      ++res.sweeps;
    }
    // Process the sweeps that odometry now covers.
    while (!pending.empty() && !odom.empty() && odom.back().stamp >= pending.front().stamp + period)
    {
      PendingSweep ps = std::move(pending.front());
      pending.pop_front();
      const double t_mid = ps.stamp + 0.5 * period;
      const Pose2 odom_mid = odometryAt(odom, t_mid);
      const auto t0 = std::chrono::steady_clock::now();
      if (!initialized)
      {
        filter.initialize(Pose2());  // the map frame is the start pose; odometry starts there too
        last_odom_pose = odom.front().pose;
        initialized = true;
      }
      filter.predict(decomposeOdometry(last_odom_pose, odom_mid));
      last_odom_pose = odom_mid;
      // Each trunk at its own instant: sensor-frame bearing b was measured (b + pi) / 2 pi into the sweep.
      std::vector<LandmarkObservation> obs;
      obs.reserve(ps.trunks.size());
      const Pose2 base_mid_inv = odom_mid.inverse();
      for (const auto& t : ps.trunks)
      {
        const double t_obs = ps.stamp + period * (wrapAngle(t.bearing) + M_PI) / (2.0 * M_PI);
        const Pose2 sensor_obs = odometryAt(odom, t_obs) * mount;
        const Pose2 sensor_mid = odom_mid * mount;
        double wx = 0.0, wy = 0.0, mx = 0.0, my = 0.0;
        sensor_obs.transformPoint(t.center.x(), t.center.y(), &wx, &wy);
        sensor_mid.inverse().transformPoint(wx, wy, &mx, &my);
        TrunkObservation moved = t;
        moved.center = Eigen::Vector2d(mx, my);
        const double rot = sensor_obs.theta - sensor_mid.theta;
        const Eigen::Matrix2d R = Eigen::Rotation2Dd(rot).toRotationMatrix();
        moved.covariance = R * t.covariance * R.transpose();
        obs.push_back(toLandmarkObservation(moved));
      }
      (void)base_mid_inv;
      filter.update(obs, mount);
      res.seconds_filter += seconds(t0);

      res.stamps.push_back(t_mid);
      res.estimate.push_back(filter.best().pose);
      res.odometry.push_back(odom_mid);
      res.truth.push_back(ps.truth_mid);
      // Trees inside the true sensor's scope at this instant.
      const Pose2 true_sensor = ps.truth_mid * mount;
      for (std::size_t k = 0; k < res.trees.size(); ++k)
      {
        const double d = (res.trees[k].position - Eigen::Vector2d(true_sensor.x, true_sensor.y)).norm();
        if (d >= config.filter.min_range && d <= config.filter.max_range)
          res.tree_seen[k] = true;
      }
      // Odometry older than the next sweep is no longer needed.
      while (odom.size() > 2 && !pending.empty() && odom[1].stamp < pending.front().stamp - 0.05)
        odom.pop_front();
      while (odom.size() > 2 && pending.empty() && odom[1].stamp < t_mid - 0.05)
        odom.pop_front();
    }
    if (!more)
      break;
  }

  const Particle& best = filter.best();
  std::vector<MapPoint> features;
  for (std::size_t i = 0; i < best.map.size(); ++i)
  {
    res.landmarks.push_back(best.map[i]);
    features.push_back({ best.map[i].mean, best.map[i].radius });
  }
  res.map = scoreMap(res.trees, res.tree_seen, features);
  if (!res.estimate.empty())
  {
    const auto err = [](const Pose2& a, const Pose2& b) { return std::hypot(a.x - b.x, a.y - b.y); };
    res.final_error = err(res.estimate.back(), res.truth.back());
    res.final_error_odometry = err(res.odometry.back(), res.truth.back());
    res.ate = absoluteTrajectoryRmse(res.estimate, res.truth);
    res.ate_odometry = absoluteTrajectoryRmse(res.odometry, res.truth);
  }
  return res;
}

}  // namespace core
}  // namespace rbpf_slam
