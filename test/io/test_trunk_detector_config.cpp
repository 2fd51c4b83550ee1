#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "rbpf_slam/io/trunk_detector_config.h"

using namespace rbpf_slam;

namespace
{
std::string writeTemp(const std::string& text)
{
  char name[] = "/tmp/rbpf_trunk_cfg_XXXXXX";
  const int fd = mkstemp(name);
  EXPECT_GE(fd, 0);
  std::ofstream(name) << text;
  return name;
}
}  // namespace

TEST(TrunkDetectorConfigFile, ShippedConfigMatchesTheBuiltInDefaults)
{
  // config/trunk_extraction.yaml documents the defaults; reading it must change nothing.
  io::YamlParamSource params(std::string(RBPF_SLAM_SOURCE_DIR) + "/config/trunk_extraction.yaml");
  core::TrunkDetectorConfig read, defaults;
  io::readTrunkDetectorConfig(params, &read);
  EXPECT_EQ(read.method, defaults.method);
  EXPECT_EQ(read.cluster_tolerance, defaults.cluster_tolerance);
  EXPECT_EQ(read.min_points, defaults.min_points);
  EXPECT_EQ(read.scan_min_beams, defaults.scan_min_beams);
  EXPECT_EQ(read.scan_min_jump, defaults.scan_min_jump);
  EXPECT_EQ(read.min_radius, defaults.min_radius);
  EXPECT_EQ(read.max_radius, defaults.max_radius);
  EXPECT_EQ(read.arc_radius_prior, defaults.arc_radius_prior);
  EXPECT_EQ(read.range_sigma, defaults.range_sigma);
  EXPECT_EQ(read.range_offset, defaults.range_offset);
  EXPECT_EQ(read.column_fit, defaults.column_fit);
  EXPECT_EQ(read.slice_height, defaults.slice_height);
  EXPECT_EQ(read.min_slices, defaults.min_slices);
  EXPECT_EQ(read.max_stem_lean, defaults.max_stem_lean);
  EXPECT_EQ(read.max_interior_share, defaults.max_interior_share);
  EXPECT_EQ(read.min_silhouette_coverage, defaults.min_silhouette_coverage);
  EXPECT_EQ(read.max_see_through, defaults.max_see_through);
  EXPECT_EQ(read.seen_from_all_sides, defaults.seen_from_all_sides);
  EXPECT_EQ(read.max_stems_per_cluster, defaults.max_stems_per_cluster);
  EXPECT_EQ(read.max_range, defaults.max_range);
  EXPECT_EQ(read.seed, defaults.seed);
}

TEST(TrunkDetectorConfigFile, LegoConfigIsValidAndEveryKeyIsUsed)
{
  io::YamlParamSource params(std::string(RBPF_SLAM_SOURCE_DIR) + "/config/lego/trunk_extraction.yaml");
  core::TrunkDetectorConfig c;
  io::readTrunkDetectorConfig(params, &c);
  EXPECT_TRUE(params.unusedKeys().empty());
  EXPECT_DOUBLE_EQ(c.arc_radius_prior, 0.055);
  EXPECT_EQ(c.method, core::TrunkMethod::kCentroid);
  EXPECT_DOUBLE_EQ(c.range_offset, 0.09);  // the data set's 90 mm from the beams' surface to the centre
}

TEST(TrunkDetectorConfigFile, BadValuesNameTheProblem)
{
  const std::string method = writeTemp("method: median\n");
  core::TrunkDetectorConfig c;
  try
  {
    io::readTrunkDetectorConfig(io::YamlParamSource(method), &c);
    FAIL() << "an unknown method was accepted";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("median"), std::string::npos) << e.what();
  }
  const std::string radius = writeTemp("min_radius: 0.5\nmax_radius: 0.1\n");
  EXPECT_THROW(io::readTrunkDetectorConfig(io::YamlParamSource(radius), &c), std::runtime_error);
  const std::string type = writeTemp("min_points: many\n");
  EXPECT_THROW(io::readTrunkDetectorConfig(io::YamlParamSource(type), &c), std::runtime_error);
  std::remove(method.c_str());
  std::remove(radius.c_str());
  std::remove(type.c_str());
}
