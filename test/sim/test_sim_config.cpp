#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "rbpf_slam/sim/sim_config.h"

using namespace rbpf_slam;

namespace
{
std::string writeTemp(const std::string& name, const std::string& text)
{
  const std::string path = std::string(::testing::TempDir()) + name;
  std::ofstream(path) << text;
  return path;
}
}  // namespace

TEST(SimConfig, ShippedConfigMatchesTheBuiltInDefaults)
{
  // config/forest_sim.yaml documents the defaults; reading it must change nothing.
  io::YamlParamSource params(std::string(RBPF_SLAM_SOURCE_DIR) + "/config/forest_sim.yaml");
  sim::ScenarioConfig read, defaults;
  sim::readScenarioConfig(params, &read);
  EXPECT_EQ(read.sim.odometry.left_scale, defaults.sim.odometry.left_scale);
  EXPECT_EQ(read.sim.odometry.right_scale, defaults.sim.odometry.right_scale);
  EXPECT_EQ(read.sim.odometry.wheel_sigma, defaults.sim.odometry.wheel_sigma);
  EXPECT_EQ(read.sim.odometry.latency, defaults.sim.odometry.latency);
  EXPECT_EQ(read.sim.lidar3d.rings, defaults.sim.lidar3d.rings);
  EXPECT_NEAR(read.sim.lidar3d.azimuth_resolution, defaults.sim.lidar3d.azimuth_resolution, 1e-12);
  EXPECT_NEAR(read.sim.lidar3d.min_elevation, defaults.sim.lidar3d.min_elevation, 1e-12);
  EXPECT_EQ(read.sim.lidar3d.mount.z, defaults.sim.lidar3d.mount.z);
  EXPECT_EQ(read.sim.lidar3d.range_sigma, defaults.sim.lidar3d.range_sigma);
  EXPECT_EQ(read.sim.robot.track_width, defaults.sim.robot.track_width);
  EXPECT_EQ(read.sim.start.y, defaults.sim.start.y);
  EXPECT_EQ(read.follower.speed, defaults.follower.speed);
  EXPECT_EQ(read.relay.linear_sigma_abs, defaults.relay.linear_sigma_abs);
  std::string unused;
  for (const auto& k : params.unusedKeys())
    unused += k + " ";
  // Keys the nodelet reads itself (world, mode, frames) are the only ones this reader leaves.
  for (const auto& k : params.unusedKeys())
    EXPECT_TRUE(k == "world" || k == "indoor_map" || k == "real_time_factor" || k == "duration" ||
                k == "lockstep" || k == "lockstep_timeout" || k == "lockstep_topics" || k == "publish_clock" ||
                k == "time_base" || k.rfind("frames/", 0) == 0)
        << "unexpected key " << k;
}

TEST(SimConfig, ValuesAreReadInTheirUnits)
{
  const std::string path = writeTemp("sim_units.yaml", "seed: 7\n"
                                                        "start: {x: 1.0, y: 2.0, yaw_deg: 90}\n"
                                                        "lidar3d: {rings: 32, azimuth_resolution_deg: 0.4,\n"
                                                        "          mount: {z: 2.5, pitch_deg: 10}}\n"
                                                        "odometry: {latency: 0.05}\n");
  io::YamlParamSource params(path);
  sim::SimulatorConfig c;
  sim::readSimulatorConfig(params, &c);
  EXPECT_EQ(c.seed, 7u);
  EXPECT_NEAR(c.start.theta, M_PI / 2, 1e-12);
  EXPECT_EQ(c.lidar3d.rings, 32);
  EXPECT_NEAR(c.lidar3d.azimuth_resolution, 0.4 * M_PI / 180.0, 1e-12);
  EXPECT_EQ(c.lidar3d.mount.z, 2.5);
  EXPECT_NEAR(c.lidar3d.mount.pitch, 10.0 * M_PI / 180.0, 1e-12);
  EXPECT_EQ(c.odometry.latency, 0.05);
  std::remove(path.c_str());
}

TEST(SimConfig, WrongTypeAndInvalidValueNameTheKey)
{
  const std::string typed = writeTemp("sim_typed.yaml", "lidar3d:\n  rings: many\n");
  io::YamlParamSource params(typed);
  sim::SimulatorConfig c;
  try
  {
    sim::readSimulatorConfig(params, &c);
    FAIL() << "no error for a non-integer ring count";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("lidar3d/rings"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(":2:"), std::string::npos) << e.what();
  }
  const std::string invalid = writeTemp("sim_invalid.yaml", "odometry: {rate: -5}\n");
  io::YamlParamSource bad(invalid);
  try
  {
    sim::readSimulatorConfig(bad, &c);
    FAIL() << "no error for a negative rate";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("rate"), std::string::npos) << e.what();
  }
  std::remove(typed.c_str());
  std::remove(invalid.c_str());
}

TEST(SimConfig, UnknownKeysAreReported)
{
  const std::string path = writeTemp("sim_typo.yaml", "odometry: {latncy: 0.05}\n");
  io::YamlParamSource params(path);
  sim::SimulatorConfig c;
  sim::readSimulatorConfig(params, &c);
  ASSERT_EQ(params.unusedKeys().size(), 1u);
  EXPECT_EQ(params.unusedKeys()[0], "odometry/latncy");
  std::remove(path.c_str());
}

