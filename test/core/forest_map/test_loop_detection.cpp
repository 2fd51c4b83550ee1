// Loop detection within a run (core::LoopDetector): the recent part of the map displaced from the old part by the
// drift is found after its confirmations, with the trees that are one; no loop where the trees already agree, where
// the recent trees are new, or where the stand is a plantation whose rows repeat.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/forest_map/loop_detection.h"

using rbpf_slam::core::Landmark;
using rbpf_slam::core::LandmarkMap;
using rbpf_slam::core::LoopClosure;
using rbpf_slam::core::LoopDetector;
using rbpf_slam::core::Pose2;

namespace
{
const Eigen::Vector2d kAround(10.0, 10.0);  ///< where the robot is on its revisit

Landmark tree(int id, const Eigen::Vector2d& at, double radius, double first, double last)
{
  Landmark l;
  l.id = id;
  l.mean = at;
  l.radius = radius;
  l.radius_variance = 0.01 * 0.01;
  l.covariance = 0.05 * 0.05 * Eigen::Matrix2d::Identity();
  l.provisional = false;
  l.observations = 20;
  l.first_seen = first;
  l.last_seen = last;
  return l;
}

std::vector<Landmark> randomStand(int n, unsigned seed)
{
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(0.0, 60.0), rad(0.08, 0.35);
  std::vector<Landmark> trees;
  while (static_cast<int>(trees.size()) < n)
  {
    const Eigen::Vector2d p(pos(rng), pos(rng));
    bool clear = true;
    for (const Landmark& o : trees)
      clear = clear && (o.mean - p).norm() > 2.5;
    if (clear)
      trees.push_back(tree(static_cast<int>(trees.size()), p, rad(rng), 5.0, 40.0));
  }
  return trees;
}

/** The old stand, and the @p n old trees nearest to @p around mapped again as new trees, carried by @p drift.inverse(). */
LandmarkMap revisited(const std::vector<Landmark>& old, const Eigen::Vector2d& around, int n, const Pose2& drift)
{
  LandmarkMap map;
  std::vector<Landmark> sorted = old;
  for (const Landmark& l : old)
    map.add(l);
  std::sort(sorted.begin(), sorted.end(), [&](const Landmark& a, const Landmark& b) {
    return (a.mean - around).squaredNorm() < (b.mean - around).squaredNorm();
  });
  const Pose2 inv = drift.inverse();
  for (int i = 0; i < n; ++i)
  {
    Eigen::Vector2d p;
    inv.transformPoint(sorted[i].mean.x(), sorted[i].mean.y(), &p.x(), &p.y());
    map.add(tree(1000 + sorted[i].id, p, sorted[i].radius, 190.0, 199.0));
  }
  return map;
}
}  // namespace

TEST(LoopDetection, ADriftedRevisitIsFoundAfterItsConfirmationsWithTheTreesThatAreOne)
{
  const std::vector<Landmark> old = randomStand(40, 3);
  const Pose2 drift(1.5, -1.0, 0.08);
  const LandmarkMap map = revisited(old, Eigen::Vector2d(10.0, 10.0), 10, drift);
  LoopDetector detector;
  LoopClosure c;
  for (int k = 0; k < 3; ++k)
  {
    c = detector.search(map, 200.0 + k, kAround);
    EXPECT_EQ(c.found, k == 2) << c.reason;
    EXPECT_EQ(c.agreeing, k + 1);
  }
  EXPECT_EQ(c.recent, 10);
  EXPECT_EQ(c.old, 40);
  EXPECT_GE(c.inliers, 9);
  EXPECT_NEAR(c.correction.x, drift.x, 0.1);
  EXPECT_NEAR(c.correction.y, drift.y, 0.1);
  EXPECT_NEAR(c.correction.theta, drift.theta, 0.01);
  ASSERT_GE(c.merged.size(), 9u);
  for (const auto& m : c.merged)
    EXPECT_EQ(m.first, 1000 + m.second) << "a recent tree merged with another tree than the one it is";
  // Applied, the detector starts counting again.
  detector.reset();
  EXPECT_FALSE(detector.search(map, 203.0, kAround).found);
}

TEST(LoopDetection, NoLoopWhereTheTreesAgreeOrTheRecentTreesAreNew)
{
  const std::vector<Landmark> old = randomStand(40, 3);
  LoopDetector agree;
  const LandmarkMap same = revisited(old, Eigen::Vector2d(10.0, 10.0), 10, Pose2(0.05, 0.0, 0.0));
  for (int k = 0; k < 4; ++k)
    EXPECT_FALSE(agree.search(same, 200.0 + k, kAround).found);
  EXPECT_NE(agree.search(same, 210.0, kAround).reason.find("already lie"), std::string::npos);

  // Recent trees from another stand: nothing to close.
  LandmarkMap other;
  for (const Landmark& l : old)
    other.add(l);
  for (const Landmark& l : randomStand(10, 17))
    other.add(tree(1000 + l.id, l.mean + Eigen::Vector2d(80.0, 0.0), l.radius, 190.0, 199.0));
  LoopDetector fresh;
  for (int k = 0; k < 4; ++k)
    EXPECT_FALSE(fresh.search(other, 200.0 + k, Eigen::Vector2d(110.0, 30.0)).found);
}

TEST(LoopDetection, PlantationRowsThatRepeatGiveNoLoop)
{
  // Trees of one radius every 4 m in rows 4 m apart: a block of them seen again fits many shifts equally well.
  std::vector<Landmark> old;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j)
      old.push_back(tree(static_cast<int>(old.size()), Eigen::Vector2d(4.0 * i, 4.0 * j), 0.15, 5.0, 40.0));
  const LandmarkMap map = revisited(old, Eigen::Vector2d(18.0, 18.0), 9, Pose2(1.2, 0.8, 0.0));
  LoopDetector detector;
  for (int k = 0; k < 5; ++k)
  {
    const LoopClosure c = detector.search(map, 200.0 + k, kAround);
    EXPECT_FALSE(c.found) << "a false loop in rows: correction " << c.correction.x << " " << c.correction.y;
  }
}
