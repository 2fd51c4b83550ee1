// The tree map file: written and read back exactly, an anchor on the earth, columns by name, and malformed files
// refused with the file and line.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <stdexcept>
#include <string>

#include "rbpf_slam/io/forest_map_file.h"
#include "io/temp_files.h"

namespace io = rbpf_slam::io;
using rbpf_slam::core::Landmark;
using rbpf_slam::core::Pose2;
using rbpf_slam::core::VisibilityScope;

namespace
{
Landmark tree(int id, double x, double y, double r)
{
  Landmark l;
  l.id = id;
  l.mean = Eigen::Vector2d(x, y);
  l.covariance << 0.0004, 0.0001, 0.0001, 0.0009;
  l.radius = r;
  l.radius_variance = 0.0001;
  l.observations = 12;
  l.provisional = false;
  l.first_seen = 1700000000.25;
  l.last_seen = 1700000100.5;
  return l;
}

std::string errorOf(const std::string& text)
{
  try
  {
    io::parseForestMap(text, "m.csv");
  }
  catch (const std::runtime_error& e)
  {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(ForestMapFile, WrittenMapReadsBackWithAnchorCovarianceAndTimes)
{
  io::ForestMap m;
  m.anchor.valid = true;
  m.anchor.latitude = 61.8441234;
  m.anchor.longitude = 24.2899876;
  m.anchor.altitude = 112.5;
  m.anchor.yaw = 0.35;
  m.anchor.sigma = 0.8;
  m.trees = { tree(3, 1.5, -2.25, 0.15), tree(9, -40.125, 12.0, 0.31) };
  m.trees[1].provisional = true;
  m.trees[1].first_seen = m.trees[1].last_seen = NAN;

  const std::string dir = temp_files::makeDir("rbpf_forest_map");
  const std::string path = dir + "/forest_map.csv";
  io::writeForestMap(path, m);
  const io::ForestMap back = io::readForestMap(path);
  ASSERT_TRUE(back.anchor.valid);
  EXPECT_NEAR(back.anchor.latitude, 61.8441234, 1e-9);
  EXPECT_NEAR(back.anchor.longitude, 24.2899876, 1e-9);
  EXPECT_NEAR(back.anchor.altitude, 112.5, 1e-3);
  EXPECT_NEAR(back.anchor.yaw, 0.35, 1e-6);
  EXPECT_NEAR(back.anchor.sigma, 0.8, 1e-3);
  ASSERT_EQ(back.trees.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i)
  {
    const Landmark& a = m.trees[i];
    const Landmark& b = back.trees[i];
    EXPECT_EQ(b.id, a.id);
    EXPECT_NEAR(b.mean.x(), a.mean.x(), 1e-6);
    EXPECT_NEAR(b.mean.y(), a.mean.y(), 1e-6);
    EXPECT_NEAR(b.radius, a.radius, 1e-6);
    EXPECT_NEAR(b.radius_variance, a.radius_variance, 1e-9);
    EXPECT_TRUE(b.covariance.isApprox(a.covariance, 1e-6)) << b.covariance;
    EXPECT_EQ(b.observations, a.observations);
    EXPECT_EQ(b.provisional, a.provisional);
  }
  EXPECT_NEAR(back.trees[0].first_seen, 1700000000.25, 1e-6);
  EXPECT_NEAR(back.trees[0].last_seen, 1700000100.5, 1e-6);
  EXPECT_TRUE(std::isnan(back.trees[1].first_seen)) << "not known stays not known";
  // The viewpoints come back: a 360-degree lidar's and a front scanner's (its half turn kept).
  m.viewpoints.resize(2);
  m.viewpoints[0].sensor = Pose2(1.25, -2.5, 0.5);
  m.viewpoints[1].sensor = Pose2(-3.0, 4.0, -1.25);
  m.viewpoints[1].scope = VisibilityScope(0.5, 30.0, M_PI);
  io::writeForestMap(path, m);
  const io::ForestMap seen = io::readForestMap(path);
  ASSERT_EQ(seen.viewpoints.size(), 2u);
  EXPECT_NEAR(seen.viewpoints[0].sensor.x, 1.25, 0.005);
  EXPECT_NEAR(seen.viewpoints[1].sensor.theta, -1.25, 1e-3);
  EXPECT_TRUE(seen.viewpoints[0].scope.fullTurn()) << "a full turn stays one after rounding";
  EXPECT_DOUBLE_EQ(seen.viewpoints[0].scope.max_range, 12.0);
  EXPECT_FALSE(seen.viewpoints[1].scope.fullTurn());
  EXPECT_NEAR(seen.viewpoints[1].scope.fov_max, 0.5 * M_PI, 1e-4);
  EXPECT_DOUBLE_EQ(seen.viewpoints[1].scope.max_range, 30.0);
  ASSERT_EQ(seen.trees.size(), 2u);
  m.viewpoints.clear();
  // The file is the package's landmark CSV: no anchor, no comment line.
  m.anchor.valid = false;
  EXPECT_EQ(io::forestMapCsv(m).compare(0, 3, "id,"), 0);
}

TEST(ForestMapFile, ColumnsAreFoundByNameAndTheOthersDefault)
{
  const io::ForestMap m = io::parseForestMap("# trees of a survey\nx,y,id,dbh\n1,2,5,0.4\n-3,4.5,6,0.2\n", "s.csv");
  EXPECT_FALSE(m.anchor.valid);
  ASSERT_EQ(m.trees.size(), 2u);
  EXPECT_EQ(m.trees[0].id, 5);
  EXPECT_DOUBLE_EQ(m.trees[0].mean.x(), 1.0);
  EXPECT_DOUBLE_EQ(m.trees[0].mean.y(), 2.0);
  EXPECT_DOUBLE_EQ(m.trees[0].radius, 0.2);
  EXPECT_NEAR(m.trees[0].covariance(0, 0), 0.01, 1e-12) << "sigma 0.1 m when the file does not say";
  EXPECT_FALSE(m.trees[0].provisional);
  EXPECT_TRUE(std::isnan(m.trees[1].last_seen));
}

TEST(ForestMapFile, MalformedFilesAreRefusedWithFileAndLine)
{
  EXPECT_NE(errorOf("").find("m.csv:1: expected the header"), std::string::npos) << errorOf("");
  EXPECT_NE(errorOf("a,b,c\n1,2,3\n").find("m.csv:1: expected a header with the columns id,x,y,dbh"),
            std::string::npos);
  EXPECT_NE(errorOf("id,x,y,dbh\n1,2,3\n").find("m.csv:2: expected 4 fields, got 3"), std::string::npos);
  EXPECT_NE(errorOf("id,x,y,dbh\n1,2,nan,0.3\n").find("m.csv:2: expected a finite number for y"), std::string::npos);
  EXPECT_NE(errorOf("id,x,y,dbh\n1,2,3,0.3\n1,4,5,0.3\n").find("m.csv:3: expected a unique id"), std::string::npos);
  EXPECT_NE(errorOf("id,x,y,dbh\n1,2,3,-0.3\n").find("m.csv:2: expected dbh and sigmas >= 0"), std::string::npos);
  EXPECT_NE(errorOf("id,x,y,dbh\n1.5,2,3,0.3\n").find("m.csv:2: expected a whole id"), std::string::npos);
  EXPECT_NE(errorOf("id,x,y,dbh,sigma_x,sigma_y,cov_xy\n1,2,3,0.3,0.1,0.1,0.5\n").find("|cov_xy|"), std::string::npos);
  EXPECT_NE(errorOf("# anchor: latitude=95 longitude=10\nid,x,y,dbh\n").find("m.csv:1: expected latitude in"),
            std::string::npos);
  EXPECT_NE(errorOf("# anchor: latitude=60\nid,x,y,dbh\n").find("m.csv:1: expected the anchor's latitude and"),
            std::string::npos);
  EXPECT_NE(errorOf("# viewpoint: x=1 y=2 yaw=0 min_range=1 max_range=12 fov_min=-3\nid,x,y,dbh\n")
                .find("m.csv:1: expected the viewpoint's fov_max"),
            std::string::npos);
  EXPECT_NE(errorOf("id,x,y,dbh\n# viewpoint: x=1 y=2 yaw=0 min_range=5 max_range=2 fov_min=-3 fov_max=3\n")
                .find("m.csv:2: expected 0 <= min_range < max_range"),
            std::string::npos);
  EXPECT_NE(errorOf("# viewpoint: x=1 y=2 z=0\nid,x,y,dbh\n").find("expected x, y, yaw"), std::string::npos);
  EXPECT_THROW(io::readForestMap("/nonexistent/forest_map.csv"), std::runtime_error);
}

TEST(ForestMapFile, Wgs84OfTheAnchorAndOfPointsAMetreAway)
{
  io::MapAnchor a;
  a.valid = true;
  a.latitude = 61.5;
  a.longitude = 24.25;
  double lat = 0.0, lon = 0.0;
  io::toWgs84(a, 0.0, 0.0, &lat, &lon);
  EXPECT_DOUBLE_EQ(lat, 61.5);
  EXPECT_DOUBLE_EQ(lon, 24.25);
  // 1000 m north and east at 61.5 deg: about 0.00897 deg of latitude, 0.01886 deg of longitude (WGS84).
  io::toWgs84(a, 1000.0, 1000.0, &lat, &lon);
  EXPECT_NEAR(lat - 61.5, 1000.0 / 111440.0 * 1.0, 2e-5);
  EXPECT_NEAR(lon - 24.25, 1000.0 / (111440.0 * std::cos(61.5 * M_PI / 180.0)) * 1.0, 1e-4);
  // The map's x axis turned 90 deg from east: x is north.
  a.yaw = M_PI / 2.0;
  double lat2 = 0.0, lon2 = 0.0;
  io::toWgs84(a, 1000.0, 0.0, &lat2, &lon2);
  EXPECT_NEAR(lat2, lat, 1e-9);
  EXPECT_NEAR(lon2, 24.25, 1e-9);
}

TEST(ForestMapFile, ChangeReportAndGeoJsonNeedAnAnchor)
{
  rbpf_slam::core::TreeChange felled;
  felled.kind = rbpf_slam::core::ChangeKind::kFelled;
  felled.id = 4;
  felled.center = Eigen::Vector2d(3.0, -1.0);
  felled.covariance = 0.0004 * Eigen::Matrix2d::Identity();
  felled.dbh_before = 0.3;
  felled.sigma_dbh_before = 0.01;
  felled.evidence = "not seen \"at all\"";
  const std::string csv = io::changesCsv({ felled });
  EXPECT_EQ(csv.substr(0, csv.find('\n')), io::kChangesHeader);
  EXPECT_NE(csv.find("\nfelled,4,3.000000,-1.000000,0.020000,0.020000,0.300000,0.010000,,,0,,,\"not seen 'at all'\"\n"),
            std::string::npos)
      << csv;
  io::MapAnchor none;
  EXPECT_THROW(io::changesGeoJson(none, { felled }), std::invalid_argument);
  io::MapAnchor a;
  a.valid = true;
  a.latitude = 61.5;
  a.longitude = 24.25;
  const std::string json = io::changesGeoJson(a, { felled });
  EXPECT_EQ(json.rfind("{\"type\": \"FeatureCollection\", \"features\": [\n", 0), 0u) << json;
  EXPECT_NE(json.find("\"kind\": \"felled\""), std::string::npos);
  EXPECT_NE(json.find("\"dbh_after_m\": null"), std::string::npos) << "NaN is null in JSON";
  EXPECT_NE(json.find("\"evidence\": \"not seen \\\"at all\\\"\""), std::string::npos) << json;
  io::ForestMap m;
  m.trees = { tree(1, 0.0, 0.0, 0.1) };
  EXPECT_THROW(io::treesGeoJson(m), std::invalid_argument);
  m.anchor = a;
  EXPECT_NE(io::treesGeoJson(m).find("\"coordinates\": [24.250000000, 61.500000000]"), std::string::npos);
}

TEST(ForestMapFile, ValuesOutsideTheirPhysicalRangeAreRefusedWithTheLine)
{
  const std::string header = "id,x,y,dbh,sigma_x,sigma_y\n";
  EXPECT_NE(errorOf(header + "1,1.0,2.0,0.3,0.1,0.1\n2,1e308,2.0,0.3,0.1,0.1\n").find("m.csv:3: expected |x|, |y| <= 100000 m"),
            std::string::npos);
  EXPECT_NE(errorOf(header + "1,1.0,-2e5,0.3,0.1,0.1\n").find("m.csv:2: expected |x|, |y|"), std::string::npos);
  EXPECT_NE(errorOf(header + "1,1.0,2.0,40,0.1,0.1\n").find("m.csv:2: expected dbh"), std::string::npos);
  EXPECT_NE(errorOf(header + "1,1.0,2.0,0.3,1e9,0.1\n").find("m.csv:2: expected dbh"), std::string::npos);
  EXPECT_NE(errorOf("# anchor: latitude=61 longitude=24 altitude=1e308 yaw=0 sigma=1\n" + header)
                .find("m.csv:1: expected altitude"),
            std::string::npos);
  EXPECT_NE(errorOf("# viewpoint: x=1e300 y=0 yaw=0 min_range=1 max_range=12 fov_min=-3 fov_max=3\n" + header)
                .find("m.csv:1: expected |x|, |y|"),
            std::string::npos);
  EXPECT_EQ(errorOf(header + "1,99999.0,-99999.0,11.5,999,0.1\n"), "") << "values inside the ranges";
}

TEST(ForestMapFile, AHugeFileStopsAtTheBoundAndReadingCanBeInterrupted)
{
  // 200000 trees with a bound of 1000: refused at the first tree too many, having parsed no more.
  std::string text = "id,x,y,dbh\n";
  for (int i = 0; i < 200000; ++i)
    text += std::to_string(i) + "," + std::to_string(i % 1000) + "," + std::to_string(i / 1000) + ",0.3\n";
  io::ForestMapReadOptions bounded;
  bounded.max_trees = 1000;
  try
  {
    io::parseForestMap(text, "big.csv", bounded);
    ADD_FAILURE() << "a map beyond the bound was read";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("big.csv:1002: more than 1000 trees"), std::string::npos) << e.what();
  }
  // Without a bound it is read whole; a cancelled read stops with "interrupted" at the next check.
  EXPECT_EQ(io::parseForestMap(text, "big.csv").trees.size(), 200000u);
  io::ForestMapReadOptions cancel;
  int asked = 0;
  cancel.cancelled = [&asked] { return ++asked >= 2; };
  try
  {
    io::parseForestMap(text, "big.csv", cancel);
    ADD_FAILURE() << "the cancelled read went on";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("big.csv:8192: interrupted"), std::string::npos) << e.what();
  }
}
