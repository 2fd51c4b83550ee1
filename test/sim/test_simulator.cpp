#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/filter/random.h"
#include "rbpf_slam/sim/drive_check.h"
#include "rbpf_slam/sim/forest_simulator.h"
#include "rbpf_slam/sim/scenario.h"

using namespace rbpf_slam::core;
using namespace rbpf_slam::sim;

namespace
{
ForestWorld flatWorld()
{
  ForestWorld w;
  w.ground.amplitude = 0.0;
  return w;
}

SimulatorConfig quietConfig()
{
  SimulatorConfig c;
  c.start = Pose2(0.0, 0.0, 0.0);
  c.lidar3d.enabled = false;
  c.robot.max_linear_accel = 1e6;
  c.robot.max_angular_accel = 1e6;
  c.odometry.wheel_sigma = 0.0;
  c.odometry.left_scale = c.odometry.right_scale = 1.0;
  return c;
}

/** @brief Drives at constant command for @p seconds; returns the last odometry sample. */
OdometrySample drive(ForestSimulator* sim, const VelocityCommand& cmd, double seconds)
{
  sim->setCommand(cmd);
  SimulatorOutput out;
  OdometrySample last;
  while (sim->time() < seconds - 1e-9)
  {
    out.clear();
    sim->step(&out);
    if (!out.odometry.empty())
      last = out.odometry.back();
  }
  return last;
}
}  // namespace

TEST(Simulator, ScaleMismatchCurvesDeadReckoningAsPredicted)
{
  SimulatorConfig c = quietConfig();
  c.odometry.latency = 0.0;
  c.odometry.left_scale = 1.0025;
  c.odometry.right_scale = 0.9975;
  ForestSimulator sim(flatWorld(), c);
  const OdometrySample odom = drive(&sim, { 1.0, 0.0 }, 30.0);
  // True motion: straight, 30 m. Odometry turns at (0.9975 - 1.0025) / 1.2 rad per metre.
  EXPECT_NEAR(sim.robot().pose().x, 30.0, 1e-6);
  EXPECT_NEAR(sim.robot().pose().y, 0.0, 1e-9);
  const double rate = -0.005 / 1.2;
  EXPECT_NEAR(odom.pose.theta, rate * 30.0, 1e-6);
  EXPECT_NEAR(odom.pose.y, rate * 30.0 * 30.0 / 2.0, 0.01);  // y = rate s^2 / 2 for small angles
}

TEST(Simulator, TurnSlipMakesOdometryOverestimateRotation)
{
  SimulatorConfig c = quietConfig();
  c.robot.turn_slip = 0.1;
  ForestSimulator sim(flatWorld(), c);
  const OdometrySample odom = drive(&sim, { 0.0, 0.5 }, 2.0);
  EXPECT_NEAR(sim.robot().pose().theta, 1.0, 1e-6);
  EXPECT_NEAR(odom.pose.theta, 1.1 * wrapAngle(sim.poseAt(odom.stamp).theta), 1e-3);
}

TEST(Simulator, WheelNoiseGrowsHeadingVarianceLinearlyWithDistance)
{
  const double sigma = 0.01, track = 1.2, distance = 20.0;
  std::vector<double> headings;
  for (int seed = 0; seed < 300; ++seed)
  {
    SimulatorConfig c = quietConfig();
    c.odometry.wheel_sigma = sigma;
    c.seed = static_cast<std::uint64_t>(seed);
    ForestSimulator sim(flatWorld(), c);
    headings.push_back(drive(&sim, { 1.0, 0.0 }, distance).pose.theta);
  }
  double mean = 0.0, var = 0.0;
  for (double h : headings)
    mean += h / headings.size();
  for (double h : headings)
    var += (h - mean) * (h - mean) / (headings.size() - 1);
  // Each wheel's travel has variance sigma^2 * distance; heading = (r - l) / track.
  const double expected = std::sqrt(2.0 * sigma * sigma * distance) / track;
  EXPECT_NEAR(std::sqrt(var), expected, 0.15 * expected);
  EXPECT_NEAR(mean, 0.0, 4.0 * expected / std::sqrt(headings.size()));
}

