// The park-drive scenario's files (scripts/make_park_drive): the park, the car and the drive as the scenario states.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/sim/forest_world.h"
#include "rbpf_slam/sim/sim_config.h"
#include "rbpf_slam/sim/waypoints_file.h"
#include "rbpf_slam/sim/world_file.h"

using namespace rbpf_slam;

namespace
{
const std::string kSourceDir = RBPF_SLAM_SOURCE_DIR;

double segmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b)
{
  const Eigen::Vector2d ab = b - a;
  const double t = ab.squaredNorm() > 0.0 ? std::max(0.0, std::min(1.0, (p - a).dot(ab) / ab.squaredNorm())) : 0.0;
  return (a + t * ab - p).norm();
}
}  // namespace

TEST(ParkDrive, TheParkHasItsTreesPolesAndCars)
{
  const sim::ForestWorld world = sim::loadForestWorld(kSourceDir + "/config/worlds/park_drive.yaml");
  EXPECT_EQ(world.max_x - world.min_x, 250.0);
  EXPECT_EQ(world.max_y - world.min_y, 250.0);
  EXPECT_EQ(world.ground.amplitude, 0.0);
  ASSERT_EQ(world.trunks.size(), 230u);
  int trees = 0, poles = 0;
  for (const auto& t : world.trunks)
  {
    trees += t.radius >= 0.10 && t.radius <= 0.50;
    poles += t.radius >= 0.04 && t.radius <= 0.08;
  }
  EXPECT_EQ(trees, 200);
  EXPECT_EQ(poles, 30);
  ASSERT_EQ(world.boxes.size(), 10u);
  for (const auto& b : world.boxes)
  {
    EXPECT_EQ(b.length, 4.5);
    EXPECT_EQ(b.width, 1.8);
  }
  EXPECT_GT(world.foliage.size(), world.trunks.size());  // crowns and bushes
}

TEST(ParkDrive, TheCarItsScannerAndTheDriveAreTheScenarios)
{
  io::YamlParamSource params(kSourceDir + "/config/sim/park_drive.yaml");
  sim::ScenarioConfig c;
  sim::readScenarioConfig(params, &c);
  EXPECT_TRUE(params.unusedKeys().empty());
  EXPECT_EQ(c.sim.robot.model, sim::RobotModel::kAckermann);
  EXPECT_EQ(c.sim.robot.wheelbase, 2.8);
  EXPECT_EQ(c.sim.odometry.speed_scale, 1.02);
  EXPECT_NEAR(c.sim.odometry.steer_bias, 0.5 * M_PI / 180.0, 1e-12);
  EXPECT_FALSE(c.sim.lidar3d.enabled);
  ASSERT_TRUE(c.sim.lidar2d.enabled);
  EXPECT_NEAR(c.sim.lidar2d.angle_min, -M_PI / 2, 1e-12);
  EXPECT_NEAR(c.sim.lidar2d.angle_max, M_PI / 2, 1e-12);
  EXPECT_EQ(c.sim.lidar2d.beams, 361);
  EXPECT_EQ(c.sim.lidar2d.rate, 5.0);
  EXPECT_EQ(c.sim.lidar2d.max_range, 80.0);
  EXPECT_EQ(c.sim.lidar2d.range_sigma, 0.02);
  EXPECT_EQ(c.sim.lidar2d.mount.z, 0.5);
  EXPECT_EQ(c.steer_on, sim::SteerOn::kTruth);
  EXPECT_GE(c.follower.speed, 2.0);
  EXPECT_LE(c.follower.speed, 6.0);

  std::string error;
  const std::vector<Eigen::Vector2d> drive = sim::namedDrive(kSourceDir + "/config/sim/park_drive.txt", &error);
  ASSERT_GT(drive.size(), 10u) << error;
  double length = 0.0;
  for (std::size_t i = 1; i < drive.size(); ++i)
    length += (drive[i] - drive[i - 1]).norm();
  EXPECT_GE(length, 4000.0);
  EXPECT_LT(length / c.follower.speed, c.timeout);

  // The road keeps >= 3 m from every trunk's surface and every car (world frame = start pose * start frame).
  const sim::ForestWorld world = sim::loadForestWorld(kSourceDir + "/config/worlds/park_drive.yaml");
  std::vector<Eigen::Vector2d> road;
  for (const auto& p : drive)
  {
    double x = 0.0, y = 0.0;
    c.sim.start.transformPoint(p.x(), p.y(), &x, &y);
    road.emplace_back(x, y);
  }
  double nearest_trunk = 1e9, nearest_box = 1e9;
  for (std::size_t i = 1; i < road.size(); ++i)
  {
    for (const auto& t : world.trunks)
      nearest_trunk = std::min(nearest_trunk, segmentDistance(Eigen::Vector2d(t.x, t.y), road[i - 1], road[i]) - t.radius);
    for (const auto& b : world.boxes)
      nearest_box = std::min(nearest_box, sim::boxSegmentDistance(b, road[i - 1], road[i]));
  }
  EXPECT_GE(nearest_trunk, 3.0);
  EXPECT_GE(nearest_box, 3.0);
}
