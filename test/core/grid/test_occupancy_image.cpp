#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/grid/occupancy_image.h"

using rbpf_slam::core::MapOrigin;
using rbpf_slam::core::OccupancyImage;

namespace
{
const double kInf = std::numeric_limits<double>::infinity();
const double kEps = 1e-9;
const std::int8_t kOcc = OccupancyImage::kOccupied;
const std::int8_t kFree = OccupancyImage::kFree;
const std::int8_t kUnk = OccupancyImage::kUnknown;

/** A grid of @p width x @p height cells, all @p fill, to be edited with set(). */
struct GridBuilder
{
  int width;
  int height;
  std::vector<std::int8_t> cells;

  GridBuilder(int w, int h, std::int8_t fill = kFree) : width(w), height(h), cells(w * h, fill) {}
  void set(int col, int row, std::int8_t v) { cells[row * width + col] = v; }
  void ring(std::int8_t v)
  {
    for (int c = 0; c < width; ++c)
    {
      set(c, 0, v);
      set(c, height - 1, v);
    }
    for (int r = 0; r < height; ++r)
    {
      set(0, r, v);
      set(width - 1, r, v);
    }
  }
  OccupancyImage build(double resolution, const MapOrigin& origin = MapOrigin()) const
  {
    return OccupancyImage(width, height, resolution, origin, cells);
  }
};

MapOrigin makeOrigin(double x, double y, double yaw)
{
  MapOrigin o;
  o.x = x;
  o.y = y;
  o.yaw = yaw;
  return o;
}

/**
 * The test room: 20 x 20 cells of 0.5 m (10 m x 10 m) with a one-cell wall all round, so the free inside is
 * [0.5, 9.5] x [0.5, 9.5] in grid metres. The interior is unknown, which casting must treat as free.
 */
OccupancyImage room(const MapOrigin& origin = MapOrigin())
{
  GridBuilder g(20, 20, kUnk);
  g.ring(kOcc);
  return g.build(0.5, origin);
}

/** Distance from (x, y) inside the box [lo, hi]^2 to its boundary along heading a. */
double boxDistance(double x, double y, double a, double lo, double hi)
{
  const double c = std::cos(a), s = std::sin(a);
  double t = kInf;
  if (std::abs(c) > 1e-15)
    t = std::min(t, ((c > 0.0 ? hi : lo) - x) / c);
  if (std::abs(s) > 1e-15)
    t = std::min(t, ((s > 0.0 ? hi : lo) - y) / s);
  return t;
}

/**
 * Reference caster, independent of the traversal: the nearest entry, over all occupied cells taken as closed
 * squares, of the ray into the square (slab test), or 0 if the start is in an occupied cell.
 */
double referenceCast(const OccupancyImage& map, double x, double y, double angle, double max_range)
{
  if (map.occupied(x, y))
    return 0.0;
  const MapOrigin& o = map.origin();
  const double r = map.resolution();
  const double c = std::cos(o.yaw), s = std::sin(o.yaw);
  const double px = (c * (x - o.x) + s * (y - o.y)) / r;
  const double py = (-s * (x - o.x) + c * (y - o.y)) / r;
  const double dx = std::cos(angle - o.yaw), dy = std::sin(angle - o.yaw);
  double best = kInf;
  for (int row = 0; row < map.height(); ++row)
  {
    for (int col = 0; col < map.width(); ++col)
    {
      if (!map.cellOccupied(col, row))
        continue;
      double t0 = 0.0, t1 = kInf;
      const double lo[2] = { static_cast<double>(col), static_cast<double>(row) };
      const double p[2] = { px, py };
      const double d[2] = { dx, dy };
      bool hit = true;
      for (int k = 0; k < 2 && hit; ++k)
      {
        if (d[k] == 0.0)
        {
          hit = p[k] >= lo[k] && p[k] <= lo[k] + 1.0;
          continue;
        }
        double a = (lo[k] - p[k]) / d[k], b = (lo[k] + 1.0 - p[k]) / d[k];
        if (a > b)
          std::swap(a, b);
        t0 = std::max(t0, a);
        t1 = std::min(t1, b);
        hit = t0 <= t1;
      }
      if (hit)
        best = std::min(best, t0);
    }
  }
  return best * r <= max_range ? best * r : kInf;
}
}  // namespace