TEST(Simulator, OdometryIsStampedWithItsMeasurementTimeAndArrivesLate)
{
  SimulatorConfig c = quietConfig();
  c.odometry.latency = 0.03;
  c.odometry.rate = 50.0;
  ForestSimulator sim(flatWorld(), c);
  sim.setCommand({ 1.0, 0.0 });
  SimulatorOutput out;
  int seen = 0;
  while (sim.time() < 2.0)
  {
    out.clear();
    sim.step(&out);
    for (const auto& o : out.odometry)
    {
      EXPECT_NEAR(sim.time() - o.stamp, 0.03, 1e-9);
      EXPECT_NEAR(o.pose.x, sim.poseAt(o.stamp).x, 1e-9);  // noise-free: odometry equals truth then
      ++seen;
    }
  }
  EXPECT_EQ(seen, 98);  // 50 Hz over 2 s, the last 30 ms not yet delivered
}

TEST(Simulator, SweepPointsAreCastFromThePoseAtTheirOwnInstant)
{
  ForestWorld w = flatWorld();
  for (int i = 0; i < 12; ++i)
  {
    TrunkSpec t;
    t.x = 8.0 * std::cos(i * M_PI / 6);
    t.y = 8.0 * std::sin(i * M_PI / 6);
    t.radius = 0.3;
    w.trunks.push_back(t);
  }
  SimulatorConfig c = quietConfig();
  c.lidar3d.enabled = true;
  c.lidar3d.range_sigma = 0.0;
  c.robot.max_linear_accel = 1e6;
  ForestSimulator sim(w, c);
  sim.setCommand({ 2.0, 0.3 });
  SimulatorOutput out;
  std::vector<LidarSweep> sweeps;
  while (sweeps.size() < 3)
  {
    out.clear();
    sim.step(&out);
    for (auto& s : out.sweeps)
      sweeps.push_back(s);
  }
  const LidarSweep& sweep = sweeps.back();
  ASSERT_GT(sweep.points.size(), 1000u);
  const Eigen::Isometry3d mount = c.lidar3d.mount.transform();
  int on_trunks = 0;
  double worst = 0.0, worst_single_pose = 0.0;
  const Eigen::Isometry3d sensor_at_start = sim.bodyPose(sim.poseAt(sweep.stamp)) * mount;
  for (const LidarPoint& p : sweep.points)
  {
    ASSERT_GE(p.time, 0.0f);
    ASSERT_LT(p.time, 0.1f);
    const Eigen::Vector3d local(p.x, p.y, p.z);
    const Eigen::Vector3d world = sim.bodyPose(sim.poseAt(sweep.stamp + p.time)) * mount * local;
    const Eigen::Vector3d naive = sensor_at_start * local;
    if (world.z() < 0.05)
      continue;  // ground
    double d = 1e9, d_naive = 1e9;
    for (const auto& t : w.trunks)
    {
      d = std::min(d, std::abs(std::hypot(world.x() - t.x, world.y() - t.y) - t.radius));
      d_naive = std::min(d_naive, std::abs(std::hypot(naive.x() - t.x, naive.y() - t.y) - t.radius));
    }
    worst = std::max(worst, d);
    worst_single_pose = std::max(worst_single_pose, d_naive);
    ++on_trunks;
  }
  EXPECT_GT(on_trunks, 500);
  EXPECT_LT(worst, 1e-3);             // float storage of the points
  EXPECT_GT(worst_single_pose, 0.05);  // the motion within a sweep is real and visible
}

TEST(Simulator, RingsHaveTheirElevationsOnFlatGround)
{
  SimulatorConfig c = quietConfig();
  c.lidar3d.enabled = true;
  c.lidar3d.range_sigma = 0.0;
  c.lidar3d.max_range = 110.0;  // the -1 deg ring meets flat ground 103 m away (1.8 m / tan 1 deg)
  ForestWorld world = flatWorld();
  world.ground.margin = 200.0;  // and the ground reaches that far
  ForestSimulator sim(world, c);
  LidarSweep sweep;
  sim.castSweep(0.0, &sweep);
  int counted = 0;
  for (const LidarPoint& p : sweep.points)
  {
    const double expected = c.lidar3d.min_elevation +
                            (c.lidar3d.max_elevation - c.lidar3d.min_elevation) * p.ring / (c.lidar3d.rings - 1);
    ASSERT_NEAR(std::atan2(p.z, std::hypot(p.x, p.y)), expected, 1e-5);
    ASSERT_LT(expected, 0.0);  // only downward rings see a flat ground
    ++counted;
  }
  EXPECT_EQ(counted, 8 * 1800);  // the 8 downward rings, every column
}

