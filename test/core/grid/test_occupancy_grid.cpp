#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/grid/occupancy_grid.h"

using rbpf_slam::core::BeamKind;
using rbpf_slam::core::MapOrigin;
using rbpf_slam::core::OccupancyGrid;
using rbpf_slam::core::OccupancyGridConfig;
using rbpf_slam::core::OccupancyImage;
using rbpf_slam::core::Pose2;
using rbpf_slam::core::ScanData;
using rbpf_slam::core::ScanLimits;

namespace
{
using Cells = std::vector<std::pair<int, int>>;

// Distance of cell (x, y) from the ideal line through a and b, in cells.
double offLine(int x, int y, int x0, int y0, int x1, int y1)
{
  const double dx = x1 - x0, dy = y1 - y0;
  return std::abs(dy * (x - x0) - dx * (y - y0)) / std::hypot(dx, dy);
}
}  // namespace

TEST(Bresenham, AllOctantsAreConnectedAndStayOnTheLine)
{
  // One end point in each of the 8 octants (and on the axes and diagonals between them) from (3, -2).
  const int x0 = 3, y0 = -2;
  const std::vector<std::pair<int, int>> ends = { { 10, 3 },  { 5, 9 },   { -1, 9 },  { -9, 4 },  { -9, -5 },
                                                  { -2, -12 }, { 6, -12 }, { 11, -6 }, { 10, -2 }, { 3, 9 },
                                                  { -6, -2 }, { 3, -11 }, { 9, 4 },   { -4, -9 } };
  Cells cells;
  for (const auto& e : ends)
  {
    OccupancyGrid::bresenham(x0, y0, e.first, e.second, &cells);
    ASSERT_FALSE(cells.empty());
    EXPECT_EQ(cells.front(), std::make_pair(x0, y0));
    EXPECT_EQ(cells.back(), e);
    const int dx = std::abs(e.first - x0), dy = std::abs(e.second - y0);
    EXPECT_EQ(cells.size(), static_cast<std::size_t>(std::max(dx, dy) + 1)) << e.first << "," << e.second;
    for (std::size_t k = 0; k < cells.size(); ++k)
    {
      EXPECT_LE(offLine(cells[k].first, cells[k].second, x0, y0, e.first, e.second), 0.5 + 1e-9)
          << "end " << e.first << "," << e.second << " cell " << k;
      if (k > 0)
      {
        // Each step is to an 8-neighbour, monotonic along both axes.
        const int sx = cells[k].first - cells[k - 1].first, sy = cells[k].second - cells[k - 1].second;
        EXPECT_LE(std::abs(sx), 1);
        EXPECT_LE(std::abs(sy), 1);
        EXPECT_TRUE(sx == 0 || (sx > 0) == (e.first > x0));
        EXPECT_TRUE(sy == 0 || (sy > 0) == (e.second > y0));
      }
    }
  }
}

TEST(Bresenham, SingleCellAndKnownLine)
{
  Cells cells;
  OccupancyGrid::bresenham(4, 4, 4, 4, &cells);
  ASSERT_EQ(cells.size(), 1u);
  OccupancyGrid::bresenham(0, 0, 4, 2, &cells);
  const Cells expected = { { 0, 0 }, { 1, 0 }, { 2, 1 }, { 3, 1 }, { 4, 2 } };
  // The middle step of a 2:1 line is a tie; either (1,0),(2,1) or (1,1),(2,1) is a Bresenham line.
  ASSERT_EQ(cells.size(), expected.size());
  EXPECT_EQ(cells.front(), expected.front());
  EXPECT_EQ(cells[2], expected[2]);
  EXPECT_EQ(cells.back(), expected.back());
}

TEST(OccupancyGrid, CellBordersBelongToTheCellAboveAndRight)
{
  OccupancyGridConfig c;
  c.resolution = 0.05;
  OccupancyGrid g(c);
  int ix, iy;
  g.cellOf(0.15, -0.15, &ix, &iy);  // decimal border: 3 and -3 despite 0.15 / 0.05 = 2.9999999999999996
  EXPECT_EQ(ix, 3);
  EXPECT_EQ(iy, -3);
  g.cellOf(0.1499, -0.1501, &ix, &iy);
  EXPECT_EQ(ix, 2);
  EXPECT_EQ(iy, -4);
  g.cellOf(0.0, -1e-12, &ix, &iy);
  EXPECT_EQ(ix, 0);
  EXPECT_EQ(iy, 0);  // within the snap distance of the border
  g.cellOf(-0.001, 3.2, &ix, &iy);
  EXPECT_EQ(ix, -1);
  EXPECT_EQ(iy, 64);
  // A ray ending exactly on a border marks the cell beyond it.
  g.updateRay(0.01, 0.01, 0.25, 0.01, true);
  EXPECT_GT(g.logOdds(5, 0), 0.0f);
  EXPECT_LT(g.logOdds(4, 0), 0.0f);
  EXPECT_LT(g.logOdds(0, 0), 0.0f);
  EXPECT_EQ(g.logOdds(6, 0), 0.0f);
}

