// Ground model and height band on synthetic clouds whose ground is known.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/extraction/ground_model.h"

using rbpf_slam::core::GroundModel;
using rbpf_slam::core::packCell;
using rbpf_slam::core::selectHeightBand;

namespace
{
/** Ground points every 0.25 m over [x0, x1] x [y0, y1] at height h(x, y). */
template <typename H>
void addGround(std::vector<Eigen::Vector3d>* pts, double x0, double x1, double y0, double y1, H h)
{
  for (double x = x0; x < x1; x += 0.25)
    for (double y = y0; y < y1; y += 0.25)
      pts->emplace_back(x, y, h(x, y));
}
}  // namespace

TEST(GroundModel, FlatGroundIsItsHeightInEveryQuadrant)
{
  std::vector<Eigen::Vector3d> pts;
  addGround(&pts, -10.0, 10.0, -10.0, 10.0, [](double, double) { return -1.8; });
  GroundModel ground(1.0, 0.0, 0.35);
  ground.build(pts);
  for (const auto& xy : { Eigen::Vector2d(5.3, 2.1), Eigen::Vector2d(-5.3, 2.1), Eigen::Vector2d(-5.3, -7.9),
                          Eigen::Vector2d(4.0, -0.5) })
    EXPECT_NEAR(ground.heightAt(xy.x(), xy.y()), -1.8, 1e-6) << xy.transpose();
}

TEST(GroundModel, ACellWithoutGroundTakesItsNeighboursLowest)
{
  // Ground at -1.8 around, but the cell [3, 4) x [0, 1) holds only a trunk's points from -1.0 up.
  std::vector<Eigen::Vector3d> pts;
  addGround(&pts, 0.0, 8.0, -4.0, 4.0, [](double, double) { return -1.8; });
  pts.erase(std::remove_if(pts.begin(), pts.end(), [](const Eigen::Vector3d& p) {
              return p.x() >= 3.0 && p.x() < 4.0 && p.y() >= 0.0 && p.y() < 1.0;
            }),
            pts.end());
  for (double z = -1.0; z < 1.0; z += 0.1)
    pts.emplace_back(3.5, 0.5, z);
  GroundModel ground(1.0, 0.0, 0.35);
  ground.build(pts);
  EXPECT_NEAR(ground.heightAt(3.5, 0.5), -1.8, 1e-6);
}

TEST(GroundModel, SlopeCapKeepsBushTopsFromLiftingTheGround)
{
  // A bush 2 m wide whose top (about 1 m above a ground at -1.8) is all the sensor sees there: with the sensor's
  // height known, the ground 6 m away is at most -1.8 + 0.1 * 6 = -1.2 high.
  std::vector<Eigen::Vector3d> bush;
  for (double x = 5.0; x < 7.0; x += 0.1)
    for (double y = -1.0; y < 1.0; y += 0.1)
      bush.emplace_back(x, y, -0.6 + 0.2 * std::cos(x + y));
  GroundModel capped(1.0, 1.8, 0.1);
  capped.build(bush);
  EXPECT_NEAR(capped.heightAt(6.0, 0.0), -1.8 + 0.1 * 6.0, 1e-6);
  GroundModel free(1.0, 0.0, 0.1);
  free.build(bush);
  EXPECT_GT(free.heightAt(6.0, 0.0), -0.85);
  // Where there is nothing, there is no ground without the cap.
  EXPECT_TRUE(std::isinf(free.heightAt(20.0, 20.0)));
  EXPECT_NEAR(capped.heightAt(20.0, 0.0), -1.8 + 0.1 * 20.0, 1e-6);
}

TEST(GroundModel, HeightBandFollowsSlopedGround)
{
  // Ground rising 0.15 m per metre; two posts 3 m tall on it, at x = 4 and x = 12.
  std::vector<Eigen::Vector3d> pts;
  const auto h = [](double x, double) { return -1.8 + 0.15 * x; };
  addGround(&pts, 1.0, 15.0, -3.0, 3.0, h);
  for (double x : { 4.0, 12.0 })
    for (double z = 0.0; z < 3.0; z += 0.05)
      pts.emplace_back(x + 0.1, 0.1, h(x, 0.0) + z);
  GroundModel ground(1.0, 1.8, 0.35);
  ground.build(pts);
  const auto band = selectHeightBand(pts, &ground, 0.5, 2.0);
  ASSERT_FALSE(band.empty());
  int near = 0, far = 0;
  for (const auto& p : band)
  {
    const double above = p.z() - h(p.x(), p.y());
    EXPECT_GE(above, 0.5 - 2.0 * 0.15 - 1e-6);  // the lowest of the 3 x 3 cells lies up to two cells' rise lower
    EXPECT_LE(above, 2.0 + 1e-6);
    (p.x() < 8.0 ? near : far)++;
  }
  // Both posts keep about 1.5 m of their height (30 points each); a fixed band would lose the far one.
  EXPECT_GE(near, 25);
  EXPECT_GE(far, 25);
}

TEST(GroundModel, CellKeysOfNegativeIndicesDiffer)
{
  EXPECT_NE(packCell(-1, 0), packCell(0, -1));
  EXPECT_NE(packCell(-1, -1), packCell(1, 1));
  EXPECT_NE(packCell(-1, 5), packCell(0, 5));
  EXPECT_EQ(packCell(-3, -7), packCell(-3, -7));
}