TEST(Simulator, TheLidarSeesNoGroundNearerThanItsLowestRingAllows)
{
  // The scenario's lidar (16 rings over +-15 degrees, 1.8 m up): its lowest ring meets level ground
  // 1.8 / tan(15 deg) = 6.72 m away, so no ground return lies nearer. On a 10 % slope the body tilts with the
  // ground, so along the slope the near edge stays at 6.7 m; across it the ground comes no nearer either.
  for (const double slope : { 0.0, 0.10 })
  {
    SimulatorConfig c = quietConfig();
    c.lidar3d.enabled = true;
    c.lidar3d.range_sigma = 0.0;
    ForestWorld world = flatWorld();
    world.ground.slope = Eigen::Vector2d(slope, 0.0);
    ForestSimulator sim(world, c);
    LidarSweep sweep;
    sim.castSweep(0.0, &sweep);
    double nearest = std::numeric_limits<double>::infinity();
    for (const LidarPoint& p : sweep.points)
      nearest = std::min(nearest, std::hypot(static_cast<double>(p.x), static_cast<double>(p.y)));
    ASSERT_FALSE(sweep.points.empty());
    EXPECT_NEAR(nearest, 1.8 / std::tan(15.0 * M_PI / 180.0), 0.05) << "slope " << slope;
  }
}

TEST(Simulator, SameSeedSameRunOtherSeedOtherRun)
{
  ForestWorld w;
  w.ground.amplitude = 0.3;
  TrunkSpec t;
  t.x = 10.0;
  t.y = 15.0;
  w.trunks.push_back(t);
  auto run = [&](std::uint64_t seed) {
    SimulatorConfig c;
    c.seed = seed;
    ForestSimulator sim(w, c);
    sim.setCommand({ 1.0, 0.1 });
    SimulatorOutput out;
    std::vector<double> values;
    while (sim.time() < 0.5)
    {
      out.clear();
      sim.step(&out);
      for (const auto& o : out.odometry)
        values.push_back(o.pose.y);
      for (const auto& s : out.sweeps)
        for (std::size_t i = 0; i < s.points.size(); i += 97)
          values.push_back(s.points[i].x);
    }
    return values;
  };
  const auto a = run(4), b = run(4), c = run(5);
  ASSERT_EQ(a, b);
  EXPECT_NE(a, c);
}

TEST(Simulator, BodyFollowsTheGround)
{
  ForestWorld w;
  w.ground.amplitude = 0.3;
  ForestSimulator sim(w, SimulatorConfig());
  const ForestRayCaster caster(w);
  const Ground& g = caster.ground();
  for (double x = 0.0; x < 30.0; x += 3.7)
  {
    const Eigen::Isometry3d body = sim.bodyPose(Pose2(x, 15.0, 0.4));
    const Eigen::Vector2d grad = g.gradient(x, 15.0);
    const Eigen::Vector3d n = Eigen::Vector3d(-grad.x(), -grad.y(), 1.0).normalized();
    EXPECT_NEAR(body.translation().z(), g.height(x, 15.0), 1e-12);
    EXPECT_NEAR((body.linear().col(2) - n).norm(), 0.0, 1e-12);
    // The heading stays the planar heading.
    EXPECT_NEAR(std::atan2(body.linear()(1, 0), body.linear()(0, 0)), 0.4, 1e-12);
  }
}

TEST(Scenario, StraightDriveFollowsOdometryToItsEnd)
{
  ForestWorld w = flatWorld();
  ScenarioConfig c;
  c.sim.lidar3d.enabled = false;
  c.sim.seed = 2;
  Scenario scenario(w, c);
  SimulatorOutput out;
  Pose2 odom;
  while (true)
  {
    out.clear();
    const bool running = scenario.step(&out);
    for (const auto& o : out.odometry)
      odom = o.pose;
    if (!running)
      break;
  }
  EXPECT_FALSE(scenario.timedOut());
  EXPECT_TRUE(scenario.follower().done());
  // The follower believes it drove 30 m along x: it did, by its own odometry.
  EXPECT_NEAR(odom.x, 30.0, 0.6);
  EXPECT_NEAR(odom.y, 0.0, 0.3);
}