TEST(OccupancyGrid, RayUpdateAndClamping)
{
  OccupancyGridConfig c;  // defaults: -0.1, +0.9, clamp 20
  OccupancyGrid g(c);
  g.updateRay(0.02, 0.02, 1.02, 0.02, true);
  EXPECT_FLOAT_EQ(g.logOdds(20, 0), 0.9f);
  for (int i = 0; i < 20; ++i)
    EXPECT_FLOAT_EQ(g.logOdds(i, 0), -0.1f) << i;
  for (int k = 0; k < 100; ++k)
    g.updateRay(0.02, 0.02, 1.02, 0.02, true);
  EXPECT_FLOAT_EQ(g.logOdds(20, 0), 20.0f);  // 101 * 0.9 clamped
  EXPECT_NEAR(g.logOdds(5, 0), -10.1f, 1e-4);  // 101 * -0.1: not yet clamped
  for (int k = 0; k < 200; ++k)
    g.updateRay(0.02, 0.02, 1.02, 0.02, false);
  EXPECT_FLOAT_EQ(g.logOdds(5, 0), -20.0f);
  // The clamp lets a wall be cleared again: 20 / 0.1 = 200 passes bring it back to 0 and beyond.
  EXPECT_NEAR(g.logOdds(20, 0), 0.0f, 1e-3);
  EXPECT_TRUE(g.config().validate().empty());
  c.log_odds_free = 0.1f;
  EXPECT_NE(c.validate().find("log_odds_free"), std::string::npos);
}

TEST(OccupancyGrid, Rep117Ranges)
{
  ScanLimits limits;  // 0.15 - 20 m, no return clears 20 m
  limits.no_return_free_range = 3.0;
  ScanData scan;
  scan.range_min = 0.1;
  scan.range_max = 30.0;
  const float inf = std::numeric_limits<float>::infinity();
  double len = -1.0;
  EXPECT_EQ(rbpf_slam::core::classifyBeam(std::nanf(""), scan, limits, &len), BeamKind::kSkip);
  EXPECT_EQ(rbpf_slam::core::classifyBeam(-inf, scan, limits, &len), BeamKind::kSkip);
  EXPECT_EQ(rbpf_slam::core::classifyBeam(0.12f, scan, limits, &len), BeamKind::kSkip);  // below the map's 0.15
  EXPECT_EQ(rbpf_slam::core::classifyBeam(2.0f, scan, limits, &len), BeamKind::kHit);
  EXPECT_DOUBLE_EQ(len, 2.0);
  EXPECT_EQ(rbpf_slam::core::classifyBeam(inf, scan, limits, &len), BeamKind::kFree);
  EXPECT_DOUBLE_EQ(len, 3.0);
  EXPECT_EQ(rbpf_slam::core::classifyBeam(25.0f, scan, limits, &len), BeamKind::kFree);  // beyond the window
  EXPECT_DOUBLE_EQ(len, 20.0);
  EXPECT_EQ(rbpf_slam::core::classifyBeam(31.0f, scan, limits, &len), BeamKind::kFree);  // beyond the sensor
  EXPECT_DOUBLE_EQ(len, 3.0);

  // Five beams along +x, +y, -x, -y and +x again from (0.025, 0.025): hit, inf, NaN, too close, far.
  OccupancyGrid g;
  scan.angle_min = 0.0;
  scan.angle_increment = M_PI / 2;
  scan.ranges = { 1.0f, inf, std::nanf(""), 0.05f };
  EXPECT_EQ(g.insertScan(Pose2(0.025, 0.025, 0.0), scan, limits), 2);
  EXPECT_GT(g.logOdds(20, 0), 0.0f);   // the hit at x = 1.025
  EXPECT_LT(g.logOdds(0, 59), 0.0f);   // +Inf cleared up to 3 m ...
  EXPECT_LT(g.logOdds(0, 60), 0.0f);   // ... its last cell is free too, not a hit
  EXPECT_EQ(g.logOdds(0, 61), 0.0f);   // and nothing beyond
  EXPECT_EQ(g.logOdds(-1, 0), 0.0f);   // NaN: nothing
  EXPECT_EQ(g.logOdds(0, -1), 0.0f);   // too close: nothing
}