TEST(GroundModel, AFarOffPointGivesTheSameGroundNearTheSensor)
{
  // A stray return kilometres away spreads the sweep over millions of cells: the model then keeps its cells in a
  // hash map instead of a grid, with the same heights.
  std::vector<Eigen::Vector3d> pts;
  addGround(&pts, -6.0, 6.0, -6.0, 6.0, [](double x, double y) { return -1.8 + 0.1 * std::sin(x) * std::cos(y); });
  for (double z = -1.0; z < 1.0; z += 0.1)
    pts.emplace_back(2.5, -3.5, z);
  std::vector<Eigen::Vector3d> with_stray = pts;
  with_stray.emplace_back(4000.0, -3000.0, 50.0);
  GroundModel grid(1.0, 1.8, 0.35), sparse(1.0, 1.8, 0.35);
  grid.build(pts);
  sparse.build(with_stray);
  for (std::size_t i = 0; i < pts.size(); i += 7)
    EXPECT_EQ(grid.heightUnder(i, pts[i].x(), pts[i].y()), sparse.heightUnder(i, pts[i].x(), pts[i].y())) << i;
  for (double x = -7.0; x < 7.0; x += 0.9)
    EXPECT_EQ(grid.heightAt(x, 0.3 * x), sparse.heightAt(x, 0.3 * x)) << x;
  EXPECT_EQ(sparse.heightAt(4000.2, -2999.9), 50.0f);
}

namespace
{
/**
 * A sensor 1.8 m up on ground rising 0.1 m per metre along x (seen as the lidar sees it: no ground within 7 m), a
 * stem 3 m ahead whose lowest return is 1 m up, and shrubs whose tops are all the sensor sees in a few cells.
 */
std::vector<Eigen::Vector3d> groundHiddenNearTheSensor()
{
  const auto h = [](double x, double) { return -1.8 + 0.1 * x; };
  std::vector<Eigen::Vector3d> pts;
  for (double a = 0.0; a < 2.0 * M_PI; a += 0.01)
    for (double r = 7.0; r < 16.0; r += 0.5)
    {
      const double x = r * std::cos(a), y = r * std::sin(a);
      if (!(x > 8.0 && x < 12.0 && std::abs(y) < 2.0))  // under the shrub and around it
        pts.emplace_back(x, y, h(x, y));
    }
  for (double z = 1.0; z < 3.0; z += 0.1)
    for (double a = -1.0; a < 1.0; a += 0.2)
      pts.emplace_back(3.0 + 0.15 * std::cos(a + M_PI), 0.15 * std::sin(a + M_PI), h(3.0, 0.0) + z);
  for (double x = 9.0; x < 11.0; x += 0.1)
    for (double y = -1.0; y < 1.0; y += 0.1)
      pts.emplace_back(x, y, h(x, y) + 0.9);  // a shrub's top hides the ground under it
  return pts;
}
}  // namespace

TEST(GroundModel, TheSeenGroundsPlaneGivesTheGroundWhereTheSensorSeesNone)
{
  const std::vector<Eigen::Vector3d> pts = groundHiddenNearTheSensor();
  GroundModel plane(1.0, 1.8, 0.35, 0.5);
  plane.build(pts);
  Eigen::Vector2d slope;
  ASSERT_TRUE(plane.groundPlane(&slope));
  EXPECT_NEAR(slope.x(), 0.1, 0.01);
  EXPECT_NEAR(slope.y(), 0.0, 0.01);
  // Under the stem, under the shrub and where nothing is seen: the ground, not the lowest return.
  EXPECT_NEAR(plane.heightAt(3.0, 0.0), -1.5, 0.05);
  EXPECT_NEAR(plane.heightAt(10.0, 0.0), -0.8, 0.05);
  EXPECT_NEAR(plane.heightAt(-2.0, 1.0), -2.0, 0.05);
  // Where the ground is seen, it is kept (the lowest of the 3 x 3 cells around).
  EXPECT_NEAR(plane.heightAt(12.0, 5.0), -1.8 + 0.1 * 11.0, 0.15);
  // Without the plane, the stem's lowest return is the ground at its foot (under the slope's cap, 1.05 m up).
  GroundModel capped(1.0, 1.8, 0.35);
  capped.build(pts);
  EXPECT_FALSE(capped.groundPlane(&slope));
  EXPECT_GT(capped.heightAt(3.0, 0.0), -0.8);
}

TEST(GroundModel, NoPlaneWithoutTheSensorsHeight)
{
  GroundModel ground(1.0, 0.0, 0.35, 0.5);
  ground.build(groundHiddenNearTheSensor());
  Eigen::Vector2d slope(7.0, 7.0);
  EXPECT_FALSE(ground.groundPlane(&slope));
  EXPECT_EQ(slope, Eigen::Vector2d(7.0, 7.0));
  EXPECT_TRUE(std::isinf(ground.heightAt(30.0, 30.0)));
}

TEST(GroundModel, WithNoGroundSeenThePlaneIsTheMountsLevel)
{
  // Only a bush's top (about 1 m above the ground at -1.8): the plane stays level through the ground under the
  // sensor, and the bush does not lift it.
  std::vector<Eigen::Vector3d> bush;
  for (double x = 5.0; x < 7.0; x += 0.1)
    for (double y = -1.0; y < 1.0; y += 0.1)
      bush.emplace_back(x, y, -0.6 + 0.2 * std::cos(x + y));
  GroundModel ground(1.0, 1.8, 0.1, 0.5);
  ground.build(bush);
  Eigen::Vector2d slope;
  ASSERT_TRUE(ground.groundPlane(&slope));
  EXPECT_NEAR(slope.norm(), 0.0, 1e-9);
  EXPECT_NEAR(ground.heightAt(6.0, 0.0), -1.8, 1e-6);
  EXPECT_NEAR(ground.heightAt(20.0, 0.0), -1.8, 1e-6);
}