namespace
{
/** Drives @p follower with a perfect unicycle from its start until it is done (or @p max_steps). */
int driveToEnd(rbpf_slam::sim::PathFollower* follower, int max_steps)
{
  rbpf_slam::core::Pose2 pose;
  const double dt = 0.05;
  for (int step = 0; step < max_steps; ++step)
  {
    const rbpf_slam::sim::VelocityCommand cmd = follower->command(pose);
    if (follower->done())
      return step;
    pose.theta = rbpf_slam::core::wrapAngle(pose.theta + cmd.angular * dt);
    pose.x += cmd.linear * dt * std::cos(pose.theta);
    pose.y += cmd.linear * dt * std::sin(pose.theta);
  }
  return max_steps;
}
}  // namespace

TEST(PathFollower, ClosedLoopIsDrivenToItsEndNotStoppedAtItsStart)
{
  using rbpf_slam::sim::PathFollower;
  // A 40 m square that ends where it starts, driven twice.
  const std::vector<Eigen::Vector2d> square{ { 0, 0 }, { 10, 0 }, { 10, 10 }, { 0, 10 }, { 0, 0 },
                                             { 10, 0 }, { 10, 10 }, { 0, 10 }, { 0, 0 } };
  PathFollower follower(square, rbpf_slam::sim::PathFollowerConfig());
  const int steps = driveToEnd(&follower, 100000);
  EXPECT_TRUE(follower.done());
  EXPECT_GT(follower.progress(), 75.0);
  EXPECT_GT(steps * 0.05, 70.0);  // about 80 m at 1 m/s
}

namespace
{
/** Points on the surface of a trunk of radius @p r at @p c, every 2 cm of its circumference. */
std::vector<Eigen::Vector2d> trunkSurface(const Eigen::Vector2d& c, double r)
{
  std::vector<Eigen::Vector2d> points;
  const int n = static_cast<int>(std::ceil(2.0 * M_PI * r / 0.02));
  for (int i = 0; i < n; ++i)
    points.push_back(c + r * Eigen::Vector2d(std::cos(2.0 * M_PI * i / n), std::sin(2.0 * M_PI * i / n)));
  return points;
}

/** What a lidar at @p pose sees of @p world_points: those within @p range, in base_link. */
std::vector<Eigen::Vector2d> seenFrom(const rbpf_slam::core::Pose2& pose, const std::vector<Eigen::Vector2d>& world_points,
                                      double range)
{
  std::vector<Eigen::Vector2d> seen;
  const rbpf_slam::core::Pose2 inv = pose.inverse();
  for (const auto& w : world_points)
  {
    Eigen::Vector2d b;
    inv.transformPoint(w.x(), w.y(), &b.x(), &b.y());
    if (b.norm() <= range)
      seen.push_back(b);
  }
  return seen;
}
}  // namespace

TEST(PathFollower, AvoidsATrunkOnThePathAndStillReachesTheEnd)
{
  using namespace rbpf_slam::core;
  PathFollowerConfig config;
  const Eigen::Vector2d trunk(6.0, 0.0);
  const double trunk_radius = 0.3;
  const std::vector<Eigen::Vector2d> surface = trunkSurface(trunk, trunk_radius);
  for (double offset : { 0.0, 0.1, -0.1 })  // dead on, and just beside the path on either side
  {
    SCOPED_TRACE(offset);
    std::vector<Eigen::Vector2d> world = surface;
    for (auto& p : world)
      p.y() += offset;
    PathFollower follower(straightDrive(12.0), config);
    Pose2 pose;
    const double dt = 0.02;
    double nearest = std::numeric_limits<double>::infinity();
    bool avoided = false;
    int step = 0;
    for (; step < 5000 && !follower.done(); ++step)
    {
      if (step % 5 == 0)  // a 10 Hz lidar
        follower.addObstacles(step * dt, pose, seenFrom(pose, world, 10.0));
      const VelocityCommand cmd = follower.command(pose);
      avoided = avoided || follower.avoiding();
      EXPECT_LE(std::abs(cmd.angular), config.max_angular + 1e-9);
      pose.theta = wrapAngle(pose.theta + cmd.angular * dt);
      pose.x += cmd.linear * dt * std::cos(pose.theta);
      pose.y += cmd.linear * dt * std::sin(pose.theta);
      for (const auto& p : world)
        nearest = std::min(nearest, (p - Eigen::Vector2d(pose.x, pose.y)).norm());
    }
    EXPECT_TRUE(follower.done());
    EXPECT_TRUE(avoided);
    EXPECT_GT(nearest, config.robot_radius);
    EXPECT_GT(nearest, config.robot_radius + 0.5 * config.clearance);
    EXPECT_NEAR(pose.x, 12.0, 0.5);
    EXPECT_NEAR(pose.y, 0.0, 0.5);
    EXPECT_LT(step * dt, 30.0);  // 12 m at 1 m/s and a detour
  }
}