TEST(OccupancyGrid, GrowsByTilesInEveryDirectionAndExports)
{
  OccupancyGrid g;
  EXPECT_EQ(g.tileCount(), 0u);
  std::vector<std::int8_t> data;
  int w = -1, h = -1;
  MapOrigin o;
  g.exportProbabilities(&data, &w, &h, &o);
  EXPECT_EQ(w, 0);
  EXPECT_TRUE(data.empty());

  g.addLogOdds(0, 0, 0.9f);
  EXPECT_EQ(g.tileCount(), 1u);
  g.addLogOdds(-1, 0, -0.1f);  // the tile to the left
  EXPECT_EQ(g.tileCount(), 2u);
  g.addLogOdds(1000, -700, 0.9f);  // far away: the bounds grow, the cells already there stay
  g.addLogOdds(-900, 800, 0.9f);
  EXPECT_EQ(g.tileCount(), 4u);
  EXPECT_FLOAT_EQ(g.logOdds(0, 0), 0.9f);
  EXPECT_FLOAT_EQ(g.logOdds(-1, 0), -0.1f);
  EXPECT_FLOAT_EQ(g.logOdds(1000, -700), 0.9f);
  EXPECT_FLOAT_EQ(g.logOdds(-900, 800), 0.9f);
  EXPECT_EQ(g.logOdds(500, 500), 0.0f);
  EXPECT_LE(g.tileX0(), -900 >> 6);
  EXPECT_GE(g.tileX0() + g.tilesX(), (1000 >> 6) + 1);

  OccupancyGrid small;
  small.addLogOdds(3, 2, 0.9f);
  small.addLogOdds(-2, 1, -0.1f);
  small.exportProbabilities(&data, &w, &h, &o);
  ASSERT_EQ(w, 128);
  ASSERT_EQ(h, 64);
  EXPECT_DOUBLE_EQ(o.x, -64 * 0.05);
  EXPECT_DOUBLE_EQ(o.y, 0.0);
  EXPECT_EQ(data[2 * w + 64 + 3], 71);          // round(100 / (1 + e^-0.9))
  EXPECT_EQ(data[1 * w + 64 - 2], 48);          // round(100 / (1 + e^0.1)) = round(47.5)
  EXPECT_EQ(data[5 * w + 70], -1);              // unknown
  const OccupancyImage img = small.toImage();
  EXPECT_EQ(img.cells()[2 * w + 64 + 3], OccupancyImage::kOccupied);
  EXPECT_EQ(img.cells()[1 * w + 64 - 2], OccupancyImage::kFree);
  EXPECT_EQ(img.cells()[5 * w + 70], OccupancyImage::kUnknown);
}

TEST(OccupancyGrid, RefusesToGrowToAbsurdSizes)
{
  OccupancyGrid g;
  g.addLogOdds(0, 0, 0.9f);
  const int x0 = g.tileX0(), nx = g.tilesX(), ny = g.tilesY();
  // Far from the map: a bounding box of millions of tile pointers is refused, and the grid stays as it was.
  EXPECT_THROW(g.addLogOdds(1 << 28, 0, 0.9f), std::out_of_range);
  EXPECT_THROW(g.addLogOdds(0, -(1 << 28), 0.9f), std::out_of_range);
  // Beyond the cells any grid holds, even as its first tile.
  OccupancyGrid fresh;
  EXPECT_THROW(fresh.addLogOdds(OccupancyGrid::kMaxTileIndex * OccupancyGrid::kTileSize, 0, 0.9f), std::out_of_range);
  EXPECT_THROW(fresh.addLogOdds(0, std::numeric_limits<int>::min(), 0.9f), std::out_of_range);
  EXPECT_EQ(fresh.tileCount(), 0u);
  EXPECT_EQ(g.tileCount(), 1u);
  EXPECT_EQ(g.tileX0(), x0);
  EXPECT_EQ(g.tilesX(), nx);
  EXPECT_EQ(g.tilesY(), ny);
  EXPECT_FLOAT_EQ(g.logOdds(0, 0), 0.9f);
  // A far but sane write still grows the grid.
  EXPECT_NO_THROW(g.addLogOdds(20000, -20000, 0.9f));
  EXPECT_EQ(g.tileCount(), 2u);

  // Points that are not finite or too far for an int index are a cell outside every grid: it reads unknown,
  // and a scan from there is refused rather than allocated.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const double v : { nan, 1e300, -1e300, std::numeric_limits<double>::infinity() })
  {
    int ix = 0, iy = 0;
    g.cellOf(v, 0.0, &ix, &iy);
    EXPECT_EQ(g.logOdds(ix, iy), 0.0f) << v;
    EXPECT_GE(std::abs(ix), OccupancyGrid::kMaxTileIndex * OccupancyGrid::kTileSize) << v;
  }
  ScanData scan;
  scan.ranges.assign(10, 2.0f);
  scan.angle_increment = 0.1;
  EXPECT_THROW(g.insertScan(Pose2(nan, 0.0, 0.0), scan, ScanLimits()), std::out_of_range);
  EXPECT_THROW(g.insertScan(Pose2(0.0, 1e12, 0.0), scan, ScanLimits()), std::out_of_range);
  EXPECT_EQ(g.tileCount(), 2u);
}

