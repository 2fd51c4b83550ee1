#include "rbpf_slam/eval/forest_slam_runner.h"

#include <cmath>
#include <memory>
#include <utility>

namespace rbpf_slam
{
namespace eval
{
using core::between;
using core::TrunkSlamConfig;
using core::HealthLevel;
using core::insideRegion95;
using core::Landmark;
using core::LoopEvent;
using core::Particle;
using core::PipelineUpdate;
using core::PlanarScan;
using core::Pose2;
using core::scanPeriod;
using core::SensorMount;
using core::SmoothedRun;
using core::TrunkSlamPipeline;
using core::wrapAngle;
using sim::Collision;
using sim::ForestSimulator;
using sim::ForestWorld;
using sim::Ground;
using sim::LaserScan2D;
using sim::Mount;
using sim::Scenario;
using sim::ScenarioConfig;
using sim::SimulatorConfig;
using sim::SimulatorOutput;
using sim::trunkAxisAt;

namespace
{
/** @brief The sensor the filters are fed, as the runner sees it. */
struct SensorSetup
{
  bool scans = false;  ///< the 2D scanner is the sensor (the 3D lidar is off)
  SensorMount mount;
  Pose2 mount_pose;
  double period = 0.0;  ///< [s] of a 3D sweep
  /// The scanner's field of view (for the trees it saw): its bearings in the sensor frame.
  double fov_min = 0.0, fov_max = 0.0;
};

SensorSetup sensorSetup(const SimulatorConfig& sc)
{
  SensorSetup s;
  // The 2D scanner is the sensor when the 3D lidar is off.
  s.scans = !sc.lidar3d.enabled && sc.lidar2d.enabled;
  const Mount& sensor_mount = s.scans ? sc.lidar2d.mount : sc.lidar3d.mount;
  s.mount.x = sensor_mount.x;
  s.mount.y = sensor_mount.y;
  s.mount.z = sensor_mount.z;
  s.mount.yaw = sensor_mount.yaw;
  s.mount_pose = Pose2(s.mount.x, s.mount.y, s.mount.yaw);
  s.period = 1.0 / sc.lidar3d.rate;
  s.fov_min = sc.lidar2d.angle_min;
  s.fov_max = sc.lidar2d.angle_max;
  return s;
}

/** @brief The truth (for scoring only): trees at breast height in the start frame. */
std::vector<MapPoint> trueTrees(const ForestWorld& world, const Pose2& start)
{
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
  return trees;
}

/** @brief The pipelines fed the one simulation, and the truth kept to score them. */
struct PipelineFeed
{
  PipelineFeed(const SensorSetup& sensor_setup, const Pose2& start_pose) : sensor(sensor_setup), start(start_pose) {}

  const SensorSetup& sensor;
  Pose2 start;
  std::vector<std::unique_ptr<TrunkSlamPipeline>> pipelines;
  /// The true pose at each sweep's middle, looked up while the simulator still holds it (scoring only); each
  /// pipeline consumes the list at its own pace.
  std::vector<std::pair<double, Pose2>> truth_at;
  std::vector<Eigen::Vector3f> pts;  ///< a sweep's points (reused)
  int sweeps = 0;