TEST(PathFollower, WithoutObstaclesInReachCommandsPurePursuit)
{
  using namespace rbpf_slam::core;
  PathFollowerConfig plain;
  plain.avoid_obstacles = false;
  PathFollowerConfig avoiding;  // default: avoid_obstacles
  ASSERT_TRUE(avoiding.avoid_obstacles);
  PathFollower a(loopDrive(), plain), b(loopDrive(), avoiding), c(loopDrive(), avoiding);
  // c sees a trunk 4 m beside the loop's start: seen, remembered, never in the way.
  const std::vector<Eigen::Vector2d> far_trunk = trunkSurface(Eigen::Vector2d(2.0, 4.0), 0.3);
  Pose2 pose(0.1, -0.2, 0.05);  // a little off the path
  const double dt = 0.02;
  int steps = 0;
  for (; steps < 20000 && !a.done(); ++steps)
  {
    c.addObstacles(steps * dt, pose, seenFrom(pose, far_trunk, 5.0));
    const VelocityCommand ca = a.command(pose), cb = b.command(pose), cc = c.command(pose);
    ASSERT_EQ(ca.linear, cb.linear) << steps;
    ASSERT_EQ(ca.angular, cb.angular) << steps;
    ASSERT_EQ(ca.linear, cc.linear) << steps;
    ASSERT_EQ(ca.angular, cc.angular) << steps;
    EXPECT_FALSE(c.avoiding());
    pose.theta = wrapAngle(pose.theta + ca.angular * dt);
    pose.x += ca.linear * dt * std::cos(pose.theta);
    pose.y += ca.linear * dt * std::sin(pose.theta);
  }
  EXPECT_TRUE(a.done());
  EXPECT_TRUE(b.done());
  EXPECT_TRUE(c.done());
  EXPECT_GT(steps, 1000);
}

TEST(PathFollower, TurnsInPlaceWhenAWallBlocksEveryArc)
{
  using namespace rbpf_slam::core;
  PathFollowerConfig config;
  PathFollower follower(straightDrive(12.0), config);
  // A wall 1 m ahead, 8 m wide: no arc forward keeps the footprint off it.
  std::vector<Eigen::Vector2d> wall;
  for (double y = -4.0; y <= 4.0; y += 0.05)
    wall.emplace_back(1.0, y);
  follower.addObstacles(0.0, Pose2(), wall);
  const VelocityCommand cmd = follower.command(Pose2());
  EXPECT_TRUE(follower.avoiding());
  EXPECT_EQ(cmd.linear, 0.0);
  EXPECT_NEAR(std::abs(cmd.angular), config.max_angular, 1e-12);
}

namespace
{
/** Drives @p follower (unicycle, 50 Hz, a 10 Hz lidar seeing @p world within 5 m) for at most @p seconds; the
 * nearest any world point came to base_link, the farthest the pose went from the x axis, and the end pose. */
struct Drive
{
  double nearest = std::numeric_limits<double>::infinity();
  double farthest = 0.0;
  rbpf_slam::core::Pose2 pose;
};
Drive drive(PathFollower* follower, const std::vector<Eigen::Vector2d>& world, double seconds,
            rbpf_slam::core::Pose2 pose = rbpf_slam::core::Pose2())
{
  Drive d;
  const double dt = 0.02;
  for (int step = 0; step * dt < seconds && !follower->done(); ++step)
  {
    if (step % 5 == 0)
      follower->addObstacles(step * dt, pose, seenFrom(pose, world, 5.0));
    const VelocityCommand cmd = follower->command(pose);
    pose.theta = rbpf_slam::core::wrapAngle(pose.theta + cmd.angular * dt);
    pose.x += cmd.linear * dt * std::cos(pose.theta);
    pose.y += cmd.linear * dt * std::sin(pose.theta);
    for (const auto& p : world)
      d.nearest = std::min(d.nearest, (p - Eigen::Vector2d(pose.x, pose.y)).norm());
    d.farthest = std::max(d.farthest, std::abs(pose.y));
  }
  d.pose = pose;
  return d;
}
}  // namespace