TEST(OccupancyGrid, CopiesShareTilesUntilWritten)
{
  OccupancyGrid a;
  a.addLogOdds(1, 1, 0.9f);
  a.addLogOdds(100, 1, 0.9f);
  OccupancyGrid b = a;
  EXPECT_TRUE(a.sharesTileWith(b, 0, 0));
  EXPECT_TRUE(a.sharesTileWith(b, 1, 0));
  b.addLogOdds(2, 2, 0.9f);
  EXPECT_FALSE(a.sharesTileWith(b, 0, 0));  // written: b has its own copy now
  EXPECT_TRUE(a.sharesTileWith(b, 1, 0));   // untouched: still shared
  EXPECT_EQ(a.logOdds(2, 2), 0.0f);
  EXPECT_FLOAT_EQ(b.logOdds(2, 2), 0.9f);
  EXPECT_FLOAT_EQ(b.logOdds(1, 1), 0.9f);
}

namespace
{
/** Every coarse count equals the number of occupied cells it covers, over the grid's tile bounds. */
void expectCoarseCountsMatch(const OccupancyGrid& g)
{
  const int k = OccupancyGrid::kCoarseSize;
  const int x0 = g.tileX0() * OccupancyGrid::kTileSize / k, y0 = g.tileY0() * OccupancyGrid::kTileSize / k;
  const int nx = g.tilesX() * OccupancyGrid::kTileSize / k, ny = g.tilesY() * OccupancyGrid::kTileSize / k;
  int checked = 0, occupied_total = 0;
  for (int cy = y0; cy < y0 + ny; ++cy)
    for (int cx = x0; cx < x0 + nx; ++cx)
    {
      int n = 0;
      for (int iy = cy * k; iy < (cy + 1) * k; ++iy)
        for (int ix = cx * k; ix < (cx + 1) * k; ++ix)
          n += g.occupied(ix, iy);
      ASSERT_EQ(g.coarseCount(cx, cy), n) << "coarse cell " << cx << ", " << cy;
      ++checked;
      occupied_total += n;
    }
  EXPECT_GT(checked, 0);
  EXPECT_GT(occupied_total, 0);
}
}  // namespace

TEST(OccupancyGrid, CoarseCountsFollowEveryWriteAndCopy)
{
  // Rays from random poses hit, pass and clear cells (cells flip between occupied and free); a copy then
  // diverges (copy-on-write); the coarse level of both must count exactly their occupied cells.
  OccupancyGrid g;
  std::srand(7);
  const auto uniform = [](double lo, double hi) { return lo + (hi - lo) * (std::rand() / (RAND_MAX + 1.0)); };
  for (int i = 0; i < 400; ++i)
    g.updateRay(uniform(-2, 2), uniform(-2, 2), uniform(-6, 6), uniform(-6, 6), i % 3 != 0);
  expectCoarseCountsMatch(g);
  OccupancyGrid copy = g;
  for (int i = 0; i < 200; ++i)
  {
    copy.updateRay(uniform(-2, 2), uniform(-2, 2), uniform(-6, 6), uniform(-6, 6), i % 2 == 0);
    copy.addLogOdds(static_cast<int>(uniform(-100, 100)), static_cast<int>(uniform(-100, 100)), 0.9f);
  }
  expectCoarseCountsMatch(g);
  expectCoarseCountsMatch(copy);
  OccupancyGridConfig bad;
  bad.occupied_log_odds = -0.5f;
  bad.free_log_odds = -1.0f;
  EXPECT_NE(bad.validate(), "");
}
