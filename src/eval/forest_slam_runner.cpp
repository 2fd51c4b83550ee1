#include "rbpf_slam/eval/forest_slam_runner.h"

#include <cmath>
#include <memory>
#include <utility>

namespace rbpf_slam
{
namespace core
{

PlanarScan toPlanarScan(const LaserScan2D& scan)
{
  PlanarScan p;
  p.ranges = scan.ranges;
  p.angle_min = scan.angle_min;
  p.angle_increment = scan.angle_increment;
  p.range_min = scan.range_min;
  p.range_max = scan.range_max;
  return p;
}

ForestSlamRunResult runForestSlam(const ForestWorld& world, const ForestSlamRunConfig& config)
{
  return runForestSlamVariants(world, config.scenario, { ForestSlamVariant{ config.detector, config.filter } }).front();
}

std::vector<ForestSlamRunResult> runForestSlamVariants(const ForestWorld& world, const ScenarioConfig& scenario_config,
                                                       const std::vector<ForestSlamVariant>& variants,
                                                       double match_gate)
{
  const std::size_t n = variants.size();
  std::vector<ForestSlamRunResult> results(n);
  if (n == 0)
    return results;
  Scenario scenario(world, scenario_config);
  ForestSimulator& sim = scenario.simulator();
  const SimulatorConfig& sc = sim.config();
  // The 2D scanner is the sensor when the 3D lidar is off.
  const bool scans = !sc.lidar3d.enabled && sc.lidar2d.enabled;
  const Mount& sensor_mount = scans ? sc.lidar2d.mount : sc.lidar3d.mount;
  SensorMount mount;
  mount.x = sensor_mount.x;
  mount.y = sensor_mount.y;
  mount.z = sensor_mount.z;
  mount.yaw = sensor_mount.yaw;
  std::vector<std::unique_ptr<TrunkSlamPipeline>> pipelines;
  std::vector<FastSlamConfig> filters;
  for (const auto& v : variants)
  {
    // The filter takes the scope its sensor states (as the node and slam_bag do); the 1-12 m ring only counts trees.
    const FastSlamConfig& f = v.filter;
    filters.push_back(f);
    pipelines.emplace_back(new TrunkSlamPipeline(v.detector, f));  // sensor height from the mount
  }
  const Pose2 mount_pose(mount.x, mount.y, mount.yaw);
  const double period = 1.0 / sc.lidar3d.rate;
  // The scanner's field of view (for the trees it saw): its bearings in the sensor frame.
  const double fov_min = sc.lidar2d.angle_min, fov_max = sc.lidar2d.angle_max;
  const Pose2 start = sc.start;

  // The truth (for scoring only): trees at breast height in the start frame.
  const Ground ground(world.ground);
  const Pose2 inv_start = start.inverse();
  std::vector<MapPoint> trees;
  for (const auto& t : world.trunks)
  {
    MapPoint mp;
    const Eigen::Vector3d c = trunkAxisAt(t, ground.height(t.x, t.y), 1.3, &mp.radius);  // breast height
    inv_start.transformPoint(c.x(), c.y(), &mp.position.x(), &mp.position.y());
    trees.push_back(mp);
  }
  for (auto& res : results)
  {
    res.trees = trees;
    res.tree_seen.assign(trees.size(), false);
  }

  // The true pose at each sweep's middle, looked up while the simulator still holds it (scoring only); each
  // pipeline consumes the list at its own pace.
  std::vector<std::pair<double, Pose2>> truth_at;
  std::vector<std::size_t> truth_next(n, 0);
  std::vector<int> cover_updates(n, 0), cover_inside(n, 0);
  SimulatorOutput out;
  std::vector<Eigen::Vector3f> pts;
  int sweeps = 0;
  while (true)
  {
    out.clear();
    const bool more = scenario.step(&out);
    for (const auto& o : out.odometry)
      for (auto& pl : pipelines)
        pl->addOdometry(o.stamp, o.pose);
    for (const auto& sw : out.sweeps)
    {
      pts.clear();
      pts.reserve(sw.points.size());
      for (const auto& p : sw.points)
        pts.emplace_back(p.x, p.y, p.z);
      for (auto& pl : pipelines)
        pl->addSweep(sw.stamp, period, pts, mount);
      truth_at.emplace_back(sw.stamp + 0.5 * period, between(start, sim.poseAt(sw.stamp + 0.5 * period)));
      ++sweeps;
    }
    for (const auto& scan : out.scans)
    {
      if (!scans)
        break;
      const PlanarScan planar = toPlanarScan(scan);
      const double scan_period = scanPeriod(scan.time_increment, scan.ranges.size());
      for (auto& pl : pipelines)
        pl->addScan(scan.stamp, scan_period, planar, mount);
      truth_at.emplace_back(scan.stamp + 0.5 * scan_period, between(start, sim.poseAt(scan.stamp + 0.5 * scan_period)));
      ++sweeps;
    }
    for (std::size_t v = 0; v < n; ++v)
    {
      ForestSlamRunResult& res = results[v];
      for (const PipelineUpdate& u : pipelines[v]->process(NAN, !more))
      {
        std::size_t& next = truth_next[v];
        while (next < truth_at.size() && truth_at[next].first < u.stamp - 1e-9)
          ++next;
        const Pose2 truth = next < truth_at.size() ? truth_at[next].second : Pose2();
        if (!res.truth.empty())
          res.distance += std::hypot(truth.x - res.truth.back().x, truth.y - res.truth.back().y);
        res.stamps.push_back(u.stamp);
        res.estimate.push_back(u.estimate);
        res.odometry.push_back(u.odometry);
        res.truth.push_back(truth);
        res.update_stats.push_back(u.stats);
        if (u.stats.has_cloud)
        {
          ++cover_updates[v];
          cover_inside[v] += insideRegion95(Eigen::Vector2d(truth.x, truth.y), u.stats.cloud_mean,
                                            u.stats.cloud_covariance);
        }
        if (u.health.level == HealthLevel::kWarn)
          ++res.health_warnings;
        if (u.loop.kind != LoopEvent::Kind::kNone)
        {
          res.max_loop_seconds = std::max(res.max_loop_seconds, u.loop.seconds);
          if (u.loop.kind == LoopEvent::Kind::kRejected)
            ++res.loops_rejected;
          else
          {
            ++res.loops_closed;
            const std::size_t last = res.estimate.size() - 1;
            const double before = last > 0 ? std::hypot(res.estimate[last - 1].x - res.truth[last - 1].x,
                                                        res.estimate[last - 1].y - res.truth[last - 1].y) :
                                             0.0;
            const double after = std::hypot(u.estimate.x - truth.x, u.estimate.y - truth.y);
            res.false_loops += after > 1.0 && after > before;
          }
        }
        // Trees inside the true sensor's scope at this instant.
        const Pose2 true_sensor = truth * mount_pose;
        for (std::size_t k = 0; k < res.trees.size(); ++k)
        {
          const Eigen::Vector2d rel = res.trees[k].position - Eigen::Vector2d(true_sensor.x, true_sensor.y);
          const double d = rel.norm();
          // Counted as seen inside the 1-12 m ring, whatever the filter's scope.
          if (d < kForestRunMinRange || d > kForestRunMaxRange)
            continue;
          if (scans)
          {
            const double bearing = wrapAngle(std::atan2(rel.y(), rel.x()) - true_sensor.theta);
            if (bearing < fov_min || bearing > fov_max)
              continue;
          }
          res.tree_seen[k] = true;
        }
      }
    }
    if (!more)
      break;
  }

  for (std::size_t v = 0; v < n; ++v)
  {
    ForestSlamRunResult& res = results[v];
    const TrunkSlamPipeline& pipeline = *pipelines[v];
    res.sweeps = sweeps;
    res.seconds_extraction = pipeline.secondsExtraction();
    res.seconds_filter = pipeline.secondsFilter();
    const Particle& best = pipeline.filter().best();
    std::vector<MapPoint> features;
    for (std::size_t i = 0; i < best.map.size(); ++i)
    {
      res.landmarks.push_back(best.map[i]);
      features.push_back({ best.map[i].mean, best.map[i].radius });
    }
    res.map = scoreMap(res.trees, res.tree_seen, features, match_gate);
    res.simulated_seconds = sim.time();
    if (const Collision* c = sim.collision())
    {
      res.collided = true;
      res.collision = *c;
      res.collision_what = c->what(sim.world());
    }
    if (!res.estimate.empty())
    {
      const auto err = [](const Pose2& a, const Pose2& b) { return std::hypot(a.x - b.x, a.y - b.y); };
      res.final_error = err(res.estimate.back(), res.truth.back());
      res.final_error_odometry = err(res.odometry.back(), res.truth.back());
      res.ate = absoluteTrajectoryRmse(res.estimate, res.truth);
      if (cover_updates[v] > 0)
        res.coverage = static_cast<double>(cover_inside[v]) / cover_updates[v];
      res.ate_odometry = absoluteTrajectoryRmse(res.odometry, res.truth);
    }
    const SmoothedRun smoothed = pipeline.smoothed();
    if (smoothed.ok && !smoothed.poses.empty())
    {
      // The smoothed path is one pose per filter update: paired with the truth by stamp.
      std::vector<Pose2> est, tru;
      std::size_t j = 0;
      for (std::size_t i = 0; i < smoothed.stamps.size(); ++i)
      {
        while (j < res.stamps.size() && res.stamps[j] < smoothed.stamps[i] - 1e-9)
          ++j;
        if (j < res.stamps.size() && std::abs(res.stamps[j] - smoothed.stamps[i]) < 1e-9)
        {
          est.push_back(smoothed.poses[i]);
          tru.push_back(res.truth[j]);
        }
      }
      if (!est.empty())
      {
        res.smoothed = true;
        res.final_error_smoothed = std::hypot(est.back().x - tru.back().x, est.back().y - tru.back().y);
        res.ate_smoothed = absoluteTrajectoryRmse(est, tru);
        res.landmarks_smoothed = smoothed.trees;
        res.stamps_smoothed = smoothed.stamps;
        res.estimate_smoothed = smoothed.poses;
        std::vector<MapPoint> smoothed_features;
        for (const Landmark& l : smoothed.trees)
          smoothed_features.push_back({ l.mean, l.radius });
        res.map_smoothed = scoreMap(res.trees, res.tree_seen, smoothed_features, match_gate);
      }
    }
  }
  return results;
}

}  // namespace core
}  // namespace rbpf_slam
