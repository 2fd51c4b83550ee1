// Map-image (map_server PGM + YAML) loading and saving.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <unistd.h>

#include "rbpf_slam/io/map_image_file.h"
#include "io/temp_files.h"

using rbpf_slam::core::MapOrigin;
using rbpf_slam::core::OccupancyImage;
using rbpf_slam::io::loadMapImage;
using rbpf_slam::io::saveMapImage;

namespace
{
std::string tempDir()
{
  return temp_files::makeDir("rbpf_map_image");
}

using temp_files::writeFile;

std::string errorOf(const std::string& yaml)
{
  try
  {
    loadMapImage(yaml);
  }
  catch (const std::runtime_error& e)
  {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(MapImageFile, AsciiPgmThresholdsAndFlip)
{
  const std::string dir = tempDir();
  // 3 x 2 image, top row first: black (occupied), white (free), mid grey (unknown).
  writeFile(dir + "/m.pgm", "P2\n# comment\n3 2\n255\n0 255 128\n255 255 0\n");
  writeFile(dir + "/m.yaml",
            "image: m.pgm\nresolution: 0.5\norigin: [1.0, -2.0, 0.0]\nnegate: 0\n"
            "occupied_thresh: 0.65\nfree_thresh: 0.196\n");
  const OccupancyImage map = loadMapImage(dir + "/m.yaml");
  ASSERT_EQ(map.width(), 3);
  ASSERT_EQ(map.height(), 2);
  EXPECT_DOUBLE_EQ(map.resolution(), 0.5);
  // Row 0 is the bottom row of the image.
  EXPECT_EQ(map.cell(0, 0), OccupancyImage::kFree);
  EXPECT_EQ(map.cell(2, 0), OccupancyImage::kOccupied);
  EXPECT_EQ(map.cell(0, 1), OccupancyImage::kOccupied);
  EXPECT_EQ(map.cell(1, 1), OccupancyImage::kFree);
  EXPECT_EQ(map.cell(2, 1), OccupancyImage::kUnknown);
  // The origin is the lower-left corner: world (1.25, -1.75) is the centre of cell (0, 0).
  const Eigen::Vector2d c = map.cellCenter(0, 0);
  EXPECT_NEAR(c.x(), 1.25, 1e-12);
  EXPECT_NEAR(c.y(), -1.75, 1e-12);
}

TEST(MapImageFile, SaveThenLoadGivesSameCells)
{
  const std::string dir = tempDir();
  std::vector<std::int8_t> cells;
  for (int i = 0; i < 7 * 5; ++i)
  {
    cells.push_back(i % 3 == 0 ? OccupancyImage::kOccupied : (i % 3 == 1 ? OccupancyImage::kFree : OccupancyImage::kUnknown));
  }
  MapOrigin origin;
  origin.x = -3.0;
  origin.y = 2.0;
  const OccupancyImage map(7, 5, 0.1, origin, cells);
  saveMapImage(map, dir + "/saved.yaml");
  const OccupancyImage back = loadMapImage(dir + "/saved.yaml");
  ASSERT_EQ(back.width(), 7);
  ASSERT_EQ(back.height(), 5);
  EXPECT_EQ(back.cells(), cells);
  EXPECT_NEAR(back.origin().x, -3.0, 1e-9);
  EXPECT_NEAR(back.origin().y, 2.0, 1e-9);
  EXPECT_NEAR(back.resolution(), 0.1, 1e-12);
  // No partial file is left behind.
  std::ifstream partial(dir + "/saved.pgm.partial-" + std::to_string(::getpid()));
  EXPECT_FALSE(partial.good());
}

TEST(MapImageFile, ErrorsNameTheKeyOrFile)
{
  const std::string dir = tempDir();
  writeFile(dir + "/noreso.yaml", "image: x.pgm\norigin: [0, 0, 0]\n");
  EXPECT_NE(errorOf(dir + "/noreso.yaml").find("resolution"), std::string::npos);

  writeFile(dir + "/bad.pgm", "XY\n1 1\n255\n0\n");
  writeFile(dir + "/bad.yaml", "image: bad.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n");
  const std::string msg = errorOf(dir + "/bad.yaml");
  EXPECT_NE(msg.find("bad.pgm"), std::string::npos) << msg;

  EXPECT_NE(errorOf(dir + "/missing.yaml"), "");
}

TEST(MapImageFile, PackagedIndoorWorldLoads)
{
  const OccupancyImage map = loadMapImage(std::string(RBPF_SLAM_SOURCE_DIR) + "/config/worlds/indoor.yaml");
  EXPECT_EQ(map.width(), 520);
  EXPECT_EQ(map.height(), 360);
  // The start pose (world origin) is free, and a ray east along the corridor hits a wall within the map.
  EXPECT_FALSE(map.occupied(0.0, 0.0));
  const double r = map.castRay(0.0, 0.0, 0.0, 40.0);
  EXPECT_GT(r, 5.0);
  EXPECT_LT(r, 40.0);
}

TEST(AtomicFiles, AFailedWriteLeavesNoFileAndNoTemporary)
{
  const std::string dir = tempDir();
  // The YAML's folder does not exist: its write fails, so the image written before it must not appear either.
  EXPECT_THROW(rbpf_slam::io::writeFilesAtomic({ { dir + "/map.pgm", "P5 image" }, { dir + "/missing/map.yaml", "x" } }),
               std::runtime_error);
  std::ifstream image(dir + "/map.pgm");
  EXPECT_FALSE(image.good());
  const std::string listing = dir + "/listing.txt";
  ASSERT_EQ(std::system(("ls -A " + dir + " > " + listing).c_str()), 0);
  std::ifstream names(listing);
  std::string name, others;
  while (std::getline(names, name))
    if (name != "listing.txt")
      others += name + " ";
  EXPECT_EQ(others, "") << "left behind in " << dir;
  // And a successful pair is there whole.
  rbpf_slam::io::writeFilesAtomic({ { dir + "/a.txt", "first" }, { dir + "/b.txt", "second" } });
  std::ifstream a(dir + "/a.txt"), b(dir + "/b.txt");
  std::string sa, sb;
  std::getline(a, sa);
  std::getline(b, sb);
  EXPECT_EQ(sa, "first");
  EXPECT_EQ(sb, "second");
}
