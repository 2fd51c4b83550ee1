#include "rbpf_slam/core/forest_slam_runner.h"

#include <cmath>
#include <deque>

namespace rbpf_slam
{
namespace core
{

ForestSlamRunResult runForestSlam(const ForestWorld& world, const ForestSlamRunConfig& config)
{
  ForestSlamRunResult res;
  Scenario scenario(world, config.scenario);
  ForestSimulator& sim = scenario.simulator();
  const SimulatorConfig& sc = sim.config();
  TrunkDetectorConfig dc = config.detector;
  if (dc.sensor_height <= 0.0)
    dc.sensor_height = sc.lidar3d.mount.z;  // what TF says on a robot
  SensorMount mount;
  mount.x = sc.lidar3d.mount.x;
  mount.y = sc.lidar3d.mount.y;
  mount.z = sc.lidar3d.mount.z;
  mount.yaw = sc.lidar3d.mount.yaw;
  TrunkSlamPipeline pipeline(dc, config.filter, mount);
  const Pose2 mount_pose(mount.x, mount.y, mount.yaw);
  const double period = 1.0 / sc.lidar3d.rate;
  const Pose2 start = sc.start;

  // The truth (for scoring only): trees at breast height in the start frame.
  const Ground ground(world.ground);
  const Pose2 inv_start = start.inverse();
  for (const auto& t : world.trunks)
  {
    MapPoint mp;
    const Eigen::Vector3d c = trunkAxisAt(t, ground.height(t.x, t.y), 1.3, &mp.radius);  // breast height
    inv_start.transformPoint(c.x(), c.y(), &mp.position.x(), &mp.position.y());
    res.trees.push_back(mp);
  }
  res.tree_seen.assign(res.trees.size(), false);

  // The true pose at each sweep's middle, looked up while the simulator still holds it (scoring only).
  std::deque<std::pair<double, Pose2>> truth_at;
  SimulatorOutput out;
  std::vector<Eigen::Vector3f> pts;
  while (true)
  {
    out.clear();
    const bool more = scenario.step(&out);
    for (const auto& o : out.odometry)
      pipeline.addOdometry(o.stamp, o.pose);
    for (const auto& sw : out.sweeps)
    {
      pts.clear();
      pts.reserve(sw.points.size());
      for (const auto& p : sw.points)
        pts.emplace_back(p.x, p.y, p.z);
      pipeline.addSweep(sw.stamp, period, pts);
      truth_at.emplace_back(sw.stamp + 0.5 * period, between(start, sim.poseAt(sw.stamp + 0.5 * period)));
      ++res.sweeps;
    }
    for (const PipelineUpdate& u : pipeline.process(!more))
    {
      while (!truth_at.empty() && truth_at.front().first < u.stamp - 1e-9)
        truth_at.pop_front();
      const Pose2 truth = truth_at.empty() ? Pose2() : truth_at.front().second;
      res.stamps.push_back(u.stamp);
      res.estimate.push_back(pipeline.filter().best().pose);
      res.odometry.push_back(u.odometry);
      res.truth.push_back(truth);
      // Trees inside the true sensor's scope at this instant.
      const Pose2 true_sensor = truth * mount_pose;
      for (std::size_t k = 0; k < res.trees.size(); ++k)
      {
        const double d = (res.trees[k].position - Eigen::Vector2d(true_sensor.x, true_sensor.y)).norm();
        if (d >= config.filter.min_range && d <= config.filter.max_range)
          res.tree_seen[k] = true;
      }
    }
    if (!more)
      break;
  }
  res.seconds_extraction = pipeline.secondsExtraction();
  res.seconds_filter = pipeline.secondsFilter();

  const Particle& best = pipeline.filter().best();
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
