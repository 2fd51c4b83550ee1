// The simulator's car (Ackermann steering and its odometry), boxes, collisions, the follower's input and the
// in-process runner on a 2D scanner.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/sim/ackermann.h"
#include "rbpf_slam/sim/forest_simulator.h"
#include "rbpf_slam/eval/forest_slam_runner.h"
#include "rbpf_slam/sim/ray_caster.h"
#include "rbpf_slam/sim/scenario.h"

using namespace rbpf_slam::core;
using namespace rbpf_slam::sim;
using namespace rbpf_slam::eval;

namespace
{
constexpr double kDeg = M_PI / 180.0;

ForestWorld flatWorld()
{
  ForestWorld w;
  w.ground.amplitude = 0.0;
  return w;
}

/** A car without odometry errors or limits that would blur a known answer. */
SimulatorConfig carConfig()
{
  SimulatorConfig c;
  c.start = Pose2(0.0, 0.0, 0.0);
  c.lidar3d.enabled = false;
  c.robot.model = RobotModel::kAckermann;
  c.robot.max_linear_accel = 1e6;
  c.robot.max_steer_rate = 1e6;
  c.odometry.speed_scale = 1.0;
  c.odometry.speed_sigma = 0.0;
  c.odometry.steer_bias = 0.0;
  c.odometry.steer_sigma = 0.0;
  c.odometry.latency = 0.0;
  return c;
}

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

TEST(Ackermann, SteersToTheCommandedYawRateOnTheBicycleModel)
{
  const SimulatorConfig c = carConfig();
  ForestSimulator sim(flatWorld(), c);
  // v = 2 m/s, w = 0.2 rad/s: delta = atan(0.2 * 2.8 / 2) and the car turns at w on a circle of radius v / w = 10 m.
  drive(&sim, { 2.0, 0.2 }, 5.0);
  const auto& car = dynamic_cast<const AckermannRobot&>(sim.robot());
  EXPECT_NEAR(car.steering(), std::atan(0.2 * 2.8 / 2.0), 1e-9);
  EXPECT_NEAR(sim.robot().velocity().angular, 0.2, 1e-9);
  const Pose2& p = sim.robot().pose();
  EXPECT_NEAR(p.theta, 1.0, 1e-6);
  EXPECT_NEAR(p.x, 10.0 * std::sin(1.0), 1e-3);
  EXPECT_NEAR(p.y, 10.0 * (1.0 - std::cos(1.0)), 1e-3);
}

TEST(Ackermann, SteeringIsClampedAndKeptAtStandstill)
{
  SimulatorConfig c = carConfig();
  c.robot.max_steer = 30.0 * kDeg;
  ForestSimulator sim(flatWorld(), c);
  drive(&sim, { 1.0, 5.0 }, 1.0);  // atan(5 * 2.8) is far beyond the limit
  const auto& car = dynamic_cast<const AckermannRobot&>(sim.robot());
  EXPECT_NEAR(car.steering(), 30.0 * kDeg, 1e-12);
  EXPECT_NEAR(sim.robot().velocity().angular, std::tan(30.0 * kDeg) / 2.8, 1e-9);
  // Standing still, a yaw-rate command says nothing about the steering: it stays.
  drive(&sim, { 0.0, -1.0 }, 2.0);
  EXPECT_NEAR(car.steering(), 30.0 * kDeg, 1e-12);
  EXPECT_EQ(sim.robot().velocity().linear, 0.0);
}

TEST(Ackermann, SpeedAndSteeringFollowTheirLimits)
{
  SimulatorConfig c = carConfig();
  c.robot.max_linear_accel = 2.0;
  c.robot.max_steer_rate = 10.0 * kDeg;
  ForestSimulator sim(flatWorld(), c);
  drive(&sim, { 5.0, 5.0 * std::tan(20.0 * kDeg) / 2.8 }, 1.0);
  const auto& car = dynamic_cast<const AckermannRobot&>(sim.robot());
  EXPECT_NEAR(sim.robot().velocity().linear, 2.0, 1e-9);  // 1 s at 2 m/s^2
  EXPECT_NEAR(car.steering(), 10.0 * kDeg, 1e-9);          // 1 s at 10 deg/s
}

TEST(Ackermann, SpeedScaleAndSteeringBiasDriftTheOdometryAsPredicted)
{
  SimulatorConfig c = carConfig();
  c.odometry.speed_scale = 1.02;
  c.odometry.steer_bias = 0.5 * kDeg;
  ForestSimulator sim(flatWorld(), c);
  const OdometrySample odom = drive(&sim, { 5.0, 0.0 }, 20.0);  // 100 m straight ahead
  EXPECT_NEAR(sim.robot().pose().x, 100.0, 1e-6);
  EXPECT_NEAR(sim.robot().pose().y, 0.0, 1e-9);
  // The odometry measures 102 m and turns by tan(0.5 deg) / 2.8 per measured metre.
  const double turn = 102.0 * std::tan(0.5 * kDeg) / 2.8;
  EXPECT_NEAR(odom.pose.theta, turn, 1e-6);
  EXPECT_NEAR(std::hypot(odom.pose.x, odom.pose.y), 102.0 * std::sin(turn / 2) / (turn / 2), 1e-3);
  EXPECT_NEAR(odom.linear, 5.1, 1e-6);
}

TEST(Ackermann, EncoderNoiseIsSeededAndSmall)
{
  SimulatorConfig c = carConfig();
  c.odometry.speed_sigma = 0.01;
  c.odometry.steer_sigma = 0.1 * kDeg;
  c.seed = 4;
  ForestSimulator a(flatWorld(), c), b(flatWorld(), c);
  const OdometrySample oa = drive(&a, { 5.0, 0.0 }, 10.0), ob = drive(&b, { 5.0, 0.0 }, 10.0);
  EXPECT_EQ(oa.pose.x, ob.pose.x);
  EXPECT_EQ(oa.pose.theta, ob.pose.theta);
  EXPECT_NE(oa.pose.x, 50.0);
  EXPECT_NEAR(oa.pose.x, 50.0, 0.5);        // 0.01 sqrt(50) = 7 cm at one sigma
  EXPECT_NEAR(oa.pose.theta, 0.0, 0.01);
}

TEST(Ackermann, ConfigurationIsValidated)
{
  RobotConfig r;
  std::string error;
  EXPECT_TRUE(r.validate(&error)) << error;
  r.wheelbase = 0.0;
  EXPECT_FALSE(r.validate(&error));
  r = RobotConfig();
  r.max_steer = 95.0 * kDeg;
  EXPECT_FALSE(r.validate(&error));
  OdometryConfig o;
  o.speed_scale = 0.0;
  EXPECT_FALSE(o.validate(&error));
  RobotModel m;
  EXPECT_TRUE(parseRobotModel("ackermann", &m));
  EXPECT_EQ(m, RobotModel::kAckermann);
  EXPECT_FALSE(parseRobotModel("tank", &m));
}

TEST(Boxes, GeometryHasItsKnownAnswers)
{
  BoxSpec b;
  b.x = 10.0;
  b.y = 5.0;
  b.yaw = 90.0 * kDeg;  // length along +y
  b.length = 4.0;
  b.width = 2.0;
  EXPECT_NEAR(boxDistance(b, Eigen::Vector2d(10.0, 5.0)), 0.0, 1e-12);
  EXPECT_NEAR(boxDistance(b, Eigen::Vector2d(13.0, 5.0)), 2.0, 1e-9);   // 1 m half width
  EXPECT_NEAR(boxDistance(b, Eigen::Vector2d(10.0, 10.0)), 3.0, 1e-9);  // 2 m half length
  EXPECT_NEAR(boxDistance(b, Eigen::Vector2d(14.0, 10.0)), 3.0 * std::sqrt(2.0), 1e-9);  // corner (11, 7)
  EXPECT_NEAR(boxSegmentDistance(b, Eigen::Vector2d(0.0, 5.0), Eigen::Vector2d(20.0, 5.0)), 0.0, 1e-12);
  EXPECT_NEAR(boxSegmentDistance(b, Eigen::Vector2d(0.0, 8.0), Eigen::Vector2d(20.0, 8.0)), 1.0, 1e-9);
  BoxSpec o = b;
  o.x = 12.1;  // 0.1 m apart across the width
  EXPECT_FALSE(boxesOverlap(b, o));
  o.x = 11.9;
  EXPECT_TRUE(boxesOverlap(b, o));
  o.x = 13.0;
  o.yaw = 45.0 * kDeg;  // a diamond whose corner reaches 13 - sqrt(2^2 + 1^2) * cos(...) -- overlaps
  o.length = 4.0;
  o.width = 2.0;
  EXPECT_TRUE(boxesOverlap(b, o));
}

TEST(Boxes, RaysHitThemAtTheirSurface)
{
  ForestWorld w = flatWorld();
  BoxSpec b;
  b.x = 20.0;
  b.y = 0.0;
  b.yaw = 0.0;
  b.length = 4.0;
  b.width = 2.0;
  b.height = 1.5;
  w.boxes.push_back(b);
  w.min_x = -10.0;
  w.max_x = 40.0;
  w.min_y = -10.0;
  w.max_y = 10.0;
  ForestRayCaster caster(w);
  Random random(1);
  const RayHit hit = caster.cast(Eigen::Vector3d(0.0, 0.0, 0.5), Eigen::Vector3d(1.0, 0.0, 0.0), 80.0, random);
  EXPECT_EQ(hit.kind, HitKind::kBox);
  EXPECT_EQ(hit.index, 0);
  EXPECT_NEAR(hit.range, 18.0, 1e-9);
  // Above the box the ray passes (and leaves the world: no return).
  const RayHit over = caster.cast(Eigen::Vector3d(0.0, 0.0, 2.0), Eigen::Vector3d(1.0, 0.0, 0.0), 80.0, random);
  EXPECT_EQ(over.kind, HitKind::kNone);
  // Diagonal through a corner region: the side y = -1 at x = 19.
  const Eigen::Vector3d d = Eigen::Vector3d(1.0, 0.05, 0.0).normalized();
  const RayHit side = caster.cast(Eigen::Vector3d(0.0, -2.0, 0.5), d, 80.0, random);
  EXPECT_EQ(side.kind, HitKind::kBox);
  EXPECT_NEAR(side.range, 20.0 / d.x(), 1e-9);  // enters at y = -1 when x = 20 (inside 18..22)

  // The 2D scanner sees it too.
  SimulatorConfig c;
  c.start = Pose2(0.0, 0.0, 0.0);
  c.lidar3d.enabled = false;
  c.lidar2d.enabled = true;
  c.lidar2d.range_sigma = 0.0;
  c.lidar2d.mount = Mount{ 0.0, 0.0, 0.5, 0.0, 0.0, 0.0 };
  c.lidar2d.angle_min = -10.0 * kDeg;
  c.lidar2d.angle_max = 10.0 * kDeg;
  c.lidar2d.beams = 21;
  ForestSimulator sim(w, c);
  LaserScan2D scan;
  sim.castScan(0.0, &scan);
  EXPECT_NEAR(scan.ranges[10], 18.0, 1e-5);
}

TEST(Boxes, ClutterKeepsClearOfThem)
{
  ForestWorld w = flatWorld();
  w.min_x = w.min_y = 0.0;
  w.max_x = w.max_y = 20.0;
  BoxSpec b;
  b.x = b.y = 10.0;
  b.length = 10.0;
  b.width = 10.0;
  w.boxes.push_back(b);
  ClutterSpec spec;
  spec.bushes = 200;
  spec.rocks = 200;
  spec.branches = 50;
  spec.crowns = false;
  spec.clearance = 0.5;
  addClutter(spec, &w);
  ASSERT_GT(w.rocks.size(), 10u);
  for (const auto& r : w.rocks)
    EXPECT_GE(boxDistance(b, r.center.head<2>()) - r.radius, 0.5 - 1e-9);
  for (const auto& f : w.foliage)
    EXPECT_GE(boxDistance(b, f.center.head<2>()) - f.radius, 0.5 - 1e-9);
  for (const auto& br : w.branches)
    EXPECT_GE(boxSegmentDistance(b, br.a, br.b) - br.radius, 0.5 - 1e-9);
}

TEST(Collisions, TheDiffDriveStopsWhereItsCircleTouchesATrunk)
{
  ForestWorld w = flatWorld();
  TrunkSpec t;
  t.x = 10.0;
  t.y = 0.2;
  t.radius = 0.3;
  w.trunks.push_back(t);
  SimulatorConfig c;
  c.start = Pose2(0.0, 0.0, 0.0);
  c.lidar3d.enabled = false;
  c.robot.footprint_radius = 0.6;
  ForestSimulator sim(w, c);
  drive(&sim, { 1.0, 0.0 }, 20.0);
  const Collision* hit = sim.collision();
  ASSERT_NE(hit, nullptr);
  EXPECT_EQ(hit->kind, HitKind::kTrunk);
  EXPECT_EQ(hit->index, 0);
  // Touch where the centres are 0.9 m apart: x = 10 - sqrt(0.9^2 - 0.2^2), within one tick's travel.
  const double touch = 10.0 - std::sqrt(0.81 - 0.04);
  EXPECT_NEAR(hit->pose.x, touch, 0.01);
  EXPECT_NEAR(sim.robot().pose().x, hit->pose.x, 1e-12);  // it stays there
  EXPECT_EQ(sim.robot().velocity().linear, 0.0);
  EXPECT_GT(hit->stamp, 0.0);
  EXPECT_EQ(hit->what(w).rfind("trunk 0", 0), 0u);
}

TEST(Collisions, TheCarStopsWhereItsBodyTouchesABox)
{
  ForestWorld w = flatWorld();
  BoxSpec b;
  b.x = 30.0;
  b.y = 1.0;
  b.yaw = 0.0;
  w.boxes.push_back(b);
  SimulatorConfig c = carConfig();
  ForestSimulator sim(w, c);
  drive(&sim, { 2.0, 0.0 }, 30.0);
  const Collision* hit = sim.collision();
  ASSERT_NE(hit, nullptr);
  EXPECT_EQ(hit->kind, HitKind::kBox);
  // The body's front (4.5 - 0.85 m ahead of the rear axle) reaches the box's rear at x = 30 - 2.25.
  EXPECT_NEAR(hit->pose.x, 30.0 - 2.25 - (4.5 - 0.85), 0.011);
  // Passing beside it (1.8 m wide bodies, 0.3 m apart) is no collision.
  w.boxes[0].y = 2.1;
  ForestSimulator beside(w, c);
  drive(&beside, { 2.0, 0.0 }, 30.0);
  EXPECT_EQ(beside.collision(), nullptr);
}

TEST(Collisions, AScenarioEndsAtItsCollision)
{
  ForestWorld w = flatWorld();
  TrunkSpec t;
  t.x = 15.0;
  t.y = 15.0;
  t.radius = 0.3;
  w.trunks.push_back(t);
  ScenarioConfig sc;  // straight 30 m from (0, 15): through the trunk
  sc.sim.lidar3d.enabled = false;
  Scenario scenario(w, sc);
  SimulatorOutput out;
  int steps = 0;
  while (scenario.step(&out))
  {
    out.clear();
    ++steps;
  }
  ASSERT_NE(scenario.simulator().collision(), nullptr);
  EXPECT_LT(scenario.simulator().time(), 30.0);
  // It stopped where its 0.6 m circle touched the 0.3 m trunk (within one tick's travel, 5 mm).
  const Pose2& p = scenario.simulator().robot().pose();
  EXPECT_LE(std::hypot(p.x - 15.0, p.y - 15.0), 0.9);
  EXPECT_GT(std::hypot(p.x - 15.0, p.y - 15.0), 0.89);
}

TEST(Follower, SteeringOnTheTruthKeepsTheCarOnTheRoadDespiteOdometryDrift)
{
  ScenarioConfig sc;
  sc.sim = carConfig();
  sc.sim.odometry.steer_bias = 2.0 * kDeg;  // dead reckoning turns by 0.0125 rad per metre
  sc.sim.seed = 1;
  sc.follower.speed = 5.0;
  sc.follower.lookahead = 8.0;
  sc.follower.max_angular = 1.0;
  sc.relay.linear_sigma_abs = sc.relay.linear_sigma_rel = 0.0;
  sc.relay.angular_sigma_abs = sc.relay.angular_sigma_rel = 0.0;
  sc.drive = straightDrive(100.0);
  auto endOf = [&](SteerOn steer_on) {
    ScenarioConfig c = sc;
    c.steer_on = steer_on;
    Scenario scenario(flatWorld(), c);
    SimulatorOutput out;
    while (scenario.step(&out))
      out.clear();
    return scenario.simulator().robot().pose();
  };
  const Pose2 truth = endOf(SteerOn::kTruth), odometry = endOf(SteerOn::kOdometry);
  EXPECT_NEAR(truth.x, 100.0, 1.0);
  EXPECT_NEAR(truth.y, 0.0, 0.3);
  // On odometry the car follows the drifting odometry: the true path bends away (about 100^2 / 2 * 0.0125 m).
  EXPECT_LT(odometry.y, -20.0);
  SteerOn s;
  EXPECT_TRUE(parseSteerOn("truth", &s));
  EXPECT_EQ(s, SteerOn::kTruth);
  EXPECT_FALSE(parseSteerOn("gps", &s));
}

TEST(ForestSlamRunner, A2DScannerFeedsThePipelineAndSeesOnlyItsFieldOfView)
{
  ForestWorld w = flatWorld();
  // Trees beside a 40 m straight road (y = 0 in the start frame; world = start frame here), and two behind the
  // start that a front scanner never sees.
  for (int i = 0; i < 8; ++i)
  {
    TrunkSpec t;
    t.x = 5.0 + 5.0 * i;
    t.y = (i % 2 ? 4.0 : -4.0);
    t.radius = 0.25;
    w.trunks.push_back(t);
  }
  for (double y : { -3.0, 3.0 })
  {
    TrunkSpec t;
    t.x = -5.0;
    t.y = y;
    t.radius = 0.25;
    w.trunks.push_back(t);
  }
  w.min_x = -20.0;
  w.max_x = 60.0;
  w.min_y = -20.0;
  w.max_y = 20.0;
  ScenarioConfig sc;
  sc.sim.start = Pose2(0.0, 0.0, 0.0);
  sc.sim.seed = 2;
  sc.sim.lidar3d.enabled = false;
  sc.sim.lidar2d.enabled = true;
  sc.sim.lidar2d.angle_min = -90.0 * kDeg;
  sc.sim.lidar2d.angle_max = 90.0 * kDeg;
  sc.sim.lidar2d.beams = 361;
  sc.sim.lidar2d.rate = 5.0;
  sc.sim.lidar2d.max_range = 80.0;
  sc.sim.lidar2d.range_sigma = 0.02;
  sc.drive = straightDrive(40.0);
  sc.steer_on = SteerOn::kTruth;  // on the road between the trees, whatever the odometry says
  ForestSlamVariant v;
  v.filter.particles = 20;
  v.detector.range_sigma = 0.02;
  v.detector.max_range = 80.0;
  const ForestSlamRunResult r = runForestSlamVariants(w, sc, { v }, 1.0).front();
  EXPECT_FALSE(r.collided) << r.collision_what << " at " << r.collision.pose.x << ", " << r.collision.pose.y;
  EXPECT_GT(r.sweeps, 100);  // 40 s at 5 Hz
  EXPECT_EQ(r.sweeps, static_cast<int>(r.estimate.size()));
  EXPECT_NEAR(r.distance, 40.0, 1.0);
  ASSERT_EQ(r.tree_seen.size(), 10u);
  for (int i = 0; i < 8; ++i)
    EXPECT_TRUE(r.tree_seen[i]) << i;
  EXPECT_FALSE(r.tree_seen[8]);
  EXPECT_FALSE(r.tree_seen[9]);
  EXPECT_GE(r.map.recall, 0.75);
  EXPECT_LT(r.ate, 0.5);
}

TEST(ForestSlamRunner, ACollisionEndsTheRunAndIsReported)
{
  ForestWorld w = flatWorld();
  TrunkSpec t;
  t.x = 15.0;
  t.y = 15.0;
  t.radius = 0.3;
  w.trunks.push_back(t);
  ScenarioConfig sc;
  sc.sim.lidar3d.enabled = false;
  sc.sim.lidar2d.enabled = true;
  sc.sim.lidar2d.rate = 5.0;
  sc.follower.avoid_obstacles = false;  // driven straight into the trunk
  ForestSlamVariant v;
  v.filter.particles = 5;
  const ForestSlamRunResult r = runForestSlamVariants(w, sc, { v }).front();
  ASSERT_TRUE(r.collided);
  EXPECT_EQ(r.collision.kind, HitKind::kTrunk);
  EXPECT_LE(std::hypot(r.collision.pose.x - 15.0, r.collision.pose.y - 15.0), 0.9);
  EXPECT_GT(std::hypot(r.collision.pose.x - 15.0, r.collision.pose.y - 15.0), 0.89);
  EXPECT_LT(r.simulated_seconds, 30.0);
  EXPECT_EQ(r.collision_what.rfind("trunk 0", 0), 0u);
}

TEST(ForestSlamRunner, ASimulatedScanConvertsAsItIs)
{
  LaserScan2D s;
  s.angle_min = -1.0;
  s.angle_increment = 0.01;
  s.range_min = 0.1;
  s.range_max = 30.0;
  s.time_increment = 0.001;
  s.ranges = { 1.0f, std::numeric_limits<float>::infinity(), 2.0f };
  const PlanarScan p = toPlanarScan(s);
  EXPECT_EQ(p.ranges, s.ranges);
  EXPECT_EQ(p.angle_min, -1.0);
  EXPECT_EQ(p.angle_increment, 0.01);
  EXPECT_EQ(p.range_max, 30.0);
  EXPECT_NEAR(scanPeriod(s.time_increment, s.ranges.size()), 0.002, 1e-15);
  EXPECT_EQ(scanPeriod(0.0, 3), 0.0);
  EXPECT_EQ(scanPeriod(0.001, 1), 0.0);
}