TEST(OccupancyImage, AccessorsAndCellLookup)
{
  GridBuilder g(4, 3);
  g.set(1, 0, kOcc);
  g.set(3, 2, kUnk);
  const OccupancyImage map = g.build(0.25, makeOrigin(-1.0, 2.0, 0.0));
  EXPECT_EQ(4, map.width());
  EXPECT_EQ(3, map.height());
  EXPECT_DOUBLE_EQ(0.25, map.resolution());
  EXPECT_DOUBLE_EQ(-1.0, map.origin().x);
  EXPECT_EQ(12u, map.cells().size());
  EXPECT_EQ(kOcc, map.cell(1, 0));
  EXPECT_EQ(kUnk, map.cell(3, 2));
  EXPECT_EQ(kFree, map.cell(0, 0));
  EXPECT_EQ(kUnk, map.cell(4, 0)) << "outside the grid is unknown";
  EXPECT_FALSE(map.cellOccupied(-1, 0));

  // Row 0 is the bottom row: cell (1, 0) covers x in [-0.75, -0.5), y in [2.0, 2.25).
  EXPECT_TRUE(map.occupied(-0.6, 2.1));
  EXPECT_TRUE(map.occupied(-0.75, 2.0)) << "a point on the lower / left border belongs to the cell";
  EXPECT_FALSE(map.occupied(-0.5, 2.1)) << "the right border belongs to the next cell";
  EXPECT_FALSE(map.occupied(-0.6, 2.25)) << "the upper border belongs to the next cell";
  EXPECT_FALSE(map.occupied(-0.6, 1.9)) << "outside the grid is not occupied";
  EXPECT_FALSE(map.occupied(std::nan(""), 2.1));
  EXPECT_FALSE(map.occupied(1e300, -1e300));

  int col = -7, row = -7;
  EXPECT_TRUE(map.worldToCell(-0.01, 2.74, &col, &row));
  EXPECT_EQ(3, col);
  EXPECT_EQ(2, row);
  EXPECT_FALSE(map.worldToCell(0.0, 2.1, &col, &row)) << "x = origin + width is outside";
  const Eigen::Vector2d centre = map.cellCenter(1, 0);
  EXPECT_NEAR(-0.625, centre.x(), kEps);
  EXPECT_NEAR(2.125, centre.y(), kEps);
}

TEST(OccupancyImage, BordersOfDecimalResolutionsAreSnapped)
{
  // 0.15 / 0.05 is 2.9999999999999996 in doubles: without snapping x = 0.15 would land in column 2.
  GridBuilder g(10, 1);
  g.set(3, 0, kOcc);
  const OccupancyImage map = g.build(0.05);
  EXPECT_TRUE(map.occupied(0.15, 0.01));
  EXPECT_FALSE(map.occupied(0.2, 0.01));
  EXPECT_DOUBLE_EQ(0.0, map.castRay(0.15, 0.025, M_PI, 1.0));
  EXPECT_DOUBLE_EQ(0.0, map.castRay(0.2, 0.025, M_PI, 1.0)) << "from the right border into the occupied cell";
  EXPECT_EQ(kInf, map.castRay(0.2, 0.025, 0.0, 1.0)) << "from the right border away from it";
  EXPECT_NEAR(0.1, map.castRay(0.05, 0.025, 0.0, 1.0), kEps);
}