TEST(PathFollower, KeepsItsMinimumClearanceInAGapNarrowerThanItsClearance)
{
  // Two trunks of radius 0.05 m 0.8 m either side of the path: the gap (1.5 m) is narrower than the footprint with
  // its clearance (2 x 0.9 m) but wider than with its minimum clearance (2 x 0.7 m). The robot creeps through, and
  // never nearer than robot_radius + min_clearance (less 1 cm: what one 20 ms step at a third of the speed takes).
  PathFollowerConfig config;
  std::vector<Eigen::Vector2d> world = trunkSurface(Eigen::Vector2d(5.0, 0.8), 0.05);
  const std::vector<Eigen::Vector2d> other = trunkSurface(Eigen::Vector2d(5.0, -0.8), 0.05);
  world.insert(world.end(), other.begin(), other.end());
  PathFollower follower(straightDrive(10.0), config);
  const Drive d = drive(&follower, world, 120.0);
  EXPECT_TRUE(follower.done());
  EXPECT_GT(d.nearest, config.robot_radius + config.min_clearance - 0.01);
  // A ratchet that lets each command come 2 cm nearer a point already too near would touch: not so.
  EXPECT_GT(d.nearest, config.robot_radius);
}

TEST(PathFollower, ALookAheadPointBehindIsTurnedTowardsNotDrivenAwayFrom)
{
  PathFollowerConfig config;
  config.avoid_obstacles = false;
  PathFollower follower(straightDrive(20.0), config);
  // 6 m beyond the start of the path, heading away from it, the look-ahead point straight behind.
  rbpf_slam::core::Pose2 pose(-6.0, 0.0, M_PI);
  const VelocityCommand cmd = follower.command(pose);
  EXPECT_NEAR(std::abs(cmd.angular), config.max_angular, 1e-12);
  const Drive d = drive(&follower, {}, 60.0, pose);
  EXPECT_TRUE(follower.done());
  EXPECT_NEAR(d.pose.x, 20.0, 0.5);
}

TEST(PathFollower, NoArcTakesItFartherThanMaxDepartureFromThePath)
{
  // A wall of trunks across the path from y = -6 to 6 m, open beyond: the detour round its end would take the robot
  // 6.5 m from the path. With max_departure 3 m it stays within 3 m (and does not get past); without, it goes round.
  std::vector<Eigen::Vector2d> world;
  for (double y = -6.0; y <= 6.0; y += 0.2)
  {
    const auto t = trunkSurface(Eigen::Vector2d(6.0, y), 0.08);
    world.insert(world.end(), t.begin(), t.end());
  }
  PathFollowerConfig bounded;
  PathFollower a(straightDrive(12.0), bounded);
  const Drive da = drive(&a, world, 120.0);
  EXPECT_FALSE(a.done());
  EXPECT_LE(da.farthest, bounded.max_departure + 0.05);
  EXPECT_GT(da.nearest, bounded.robot_radius + bounded.min_clearance - 0.01);
  PathFollowerConfig unbounded;
  unbounded.max_departure = 0.0;
  PathFollower b(straightDrive(12.0), unbounded);
  const Drive db = drive(&b, world, 300.0);
  EXPECT_GT(db.farthest, 6.0);
}

/** A flat empty world and the straight drive from (0, 15) heading +x: what each drive check starts from. */
class DriveCheck : public ::testing::Test
{
protected:
  DriveCheck()
  {
    world.ground.amplitude = 0.0;
    config.sim.start = rbpf_slam::core::Pose2(0.0, 15.0, 0.0);
    config.drive = straightDrive(30.0);
  }
  ForestWorld world;
  ScenarioConfig config;
  std::string error;
};

