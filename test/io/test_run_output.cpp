// Run outputs: the one landmark CSV (slam_bag's map.csv, the FastSLAM node's inventory) and TUM trajectories.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "rbpf_slam/io/run_output.h"
#include "io/temp_files.h"

using rbpf_slam::core::Landmark;
using rbpf_slam::core::Pose2;
namespace io = rbpf_slam::io;

namespace
{
std::vector<std::string> split(const std::string& text, char sep)
{
  std::vector<std::string> parts;
  std::istringstream in(text);
  std::string part;
  while (std::getline(in, part, sep))
    parts.push_back(part);
  if (sep == ',' && !text.empty() && text.back() == ',')
    parts.emplace_back();  // a last field left empty
  return parts;
}
}  // namespace

TEST(LandmarksCsv, InventoryColumnsWithDiameterAndProvisional)
{
  Landmark a;
  a.id = 7;
  a.mean = Eigen::Vector2d(1.5, -2.25);
  a.covariance << 0.0004, 0.0, 0.0, 0.0009;  // sigma 2 cm and 3 cm
  a.radius = 0.15;
  a.radius_variance = 0.0001;  // sigma of r: 1 cm, of dbh: 2 cm
  a.observations = 12;
  a.provisional = false;
  Landmark b = a;
  b.id = 8;
  b.provisional = true;
  b.covariance(0, 0) = -1e-12;  // round-off below zero: sigma 0, never NaN

  const std::vector<std::string> lines = split(io::landmarksCsv({ a, b }), '\n');
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[0], "id,x,y,dbh,sigma_x,sigma_y,sigma_dbh,observations,provisional,cov_xy,first_seen,last_seen");
  EXPECT_EQ(lines[0], io::kLandmarksCsvHeader);
  const std::vector<std::string> first = split(lines[1], ',');
  ASSERT_EQ(first.size(), 12u) << lines[1];
  EXPECT_EQ(first[0], "7");
  EXPECT_DOUBLE_EQ(std::stod(first[1]), 1.5);
  EXPECT_DOUBLE_EQ(std::stod(first[2]), -2.25);
  EXPECT_NEAR(std::stod(first[3]), 0.30, 1e-9) << "dbh is the diameter";
  EXPECT_NEAR(std::stod(first[4]), 0.02, 1e-9);
  EXPECT_NEAR(std::stod(first[5]), 0.03, 1e-9);
  EXPECT_NEAR(std::stod(first[6]), 0.02, 1e-9) << "sigma of the diameter";
  EXPECT_EQ(first[7], "12");
  EXPECT_EQ(first[8], "0");
  EXPECT_EQ(std::stod(first[9]), 0.0);
  EXPECT_EQ(first[10], "") << "first seen: not known";
  EXPECT_EQ(first[11], "");
  const std::vector<std::string> second = split(lines[2], ',');
  ASSERT_EQ(second.size(), 12u) << lines[2];
  EXPECT_EQ(second[0], "8");
  EXPECT_EQ(std::stod(second[4]), 0.0);
  EXPECT_EQ(second[8], "1");
}

TEST(LandmarksCsv, EmptyMapIsTheHeaderAlone)
{
  EXPECT_EQ(io::landmarksCsv({}), std::string(io::kLandmarksCsvHeader) + "\n");
}

TEST(Tum, WrittenTrajectoryReadsBack)
{
  const std::string dir = temp_files::makeDir("rbpf_run_output");
  const std::string path = dir + "/estimate.tum";
  const std::vector<double> stamps{ 10.0, 10.5, 11.25 };
  const std::vector<Pose2> poses{ Pose2(0.0, 0.0, 0.0), Pose2(1.0, -0.5, 3.0), Pose2(2.0, 0.25, -1.5) };
  io::writeTum(path, stamps, poses);
  std::vector<double> t;
  std::vector<Pose2> p;
  io::readTum(path, &t, &p);
  ASSERT_EQ(t.size(), 3u);
  ASSERT_EQ(p.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i)
  {
    EXPECT_NEAR(t[i], stamps[i], 1e-9);
    EXPECT_NEAR(p[i].x, poses[i].x, 1e-9);
    EXPECT_NEAR(p[i].y, poses[i].y, 1e-9);
    EXPECT_NEAR(std::remainder(p[i].theta - poses[i].theta, 2.0 * M_PI), 0.0, 1e-9);
  }
  EXPECT_THROW(io::readTum(dir + "/missing.tum", &t, &p), std::runtime_error);
}

TEST(Tum, UnixEpochStampsKeepTheirSubMillisecondPart)
{
  // Two poses 0.4 ms apart at a Unix-epoch stamp: twelve significant digits would write both as ...123.457 (1 ms
  // steps); the files keep nanoseconds.
  const std::string dir = temp_files::makeDir("rbpf_run_output");
  const std::string path = dir + "/epoch.tum";
  const std::vector<double> stamps{ 1700000000.123456789, 1700000000.123856789 };
  io::writeTum(path, stamps, { Pose2(), Pose2(0.1, 0.0, 0.0) });
  std::vector<double> t;
  std::vector<Pose2> p;
  io::readTum(path, &t, &p);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_NEAR(t[0], stamps[0], 1e-6);
  EXPECT_NEAR(t[1], stamps[1], 1e-6);
  EXPECT_NEAR(t[1] - t[0], 0.0004, 1e-6);
  EXPECT_EQ(io::stampText(1700000000.5), "1700000000.500000000");
  EXPECT_EQ(io::stampText(std::nan("")), "");
}

TEST(FastSlamRunRecord, SearchesWhileTrackingAreCountedByHowEachEnded)
{
  io::FastSlamRunRecord record;
  EXPECT_EQ(record.lostSummary(), "") << "no search, nothing to say";
  double t = 10.0;
  // Each search: two updates of gathering, then the update that ends it (one of three ways).
  const auto search = [&](bool recovered, bool confirmed, bool gave_up) {
    for (int k = 0; k < 3; ++k)
    {
      rbpf_slam::core::PipelineUpdate u;
      u.stamp = (t += 0.1);
      u.relocalization.lost = true;
      u.relocalization.active = true;
      const bool last = k == 2;
      u.relocalization.recovered = last && recovered;
      u.relocalization.confirmed = last && confirmed;
      u.relocalization.gave_up = last && gave_up;
      record.addUpdate(u);
    }
  };
  search(false, false, true);  // nothing found within a window of travel; the next warning starts another
  search(true, false, false);
  search(false, true, false);
  const std::string s = record.lostSummary();
  EXPECT_NE(s.find("searched again 3 times while tracking: 1 found the robot elsewhere"), std::string::npos) << s;
  EXPECT_NE(s.find("(at 10.600 s)"), std::string::npos) << s;
  EXPECT_NE(s.find("1 found it where the estimate was, 1 found nothing within a window of travel"), std::string::npos)
      << s;
}