TEST(SimConfig, ShippedConfigDocumentsTheCarAndTheFollowerInput)
{
  io::YamlParamSource params(std::string(RBPF_SLAM_SOURCE_DIR) + "/config/forest_sim.yaml");
  sim::ScenarioConfig read, defaults;
  sim::readScenarioConfig(params, &read);
  EXPECT_EQ(read.sim.robot.model, defaults.sim.robot.model);
  EXPECT_EQ(read.sim.robot.footprint_radius, defaults.sim.robot.footprint_radius);
  EXPECT_EQ(read.sim.robot.wheelbase, defaults.sim.robot.wheelbase);
  EXPECT_NEAR(read.sim.robot.max_steer, defaults.sim.robot.max_steer, 1e-12);
  EXPECT_NEAR(read.sim.robot.max_steer_rate, defaults.sim.robot.max_steer_rate, 1e-12);
  EXPECT_EQ(read.sim.robot.length, defaults.sim.robot.length);
  EXPECT_EQ(read.sim.robot.width, defaults.sim.robot.width);
  EXPECT_EQ(read.sim.robot.rear_overhang, defaults.sim.robot.rear_overhang);
  EXPECT_EQ(read.sim.odometry.speed_scale, defaults.sim.odometry.speed_scale);
  EXPECT_EQ(read.sim.odometry.speed_sigma, defaults.sim.odometry.speed_sigma);
  EXPECT_NEAR(read.sim.odometry.steer_bias, defaults.sim.odometry.steer_bias, 1e-12);
  EXPECT_NEAR(read.sim.odometry.steer_sigma, defaults.sim.odometry.steer_sigma, 1e-12);
  EXPECT_EQ(read.sim.odometry.wheelbase, defaults.sim.odometry.wheelbase);
  EXPECT_EQ(read.steer_on, defaults.steer_on);
  EXPECT_EQ(read.sim.robot.max_angular_accel, defaults.sim.robot.max_angular_accel);
  EXPECT_EQ(read.sim.robot.max_linear_accel, defaults.sim.robot.max_linear_accel);
}

TEST(SimConfig, TheCarAndTheFollowerInputAreRead)
{
  const std::string path = writeTemp("sim_car.yaml", "robot: {model: ackermann, wheelbase: 3.0, max_steer_deg: 30}\n"
                                                      "odometry: {speed_scale: 1.05, steer_bias_deg: -1.0}\n"
                                                      "follower: {steer_on: truth}\n");
  io::YamlParamSource params(path);
  sim::ScenarioConfig c;
  sim::readScenarioConfig(params, &c);
  EXPECT_EQ(c.sim.robot.model, sim::RobotModel::kAckermann);
  EXPECT_EQ(c.sim.robot.wheelbase, 3.0);
  EXPECT_NEAR(c.sim.robot.max_steer, 30.0 * M_PI / 180.0, 1e-12);
  EXPECT_EQ(c.sim.odometry.speed_scale, 1.05);
  EXPECT_NEAR(c.sim.odometry.steer_bias, -M_PI / 180.0, 1e-12);
  EXPECT_EQ(c.steer_on, sim::SteerOn::kTruth);
  std::remove(path.c_str());

  for (const char* bad : { "robot: {model: tank}\n", "follower: {steer_on: gps}\n", "robot: {wheelbase: 0}\n",
                           "odometry: {speed_scale: -1}\n" })
  {
    const std::string p = writeTemp("sim_bad_car.yaml", bad);
    io::YamlParamSource ps(p);
    sim::ScenarioConfig s;
    EXPECT_THROW(sim::readScenarioConfig(ps, &s), std::runtime_error) << bad;
    std::remove(p.c_str());
  }
}

TEST(SimConfig, LoadScenarioReadsTheFileTheStartAndTheDrive)
{
  // The file's values over the defaults, its unknown keys named, the start given over the file's, the named drive.
  const std::string path = writeTemp("scenario.yaml", "follower:\n  speed: 0.5\nstart: {x: 1.0, y: 2.0, yaw_deg: 0.0}\n"
                                                      "follwer_speed: 3\n");
  std::vector<std::string> unknown;
  const core::Pose2 start(4.0, 5.0, 0.5);
  const sim::ScenarioConfig c = sim::loadScenario(path, "straight", &start, &unknown);
  EXPECT_DOUBLE_EQ(c.follower.speed, 0.5);
  EXPECT_DOUBLE_EQ(c.sim.start.x, 4.0);
  EXPECT_DOUBLE_EQ(c.sim.start.theta, 0.5);
  ASSERT_EQ(unknown.size(), 1u);
  EXPECT_EQ(unknown[0], "follwer_speed");
  EXPECT_GE(c.drive.size(), 2u);
  // Without a file: the defaults, no unknown keys; a drive that cannot be read throws with its name.
  const sim::ScenarioConfig d = sim::loadScenario("", "loop", nullptr, &unknown);
  EXPECT_TRUE(unknown.empty());
  EXPECT_EQ(d.sim.start.y, sim::ScenarioConfig().sim.start.y);
  try
  {
    sim::loadScenario("", "no_such_drive.txt", nullptr, &unknown);
    FAIL() << "a drive that cannot be read was accepted";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("no_such_drive"), std::string::npos) << e.what();
  }
}