TEST_F(DriveCheck, RefusesADriveWithNoWayThroughAndSaysWhere)
{
  EXPECT_TRUE(checkDrive(world, config, &error)) << error;
  // One trunk on the drive: the planner goes round it within 3 m.
  TrunkSpec t;
  t.x = 10.0;
  t.y = 15.0;
  t.radius = 0.2;
  world.trunks.push_back(t);
  EXPECT_TRUE(checkDrive(world, config, &error)) << error;
  // A row of trunks across the drive, 1 m apart, from y = 10 to 20 m: no gap for 0.7 m either side within 3 m.
  for (double y = 10.0; y <= 20.0; y += 1.0)
  {
    t.x = 20.0;
    t.y = y;
    world.trunks.push_back(t);
  }
  EXPECT_FALSE(checkDrive(world, config, &error));
  // The first point of the drive with no reachable place within 3 m: just beyond the row.
  EXPECT_NE(error.find("its point (22.20, 15.00) in the world cannot be reached"), std::string::npos) << error;
  EXPECT_NE(error.find("no way there within 3.0 m of the drive"), std::string::npos) << error;
  // Without the planner, the drive itself must keep the footprint off every trunk: the first one is named.
  config.follower.avoid_obstacles = false;
  EXPECT_FALSE(checkDrive(world, config, &error));
  EXPECT_NE(error.find("trunk 0 at (10.00, 15.00)"), std::string::npos) << error;
  // A drive that leaves the ground, and one that does not move.
  config.follower.avoid_obstacles = true;
  world.trunks.clear();
  config.drive = straightDrive(200.0);
  EXPECT_FALSE(checkDrive(world, config, &error));
  EXPECT_NE(error.find("leaves the ground"), std::string::npos) << error;
  config.drive = { Eigen::Vector2d(1.0, 1.0), Eigen::Vector2d(1.0, 1.0) };
  EXPECT_FALSE(checkDrive(world, config, &error));
  EXPECT_NE(error.find("fewer than two distinct waypoints"), std::string::npos) << error;
  // A start beside a trunk, nearer than the robot needs: refused with the start and the distance it needs.
  config.drive = straightDrive(30.0);
  t.x = 0.5;
  t.y = 15.0;
  world.trunks.push_back(t);
  EXPECT_FALSE(checkDrive(world, config, &error));
  EXPECT_NE(error.find("it starts at (0.00, 15.00) in the world, nearer than"), std::string::npos) << error;
  // The ground's extent is named on both axes.
  world.trunks.clear();
  config.drive = straightDrive(200.0);
  EXPECT_FALSE(checkDrive(world, config, &error));
  EXPECT_EQ(error.find("x ..."), std::string::npos) << error;
}

TEST_F(DriveCheck, ClutterThePlannerSteersRoundClosesTheWayAndLowClutterDoesNot)
{
  // A hedge of bushes across the drive at x = 20 m, centres 1.0 m apart from y = 9 to 21 m, 0.8 m up (in the
  // planner's height band): no gap at all.
  for (double y = 9.0; y <= 21.0; y += 1.0)
    world.foliage.push_back(FoliageSpec{ Eigen::Vector3d(20.0, y, 0.8), 0.5, 0.3 });
  EXPECT_FALSE(checkDrive(world, config, &error));
  EXPECT_NE(error.find("bushes, rocks, low branches"), std::string::npos) << error;
  // The same hedge as crowns 5 m up (above the band): the planner does not see them.
  for (FoliageSpec& f : world.foliage)
    f.center.z() = 5.0;
  EXPECT_TRUE(checkDrive(world, config, &error)) << error;
  // Rocks half buried (centre at the ground, 0.5 m radius: 0.8 m wide where the band starts 0.3 m up) 1.4 m apart:
  // 0.6 m gaps, narrower than the 1.4 m the robot needs: closed.
  world.foliage.clear();
  for (double y = 9.0; y <= 21.0; y += 1.4)
    world.rocks.push_back(RockSpec{ Eigen::Vector3d(20.0, y, 0.0), 0.5 });
  EXPECT_FALSE(checkDrive(world, config, &error));
  // Rocks as low as the fallen branches (0.2 m radius, under the band): open.
  for (RockSpec& r : world.rocks)
    r.radius = 0.2;
  EXPECT_TRUE(checkDrive(world, config, &error)) << error;
  // A start beside a bush is not refused (the planner lets the robot leave it; a bush is no collision), as long as
  // the way goes on.
  world.rocks.clear();
  world.foliage.push_back(FoliageSpec{ Eigen::Vector3d(0.0, 15.9, 0.8), 0.5, 0.3 });
  EXPECT_TRUE(checkDrive(world, config, &error)) << error;
  // Seen only by a 2D scanner 0.5 m up (no 3D lidar): the bushes count where they cut its plane.
  config.sim.lidar3d.enabled = false;
  config.sim.lidar2d.enabled = true;
  config.sim.lidar2d.mount.z = 0.5;
  for (double y = 9.0; y <= 21.0; y += 1.0)
    world.foliage.push_back(FoliageSpec{ Eigen::Vector3d(20.0, y, 0.8), 0.5, 0.3 });
  EXPECT_FALSE(checkDrive(world, config, &error));
  config.sim.lidar2d.mount.z = 1.5;  // above the bushes' tops (1.3 m)
  EXPECT_TRUE(checkDrive(world, config, &error)) << error;
}

