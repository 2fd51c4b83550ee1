#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "rbpf_slam/ros/grid_slam_node.h"
#include "rbpf_slam/ros/scan_conversions.h"

using namespace rbpf_slam;

TEST(GridConversions, LaserScanToScanDataRefusesMalformedScans)
{
  sensor_msgs::LaserScan msg;
  core::ScanData scan;
  EXPECT_NE(toScanData(msg, &scan).find("no ranges"), std::string::npos);
  msg.ranges = { 1.0f, std::numeric_limits<float>::infinity(), std::nanf("") };
  msg.angle_min = -0.5f;
  msg.angle_increment = 0.0f;
  EXPECT_NE(toScanData(msg, &scan).find("angle_increment"), std::string::npos);
  msg.angle_increment = 0.5f;
  msg.range_min = 0.1f;
  msg.range_max = 30.0f;
  ASSERT_EQ(toScanData(msg, &scan), "");
  EXPECT_EQ(scan.ranges.size(), 3u);
  EXPECT_TRUE(std::isinf(scan.ranges[1]));  // REP-117 values pass through: the core interprets them
  EXPECT_DOUBLE_EQ(scan.angle_min, -0.5);
  EXPECT_DOUBLE_EQ(scan.range_max, 30.0);
  msg.range_max = 0.0f;  // unset: no sensor limit
  ASSERT_EQ(toScanData(msg, &scan), "");
  EXPECT_GT(scan.range_max, 1e6);
}

TEST(GridConversions, OccupancyGridMessage)
{
  core::OccupancyGrid grid;
  grid.addLogOdds(3, 2, 0.9f);
  grid.addLogOdds(-2, 1, -0.1f);
  nav_msgs::OccupancyGrid msg;
  toMsg(grid, &msg);
  EXPECT_EQ(msg.info.width, 128u);
  EXPECT_EQ(msg.info.height, 64u);
  EXPECT_NEAR(msg.info.resolution, 0.05, 1e-7);
  EXPECT_DOUBLE_EQ(msg.info.origin.position.x, -3.2);
  EXPECT_DOUBLE_EQ(msg.info.origin.orientation.w, 1.0);
  ASSERT_EQ(msg.data.size(), 128u * 64u);
  EXPECT_EQ(msg.data[2 * 128 + 64 + 3], 71);
  EXPECT_EQ(msg.data[1 * 128 + 62], 48);
  EXPECT_EQ(msg.data[0], -1);
}