  /** @brief Hands one step's odometry and sweeps (or scans) to every pipeline. */
  void add(const SimulatorOutput& out, const ForestSimulator& sim)
  {
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
        pl->addSweep(sw.stamp, sensor.period, pts, sensor.mount);
      truth_at.emplace_back(sw.stamp + 0.5 * sensor.period, between(start, sim.poseAt(sw.stamp + 0.5 * sensor.period)));
      ++sweeps;
    }
    for (const auto& scan : out.scans)
    {
      if (!sensor.scans)
        break;
      const PlanarScan planar = toPlanarScan(scan);
      const double scan_period = scanPeriod(scan.time_increment, scan.ranges.size());
      for (auto& pl : pipelines)
        pl->addScan(scan.stamp, scan_period, planar, sensor.mount);
      truth_at.emplace_back(scan.stamp + 0.5 * scan_period, between(start, sim.poseAt(scan.stamp + 0.5 * scan_period)));
      ++sweeps;
    }
  }
};

/** @brief What is counted of one variant's updates on the way. */
struct VariantTally
{
  std::size_t truth_next = 0;  ///< into PipelineFeed::truth_at
  int cover_updates = 0, cover_inside = 0;
};

/** @brief Counts a loop the update closed or refused; a closed loop is false when it took the estimate away. */
void countLoop(const PipelineUpdate& u, const Pose2& truth, ForestSlamRunResult* result)
{
  ForestSlamRunResult& res = *result;
  if (u.loop.kind == LoopEvent::Kind::kNone)
    return;
  res.max_loop_seconds = std::max(res.max_loop_seconds, u.loop.seconds);
  if (u.loop.kind == LoopEvent::Kind::kRejected)
    ++res.loops_rejected;
  else
  {
    ++res.loops_closed;
    const std::size_t last = res.estimate.size() - 1;
    const double before = last > 0 ? std::hypot(res.estimate[last - 1].x - res.truth[last - 1].x,
                                                res.estimate[last - 1].y - res.truth[last - 1].y)
                                   : 0.0;
    const double after = std::hypot(u.estimate.x - truth.x, u.estimate.y - truth.y);
    res.false_loops += after > 1.0 && after > before;
  }
}

/** @brief Marks the trees inside the true sensor's scope at @p truth as seen. */
void markSeenTrees(const Pose2& truth, const SensorSetup& sensor, ForestSlamRunResult* res)
{
  const Pose2 true_sensor = truth * sensor.mount_pose;
  for (std::size_t k = 0; k < res->trees.size(); ++k)
  {
    const Eigen::Vector2d rel = res->trees[k].position - Eigen::Vector2d(true_sensor.x, true_sensor.y);
    const double d = rel.norm();
    // Counted as seen inside the 1-12 m ring, whatever the filter's scope.
    if (d < kForestRunMinRange || d > kForestRunMaxRange)
      continue;
    if (sensor.scans)
    {
      const double bearing = wrapAngle(std::atan2(rel.y(), rel.x()) - true_sensor.theta);
      if (bearing < sensor.fov_min || bearing > sensor.fov_max)
        continue;
    }
    res->tree_seen[k] = true;
  }
}

/** @brief Records one filter update of a variant with the true pose at its stamp. */
void recordUpdate(const PipelineUpdate& u, const PipelineFeed& feed, VariantTally* tally, ForestSlamRunResult* result)
{
  ForestSlamRunResult& res = *result;
  std::size_t& next = tally->truth_next;
  const std::vector<std::pair<double, Pose2>>& truth_at = feed.truth_at;
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
    // The region the robot is told: the published estimate with its covariance.
    ++tally->cover_updates;
    tally->cover_inside += insideRegion95(Eigen::Vector2d(truth.x, truth.y), Eigen::Vector2d(u.estimate.x, u.estimate.y),
                                          u.covariance.topLeftCorner<2, 2>());
  }
  if (u.health.level == HealthLevel::kWarn)
    ++res.health_warnings;
  countLoop(u, truth, &res);
  markSeenTrees(truth, feed.sensor, &res);
}

/** @brief Scores the run smoothed at its end, its path paired with the truth by stamp. */
void scoreSmoothed(const SmoothedRun& smoothed, double match_gate, ForestSlamRunResult* result)
{
  ForestSlamRunResult& res = *result;
  if (!smoothed.ok || smoothed.poses.empty())
    return;
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
  if (est.empty())
    return;
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

/** @brief Fills in a variant's result once the run is over: its map, errors, collision and smoothed run. */
void finishVariant(const TrunkSlamPipeline& pipeline, const ForestSimulator& sim, int sweeps, const VariantTally& tally,
                   double match_gate, ForestSlamRunResult* result)
{
  ForestSlamRunResult& res = *result;
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
    if (tally.cover_updates > 0)
      res.coverage = static_cast<double>(tally.cover_inside) / tally.cover_updates;
    res.ate_odometry = absoluteTrajectoryRmse(res.odometry, res.truth);
  }
  scoreSmoothed(pipeline.smoothed(), match_gate, &res);
}
}  // namespace

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
  const SensorSetup sensor = sensorSetup(sc);
  PipelineFeed feed(sensor, sc.start);
  for (const auto& v : variants)
  {
    // The filter takes the scope its sensor states (as the node and slam_bag do); the 1-12 m ring only counts trees.
    const TrunkSlamConfig& f = v.filter;
    feed.pipelines.emplace_back(new TrunkSlamPipeline(v.detector, f));  // sensor height from the mount
  }

  const std::vector<MapPoint> trees = trueTrees(world, feed.start);
  for (auto& res : results)
  {
    res.trees = trees;
    res.tree_seen.assign(trees.size(), false);
  }

  std::vector<VariantTally> tallies(n);
  SimulatorOutput out;
  while (true)
  {
    out.clear();
    const bool more = scenario.step(&out);
    feed.add(out, sim);
    for (std::size_t v = 0; v < n; ++v)
      for (const PipelineUpdate& u : feed.pipelines[v]->process(NAN, !more))
        recordUpdate(u, feed, &tallies[v], &results[v]);
    if (!more)
      break;
  }

  for (std::size_t v = 0; v < n; ++v)
    finishVariant(*feed.pipelines[v], sim, feed.sweeps, tallies[v], match_gate, &results[v]);
  return results;
}

}  // namespace eval
}  // namespace rbpf_slam