TEST(OccupancyImage, ConstructorRejectsBadInput)
{
  const std::vector<std::int8_t> six(6, kFree);
  EXPECT_THROW(OccupancyImage(2, 2, 0.1, MapOrigin(), six), std::invalid_argument);
  EXPECT_THROW(OccupancyImage(-2, -3, 0.1, MapOrigin(), six), std::invalid_argument);
  EXPECT_THROW(OccupancyImage(2, 3, 0.0, MapOrigin(), six), std::invalid_argument);
  EXPECT_THROW(OccupancyImage(2, 3, std::nan(""), MapOrigin(), six), std::invalid_argument);
  EXPECT_THROW(OccupancyImage(2, 3, 0.1, makeOrigin(0.0, kInf, 0.0), six), std::invalid_argument);
  std::vector<std::int8_t> bad = six;
  bad[4] = 50;
  try
  {
    OccupancyImage(2, 3, 0.1, MapOrigin(), bad);
    FAIL() << "a cell value of 50 was accepted";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("col 0, row 2"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(OccupancyImage(2, 3, 0.1, MapOrigin(), six));
}

TEST(OccupancyImage, RaysAlongBothAxes)
{
  const OccupancyImage map = room();
  // Start (4.3, 5.2): walls' inner faces at 0.5 and 9.5.
  EXPECT_NEAR(5.2, map.castRay(4.3, 5.2, 0.0, 100.0), kEps);
  EXPECT_NEAR(4.3, map.castRay(4.3, 5.2, M_PI / 2, 100.0), kEps);
  EXPECT_NEAR(3.8, map.castRay(4.3, 5.2, M_PI, 100.0), kEps);
  EXPECT_NEAR(3.8, map.castRay(4.3, 5.2, -M_PI, 100.0), kEps);
  EXPECT_NEAR(4.7, map.castRay(4.3, 5.2, -M_PI / 2, 100.0), kEps);
  EXPECT_NEAR(4.7, map.castRay(4.3, 5.2, 3 * M_PI / 2, 100.0), kEps);
  EXPECT_NEAR(5.2, map.castRay(4.3, 5.2, 2 * M_PI, 100.0), kEps);
}

TEST(OccupancyImage, RaysInAllEightOctants)
{
  const OccupancyImage map = room();
  for (int k = 0; k < 8; ++k)
  {
    const double a = M_PI / 8 + k * M_PI / 4;  // the middle of octant k
    EXPECT_NEAR(boxDistance(4.3, 5.2, a, 0.5, 9.5), map.castRay(4.3, 5.2, a, 100.0), kEps) << "octant " << k;
  }
  for (int k = 0; k < 8; ++k)
  {
    const double a = k * M_PI / 4;  // the octant borders: axes and diagonals
    EXPECT_NEAR(boxDistance(6.1, 2.9, a, 0.5, 9.5), map.castRay(6.1, 2.9, a, 100.0), kEps) << "angle " << a;
  }
  for (int k = 0; k < 720; ++k)
  {
    const double a = -M_PI + k * M_PI / 360;
    ASSERT_NEAR(boxDistance(1.37, 8.81, a, 0.5, 9.5), map.castRay(1.37, 8.81, a, 100.0), kEps) << "angle " << a;
  }
}

TEST(OccupancyImage, RayStartingOnCellBorders)
{
  GridBuilder g(20, 20, kFree);
  g.ring(kOcc);
  g.set(12, 10, kOcc);  // the square [6.0, 6.5] x [5.0, 5.5]
  const OccupancyImage map = g.build(0.5);

  // On a vertex of the grid (5.0, 5.0), in every direction of the octant borders.
  EXPECT_NEAR(1.0, map.castRay(5.0, 5.0, 0.0, 100.0), kEps) << "along y = 5.0, the line through the block's base";
  EXPECT_NEAR(4.5, map.castRay(5.0, 5.0, M_PI, 100.0), kEps);
  EXPECT_NEAR(4.5, map.castRay(5.0, 5.0, M_PI / 2, 100.0), kEps);
  EXPECT_NEAR(4.5, map.castRay(5.0, 5.0, -M_PI / 2, 100.0), kEps);
  EXPECT_NEAR(4.5 * std::sqrt(2.0), map.castRay(5.0, 5.0, 3 * M_PI / 4, 100.0), kEps);
  EXPECT_NEAR(4.5 * std::sqrt(2.0), map.castRay(5.0, 5.0, -M_PI / 4, 100.0), kEps);

  // On the block's left face: inside it by the half-open convention.
  EXPECT_DOUBLE_EQ(0.0, map.castRay(6.0, 5.2, M_PI, 100.0));
  // On its right face: free; into the block at once, away from it the full way to the wall.
  EXPECT_DOUBLE_EQ(0.0, map.castRay(6.5, 5.2, M_PI, 100.0));
  EXPECT_NEAR(3.0, map.castRay(6.5, 5.2, 0.0, 100.0), kEps);
  // On its top face: free, and a ray straight down enters it at once.
  EXPECT_DOUBLE_EQ(0.0, map.castRay(6.2, 5.5, -M_PI / 2, 100.0));
  EXPECT_NEAR(4.0, map.castRay(6.2, 5.5, M_PI / 2, 100.0), kEps);
  // Along the line y = 5.5 (the block's top face) the ray runs above the block: it grazes, does not hit.
  EXPECT_NEAR(9.0, map.castRay(0.5, 5.5, 0.0, 100.0), kEps);
  // Along y = 5.0 (its bottom face) the ray runs through the block's row.
  EXPECT_NEAR(5.5, map.castRay(0.5, 5.0, 0.0, 100.0), kEps);
}

TEST(OccupancyImage, DiagonalThroughGridVerticesDoesNotLeakThroughCornerTouchingWall)
{
  // A diagonal wall of cells touching only at their corners, as 8-connected line drawing makes them:
  // (16, 4), (15, 5), ... (12, 8), (11, 9), ... From the centre of cell (5, 2) a 45 degree ray runs along
  // y = x - 3 through grid vertices only, and crosses the wall exactly at vertex (12, 9), between the
  // corners of (12, 8) and (11, 9); the cells on both sides of the wall are free.
  GridBuilder g(20, 20, kFree);
  for (int k = 0; k < 8; ++k)
    g.set(16 - k, 4 + k, kOcc);
  const OccupancyImage map = g.build(0.5);
  const double expected = std::hypot(12 - 5.5, 9 - 2.5) * 0.5;
  EXPECT_NEAR(expected, referenceCast(map, 2.75, 1.25, M_PI / 4, 100.0), 1e-8);
  EXPECT_NEAR(expected, map.castRay(2.75, 1.25, M_PI / 4, 100.0), 1e-8) << "the ray leaked between the corners";
  // Back from the other side (from the centre of cell (15, 12)), through the same vertex.
  EXPECT_NEAR(std::hypot(15.5 - 12, 12.5 - 9) * 0.5, map.castRay(7.75, 6.25, -3 * M_PI / 4, 100.0), 1e-8);

  // A ray through a vertex whose side cells are free passes; the cell it enters at the vertex is hit there.
  GridBuilder h(20, 20, kFree);
  h.set(12, 9, kOcc);
  const OccupancyImage block = h.build(0.5);
  EXPECT_NEAR(expected, block.castRay(2.75, 1.25, M_PI / 4, 100.0), 1e-8);
  // One cell higher the ray grazes the block's top-left corner: a side cell of that vertex, so it is touched.
  EXPECT_NEAR(std::hypot(12 - 5.5, 10 - 3.5) * 0.5, block.castRay(2.75, 1.75, M_PI / 4, 100.0), 1e-8);
  EXPECT_EQ(kInf, block.castRay(2.75, 2.25, M_PI / 4, 100.0)) << "two cells higher, the ray passes above it";
}

TEST(OccupancyImage, StartInsideOccupiedCellIsZero)
{
  const OccupancyImage map = room();
  for (int k = 0; k < 8; ++k)
  {
    EXPECT_DOUBLE_EQ(0.0, map.castRay(0.2, 5.0, k * M_PI / 4, 100.0));
    EXPECT_DOUBLE_EQ(0.0, map.castRay(9.9, 9.9, k * M_PI / 4, 0.0)) << "even with max_range 0";
  }
}

TEST(OccupancyImage, RaysThatEscapeAreInfinite)
{
  GridBuilder g(20, 20, kFree);
  g.ring(kOcc);
  g.set(19, 10, kFree);  // a one-cell door in the east wall: y in [5.0, 5.5]
  g.set(19, 11, kFree);  // widened to [5.0, 6.0]
  const OccupancyImage map = g.build(0.5);
  EXPECT_EQ(kInf, map.castRay(4.0, 5.4, 0.0, 100.0));
  EXPECT_EQ(kInf, map.castRay(4.0, 5.0, 0.0, kInf)) << "along the door's lower border";
  EXPECT_NEAR(5.5, map.castRay(4.0, 4.9, 0.0, kInf), kEps);
  // Starting outside the grid: away from it, past it, and towards it (hits the outer face of the wall).
  EXPECT_EQ(kInf, map.castRay(-2.0, 5.2, M_PI, 100.0));
  EXPECT_EQ(kInf, map.castRay(-2.0, 12.0, 0.0, 100.0));
  EXPECT_EQ(kInf, map.castRay(-2.0, 10.0, 0.0, 100.0)) << "along the grid's top edge, outside the grid";
  EXPECT_NEAR(2.0, map.castRay(-2.0, 5.2, 0.0, 100.0), kEps);
  EXPECT_NEAR(2.0, map.castRay(-2.0, 0.0, 0.0, 100.0), kEps) << "along the grid's bottom edge, inside the grid";
  EXPECT_NEAR(std::sqrt(2.0), map.castRay(-1.0, -1.0, M_PI / 4, 100.0), kEps) << "into the corner";
  EXPECT_NEAR(2.0 * std::sqrt(2.0), map.castRay(12.0, 7.0, 3 * M_PI / 4, 100.0), kEps);
  EXPECT_EQ(kInf, map.castRay(12.0, 8.0, 3 * M_PI / 4, 100.0)) << "touches the grid at its corner only";
  EXPECT_EQ(kInf, OccupancyImage().castRay(0.0, 0.0, 0.0, 100.0)) << "empty grid";
}

TEST(OccupancyImage, MaxRangeIsRespected)
{
  const OccupancyImage map = room();
  EXPECT_NEAR(5.0, map.castRay(4.5, 5.2, 0.0, 100.0), kEps);
  EXPECT_DOUBLE_EQ(5.0, map.castRay(4.5, 5.2, 0.0, 5.0)) << "a hit at exactly max_range counts";
  EXPECT_EQ(kInf, map.castRay(4.5, 5.2, 0.0, 4.999));
  EXPECT_EQ(kInf, map.castRay(4.5, 5.2, 0.0, 0.0));
  EXPECT_EQ(kInf, map.castRay(-20.0, 5.2, 0.0, 19.9)) << "the grid is beyond max_range";
  EXPECT_NEAR(20.0, map.castRay(-20.0, 5.2, 0.0, 20.1), kEps);
  EXPECT_TRUE(std::isnan(map.castRay(4.5, 5.2, 0.0, -1.0)));
  EXPECT_TRUE(std::isnan(map.castRay(4.5, 5.2, 0.0, std::nan(""))));
  EXPECT_TRUE(std::isnan(map.castRay(std::nan(""), 5.2, 0.0, 10.0)));
  EXPECT_TRUE(std::isnan(map.castRay(4.5, 5.2, kInf, 10.0)));
}

TEST(OccupancyImage, OriginOffset)
{
  const double ox = -3.25, oy = 2.0;
  const OccupancyImage map = room(makeOrigin(ox, oy, 0.0));
  EXPECT_TRUE(map.occupied(ox + 0.2, oy + 5.0));
  EXPECT_FALSE(map.occupied(0.2, 5.0));
  for (int k = 0; k < 16; ++k)
  {
    const double a = k * M_PI / 8 + 0.1;
    EXPECT_NEAR(boxDistance(4.3, 5.2, a, 0.5, 9.5), map.castRay(ox + 4.3, oy + 5.2, a, 100.0), kEps);
  }
}

TEST(OccupancyImage, OriginYaw)
{
  // The grid's x axis points along world heading yaw; a point p in grid metres is at origin + R(yaw) p.
  for (const double yaw : { 0.7, M_PI / 2, -2.5, M_PI })
  {
    const MapOrigin o = makeOrigin(1.0, -2.0, yaw);
    const OccupancyImage map = room(o);
    const double c = std::cos(yaw), s = std::sin(yaw);
    const double wx = o.x + c * 4.3 - s * 5.2;
    const double wy = o.y + s * 4.3 + c * 5.2;
    EXPECT_FALSE(map.occupied(wx, wy));
    EXPECT_TRUE(map.occupied(o.x + c * 0.25 - s * 5.0, o.y + s * 0.25 + c * 5.0)) << "in the west wall";
    EXPECT_NEAR(5.2, map.castRay(wx, wy, yaw, 100.0), 1e-8) << "along the grid's +x, yaw " << yaw;
    EXPECT_NEAR(4.3, map.castRay(wx, wy, yaw + M_PI / 2, 100.0), 1e-8) << "along the grid's +y, yaw " << yaw;
    EXPECT_NEAR(3.8, map.castRay(wx, wy, yaw + M_PI, 100.0), 1e-8);
    EXPECT_NEAR(4.7, map.castRay(wx, wy, yaw - M_PI / 2, 100.0), 1e-8);
    for (int k = 0; k < 8; ++k)
    {
      const double local = M_PI / 8 + k * M_PI / 4;
      EXPECT_NEAR(boxDistance(4.3, 5.2, local, 0.5, 9.5), map.castRay(wx, wy, local + yaw, 100.0), 1e-8);
    }
    const Eigen::Vector2d centre = map.cellCenter(10, 10);
    EXPECT_NEAR(o.x + c * 5.25 - s * 5.25, centre.x(), kEps);
    EXPECT_NEAR(o.y + s * 5.25 + c * 5.25, centre.y(), kEps);
  }
}

TEST(OccupancyImage, MatchesReferenceOnRandomGrids)
{
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial)
  {
    GridBuilder g(31, 17, kFree);
    for (auto& v : g.cells)
    {
      const double u = unit(rng);
      v = u < 0.08 ? kOcc : (u < 0.2 ? kUnk : kFree);
    }
    const MapOrigin o = makeOrigin(-5.0 + 10.0 * unit(rng), -5.0 + 10.0 * unit(rng), trial % 2 ? 0.0 : 6.0 * unit(rng));
    const OccupancyImage map = g.build(0.05 + 0.2 * unit(rng), o);
    const double w = map.width() * map.resolution(), h = map.height() * map.resolution();
    for (int k = 0; k < 200; ++k)
    {
      // Starts inside and around the grid, in grid metres, then to the world.
      const double gx = -0.3 * w + 1.6 * w * unit(rng), gy = -0.3 * h + 1.6 * h * unit(rng);
      const double x = o.x + std::cos(o.yaw) * gx - std::sin(o.yaw) * gy;
      const double y = o.y + std::sin(o.yaw) * gx + std::cos(o.yaw) * gy;
      const double a = -M_PI + 2.0 * M_PI * unit(rng);
      const double max_range = k % 3 ? kInf : 2.0 * w * unit(rng);
      const double expected = referenceCast(map, x, y, a, max_range);
      const double actual = map.castRay(x, y, a, max_range);
      if (std::isinf(expected))
        ASSERT_EQ(kInf, actual) << "trial " << trial << " ray " << k;
      else
        ASSERT_NEAR(expected, actual, 1e-9) << "trial " << trial << " ray " << k;
    }
  }
}
