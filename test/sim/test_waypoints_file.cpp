// Drive files: waypoints `x y` per line, and drives by name (sim::readWaypoints, sim::namedDrive).
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "rbpf_slam/sim/path_follower.h"
#include "rbpf_slam/sim/waypoints_file.h"
#include "io/temp_files.h"

namespace sim = rbpf_slam::sim;

namespace
{
std::string writeTemp(const std::string& name, const std::string& text)
{
  return temp_files::writeFile(temp_files::makeDir("rbpf_waypoints") + "/" + name, text);
}

std::string errorOf(const std::string& path)
{
  try
  {
    sim::readWaypoints(path);
  }
  catch (const std::runtime_error& e)
  {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(WaypointsFile, ReadsPointsSkippingCommentsAndBlankLines)
{
  const std::string path = writeTemp("loop.txt", "# corridor loop\n4 0\n\n  8 0.5   # the door\r\n12.9 -4.6\n");
  const std::vector<Eigen::Vector2d> w = sim::readWaypoints(path);
  ASSERT_EQ(w.size(), 3u);
  EXPECT_EQ(w[0], Eigen::Vector2d(4.0, 0.0));
  EXPECT_EQ(w[1], Eigen::Vector2d(8.0, 0.5));
  EXPECT_EQ(w[2], Eigen::Vector2d(12.9, -4.6));
}

TEST(WaypointsFile, ErrorsNameTheFileAndLine)
{
  const std::string one = writeTemp("one.txt", "4 0\n8\n");
  EXPECT_EQ(errorOf(one), one + ":2: expected 'x y', got '8'");
  const std::string crlf = writeTemp("crlf.txt", "4 0\r\n8\r\n");
  EXPECT_EQ(errorOf(crlf), crlf + ":2: expected 'x y', got '8'");
  const std::string three = writeTemp("three.txt", "4 0 1\n");
  EXPECT_EQ(errorOf(three), three + ":1: expected 'x y', got '4 0 1'");
  const std::string word = writeTemp("word.txt", "1 2\n3 4\nstraight\n");
  EXPECT_EQ(errorOf(word), word + ":3: expected 'x y', got 'straight'");
  const std::string inf = writeTemp("inf.txt", "nan 2\n");
  EXPECT_NE(errorOf(inf).find(inf + ":1:"), std::string::npos) << errorOf(inf);
  const std::string empty = writeTemp("empty.txt", "# nothing\n\n");
  EXPECT_EQ(errorOf(empty), empty + ": no waypoints");
  EXPECT_NE(errorOf(empty + ".missing").find("cannot read"), std::string::npos);
}

TEST(WaypointsFile, NamedDrives)
{
  std::string error;
  EXPECT_EQ(sim::namedDrive("straight", &error), rbpf_slam::sim::straightDrive());
  EXPECT_EQ(sim::namedDrive("loop", &error), rbpf_slam::sim::loopDrive());
  EXPECT_TRUE(error.empty()) << error;
  const std::string path = writeTemp("drive.txt", "0 0\n12 0\n");
  EXPECT_EQ(sim::namedDrive(path, &error).size(), 2u);
  EXPECT_TRUE(sim::namedDrive("circle", &error).empty());
  EXPECT_EQ(error, "drive 'circle' is neither 'straight', 'loop' nor a readable waypoint file");
  const std::string bad = writeTemp("bad.txt", "0 0\nx y\n");
  EXPECT_TRUE(sim::namedDrive(bad, &error).empty());
  EXPECT_EQ(error, bad + ":2: expected 'x y', got 'x y'");
}