TEST(GravityLevel, LevelsATiltedBodyAsItsTrueTiltDoesThroughNoiseAndBriefAccelerations)
{
  const double g = 9.80665;
  // base_link rolled 4 degrees and pitched -3 (a 7 % slope, across and up).
  const Eigen::Matrix3d tilt = (Eigen::AngleAxisd(-0.0524, Eigen::Vector3d::UnitY()) *
                                Eigen::AngleAxisd(0.0698, Eigen::Vector3d::UnitX())).toRotationMatrix();
  GravityLevel level(1.0);
  EXPECT_FALSE(level.ready());
  EXPECT_TRUE(level.levelling().isIdentity(1e-12));
  Random random(3);
  double t = 0.0;
  for (int i = 0; i < 500; ++i, t += 0.01)  // 5 s at 100 Hz, 0.1 m/s^2 of noise; 0.2 s of braking at 2 m/s^2 at 2 s
  {
    Eigen::Vector3d f = tilt.transpose() * Eigen::Vector3d(0.0, 0.0, g);
    if (i >= 200 && i < 220)
      f += tilt.transpose() * Eigen::Vector3d(-2.0, 0.0, 0.0);
    for (int k = 0; k < 3; ++k)
      f[k] += random.gaussian(0.1);
    EXPECT_TRUE(level.add(t, f));
  }
  ASSERT_TRUE(level.ready());
  // A trunk's point 1.8 m up and 3 m ahead, seen by the tilted body, levelled: within 2 cm of where it is.
  const Eigen::Vector3d truth(3.0, 0.5, 1.8);
  const Eigen::Vector3d seen = tilt.transpose() * truth;
  EXPECT_GT((seen - truth).head<2>().norm(), 0.1);  // unlevelled: over 0.1 m off
  EXPECT_LT((level.levelling() * seen - truth).norm(), 0.02);
  // Samples that are not gravity are left out, and do not move the level.
  const Eigen::Matrix3d before = level.levelling();
  EXPECT_FALSE(level.add(t, Eigen::Vector3d(0.0, 0.0, 0.0)));
  EXPECT_FALSE(level.add(t, Eigen::Vector3d(std::nan(""), 0.0, g)));
  EXPECT_FALSE(level.add(t, Eigen::Vector3d(0.0, 0.0, 3.0 * g)));
  EXPECT_TRUE(level.levelling().isApprox(before, 1e-12));
}

TEST(PathFollower, ObstaclesFromACloudAreWhatStandsNotTheGround)
{
  using namespace rbpf_slam::core;
  PathFollowerConfig config;
  std::vector<Eigen::Vector3d> cloud;
  // Ground rising 0.5 m over 4 m ahead (in the height band, but flat within each cell) ...
  for (double x = 0.5; x <= 4.0; x += 0.05)
    for (double y = -2.0; y <= 2.0; y += 0.05)
      cloud.emplace_back(x, y, 0.125 * x);
  // ... and a trunk's front 3 m to the left, hit by rings from 0.2 to 2.4 m up.
  for (int i = 2; i <= 24; ++i)
    cloud.emplace_back(0.0, 3.0, 0.1 * i);
  cloud.emplace_back(0.0, 3.0, 5.0);  // a crown above it
  const std::vector<Eigen::Vector2d> obstacles = obstaclesFromCloud(cloud, config);
  ASSERT_FALSE(obstacles.empty());
  for (const auto& p : obstacles)
  {
    EXPECT_NEAR(p.x(), 0.0, 1e-12);
    EXPECT_NEAR(p.y(), 3.0, 1e-12);
  }
  EXPECT_EQ(obstacles.size(), 22u);  // 0.3 to 2.4 m
  // A planar scan: every finite return within range, on base_link.
  const std::vector<float> ranges{ 1.0f, std::numeric_limits<float>::infinity(), 2.0f, 9.0f };
  const std::vector<Eigen::Vector2d> scan =
      obstaclesFromScan(ranges, 0.0, M_PI / 2.0, 0.1, 30.0, Pose2(0.3, 0.0, 0.0), config);
  ASSERT_EQ(scan.size(), 2u);
  EXPECT_NEAR(scan[0].x(), 1.3, 1e-9);
  EXPECT_NEAR(scan[1].x(), -1.7, 1e-9);
}
