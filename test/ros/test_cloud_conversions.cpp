// The one validated PointCloud2 access (readCloud) against every malformed kind of cloud a driver, a bag or a
// bit flip can produce: each is refused with its reason, without reading outside the message.
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/ros/cloud_conversions.h"
#include "rbpf_slam/ros/scan_conversions.h"

using namespace rbpf_slam;

namespace
{
sensor_msgs::PointField field(const std::string& name, std::uint32_t offset, std::uint8_t type)
{
  sensor_msgs::PointField f;
  f.name = name;
  f.offset = offset;
  f.datatype = type;
  f.count = 1;
  return f;
}

/** @brief n points (x = i, y = 2, z = 3, time = i / 1000) in float32 x y z time, 16 bytes a point. */
sensor_msgs::PointCloud2 cloud(std::uint32_t n = 10)
{
  sensor_msgs::PointCloud2 c;
  c.height = 1;
  c.width = n;
  c.point_step = 16;
  c.row_step = 16 * n;
  c.fields = { field("x", 0, sensor_msgs::PointField::FLOAT32), field("y", 4, sensor_msgs::PointField::FLOAT32),
               field("z", 8, sensor_msgs::PointField::FLOAT32), field("time", 12, sensor_msgs::PointField::FLOAT32) };
  c.data.resize(c.row_step);
  for (std::uint32_t i = 0; i < n; ++i)
  {
    const float v[4] = { static_cast<float>(i), 2.0f, 3.0f, 0.001f * static_cast<float>(i) };
    std::memcpy(&c.data[16 * i], v, sizeof(v));
  }
  return c;
}
}  // namespace

TEST(CloudConversions, AWellFormedCloudIsReadWithItsSweepTime)
{
  CloudPoints out;
  ASSERT_EQ(readCloud(cloud(), &out), "");
  ASSERT_EQ(out.points.size(), 10u);
  EXPECT_EQ(out.points[7].x(), 7.0f);
  EXPECT_TRUE(out.has_time);
  EXPECT_NEAR(out.sweep_period, 0.009, 1e-6);
}

TEST(CloudConversions, EveryMalformedKindIsRefusedWithItsReason)
{
  struct Kind
  {
    const char* name;
    std::function<void(sensor_msgs::PointCloud2*)> spoil;
    const char* reason;
  };
  const std::vector<Kind> kinds = {
    { "empty", [](sensor_msgs::PointCloud2* c) { *c = cloud(0); }, "empty cloud" },
    { "data 5 bytes longer", [](sensor_msgs::PointCloud2* c) { c->data.resize(c->data.size() + 5); }, "data holds" },
    { "data short", [](sensor_msgs::PointCloud2* c) { c->data.resize(c->data.size() / 2); }, "data holds" },
    { "no z", [](sensor_msgs::PointCloud2* c) { c->fields.erase(c->fields.begin() + 2); }, "no field z" },
    { "x is int32", [](sensor_msgs::PointCloud2* c) { c->fields[0].datatype = sensor_msgs::PointField::INT32; },
      "field x is not float32" },
    { "y count 0", [](sensor_msgs::PointCloud2* c) { c->fields[1].count = 0; }, "count 0" },
    { "z beyond the point", [](sensor_msgs::PointCloud2* c) { c->fields[2].offset = 14; }, "outside point_step" },
    { "time beyond the point", [](sensor_msgs::PointCloud2* c) { c->fields[3].offset = 1000000; },
      "field time" },
    { "time is uint8", [](sensor_msgs::PointCloud2* c) { c->fields[3].datatype = sensor_msgs::PointField::UINT8; },
      "field time is not float32" },
    { "row_step too small", [](sensor_msgs::PointCloud2* c) { c->row_step = 8; }, "row_step" },
    { "point_step 0", [](sensor_msgs::PointCloud2* c) { c->point_step = 0; }, "outside point_step" },
    { "foreign byte order", [](sensor_msgs::PointCloud2* c) { c->is_bigendian = !c->is_bigendian; }, "byte order" },
    { "height lies", [](sensor_msgs::PointCloud2* c) { c->height = 100000; }, "data holds" },
    { "width * height overflows 32 bits",
      [](sensor_msgs::PointCloud2* c) {
        c->width = 0x10000;
        c->height = 0x10000;
        c->row_step = 0x10000 * 16;
      },
      "data holds" },
    { "all NaN",
      [](sensor_msgs::PointCloud2* c) {
        const float nan = std::numeric_limits<float>::quiet_NaN();
        for (std::size_t i = 0; i < c->data.size(); i += 4)
          std::memcpy(&c->data[i], &nan, 4);
      },
      "no finite point" },
    { "absolute per-point times",
      [](sensor_msgs::PointCloud2* c) {
        const float t = 1.7e9f;
        std::memcpy(&c->data[12], &t, 4);
      },
      "not relative to the stamp" },
  };
  for (const auto& k : kinds)
  {
    sensor_msgs::PointCloud2 c = cloud();
    k.spoil(&c);
    CloudPoints out;
    const std::string why = readCloud(c, &out);
    EXPECT_NE(why.find(k.reason), std::string::npos) << k.name << ": " << why;
    EXPECT_TRUE(out.points.empty()) << k.name;
  }
}

TEST(CloudConversions, Float64PaddedRowsAndNoTimeAreRead)
{
  sensor_msgs::PointCloud2 c;
  c.height = 2;
  c.width = 3;
  c.point_step = 24;
  c.row_step = 3 * 24 + 8;  // 8 bytes of padding per row
  c.fields = { field("x", 0, sensor_msgs::PointField::FLOAT64), field("y", 8, sensor_msgs::PointField::FLOAT64),
               field("z", 16, sensor_msgs::PointField::FLOAT64) };
  c.data.assign(2 * c.row_step, 0);
  for (int row = 0; row < 2; ++row)
    for (int col = 0; col < 3; ++col)
    {
      const double v[3] = { 10.0 * row + col, -1.0, 0.5 };
      std::memcpy(&c.data[row * c.row_step + col * 24], v, sizeof(v));
    }
  CloudPoints out;
  ASSERT_EQ(readCloud(c, &out), "");
  ASSERT_EQ(out.points.size(), 6u);
  EXPECT_EQ(out.points[4].x(), 11.0f);
  EXPECT_FALSE(out.has_time);
  EXPECT_EQ(out.sweep_period, 0.0);
}

TEST(ScanConversions, AScanWithoutAnyMeasurementIsRefusedButOpenSpaceIsNot)
{
  sensor_msgs::LaserScan msg;
  msg.angle_min = -1.0f;
  msg.angle_increment = 0.01f;
  msg.range_min = 0.1f;
  msg.range_max = 30.0f;
  core::PlanarScan scan;
  msg.ranges.assign(200, std::numeric_limits<float>::quiet_NaN());
  EXPECT_NE(toPlanarScan(msg, &scan).find("no beam"), std::string::npos);
  msg.ranges.assign(200, 0.0f);
  EXPECT_NE(toPlanarScan(msg, &scan).find("no beam"), std::string::npos);
  msg.ranges.assign(200, std::numeric_limits<float>::infinity());  // nothing in range: a valid look
  EXPECT_EQ(toPlanarScan(msg, &scan), "");
  msg.ranges.clear();
  EXPECT_NE(toPlanarScan(msg, &scan).find("no ranges"), std::string::npos);
  msg.ranges.assign(5, 1.0f);
  msg.angle_increment = std::numeric_limits<float>::quiet_NaN();
  EXPECT_NE(toPlanarScan(msg, &scan).find("angle"), std::string::npos);
}
