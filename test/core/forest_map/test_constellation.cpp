// Global relocalization by constellation: the transform from the trunks seen to a saved map is found from
// positions and radii alone, refused where the stand is ambiguous or unknown.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/forest_map/stand_test_util.h"

#include "rbpf_slam/core/forest_map/constellation.h"

using namespace rbpf_slam::core;

using rbpf_slam::test::randomStand;

namespace
{

/** The trees within @p range of @p pose (map frame), in the robot's frame, with noise. */
std::vector<TrunkPoint> seenFrom(const std::vector<Landmark>& trees, const Pose2& pose, double range, unsigned seed)
{
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.03), rnoise(0.0, 0.015);
  std::vector<TrunkPoint> seen;
  const Pose2 inv = pose.inverse();
  for (const Landmark& l : trees)
  {
    if ((l.mean - Eigen::Vector2d(pose.x, pose.y)).norm() > range)
      continue;
    TrunkPoint t;
    inv.transformPoint(l.mean.x(), l.mean.y(), &t.center.x(), &t.center.y());
    t.center += Eigen::Vector2d(noise(rng), noise(rng));
    t.radius = l.radius + rnoise(rng);
    t.radius_sigma = 0.02;
    seen.push_back(t);
  }
  return seen;
}
}  // namespace

TEST(Constellation, FindsThePoseInARandomStandDespiteMissesAndClutter)
{
  const std::vector<Landmark> trees = randomStand(150, 60.0, 3);
  const ConstellationMatcher matcher(trees);
  EXPECT_GT(matcher.mapPairs(), 1000u);
  int found = 0;
  for (unsigned k = 0; k < 10; ++k)
  {
    const Pose2 truth(15.0 + 3.0 * k, 20.0 + 2.0 * k, -2.5 + 0.6 * k);
    std::vector<TrunkPoint> seen = seenFrom(trees, truth, 12.0, 10 + k);
    ASSERT_GE(seen.size(), 8u);
    seen.erase(seen.begin());  // a trunk hidden
    TrunkPoint bush;           // two trunk-like objects that are not in the map
    bush.center = Eigen::Vector2d(2.0, 1.0);
    bush.radius = 0.1;
    bush.radius_sigma = 0.02;
    seen.push_back(bush);
    bush.center = Eigen::Vector2d(-4.0, 6.5);
    seen.push_back(bush);
    const ConstellationResult r = matcher.match(seen);
    ASSERT_FALSE(r.hypotheses.empty()) << r.reason;
    const Pose2& t = r.hypotheses.front().transform;  // robot frame -> map: the robot's pose
    if (!r.accepted)
      continue;
    ++found;
    EXPECT_NEAR(t.x, truth.x, 0.05) << k;
    EXPECT_NEAR(t.y, truth.y, 0.05) << k;
    EXPECT_NEAR(std::remainder(t.theta - truth.theta, 2 * M_PI), 0.0, 0.01) << k;
    EXPECT_GE(r.hypotheses.front().inliers, static_cast<int>(seen.size()) - 2);
  }
  EXPECT_EQ(found, 10);
}

TEST(Constellation, RefusesAnUnknownStand)
{
  const std::vector<Landmark> map = randomStand(150, 60.0, 3);
  const std::vector<Landmark> elsewhere = randomStand(150, 60.0, 99);
  const ConstellationMatcher matcher(map);
  for (unsigned k = 0; k < 10; ++k)
  {
    const ConstellationResult r = matcher.match(seenFrom(elsewhere, Pose2(20.0 + 2.0 * k, 30.0, 0.3 * k), 12.0, k));
    EXPECT_FALSE(r.accepted) << k << ": " << r.hypotheses.front().inliers << " inliers";
  }
}

TEST(Constellation, RefusesARegularPlantationAsAmbiguous)
{
  // Rows 4 m apart, trees 3 m apart, all of one radius: every shift by a row or a tree explains as much.
  std::vector<Landmark> rows;
  for (int i = 0; i < 12; ++i)
    for (int j = 0; j < 12; ++j)
    {
      Landmark l;
      l.mean = Eigen::Vector2d(3.0 * i, 4.0 * j);
      l.radius = 0.15;
      l.radius_variance = 1e-4;
      l.provisional = false;
      l.id = 12 * i + j;
      rows.push_back(l);
    }
  const ConstellationMatcher matcher(rows);
  const ConstellationResult r = matcher.match(seenFrom(rows, Pose2(16.5, 22.0, 0.0), 10.0, 1));
  EXPECT_FALSE(r.accepted);
  EXPECT_NE(r.reason.find("ambiguous"), std::string::npos) << r.reason;
}

TEST(Constellation, RefusesAMapDenserThanAForestBeforeIndexingIt)
{
  // 20000 trees 0.63 m apart (2.5 per square metre): 49 million pairs within 25 m. Refused, by a message that says
  // why, before the index is built (counted without storing: seconds, not minutes and a gigabyte).
  std::vector<Landmark> dense;
  for (int i = 0; i < 20000; ++i)
  {
    Landmark l;
    l.mean = Eigen::Vector2d(0.632 * (i % 141), 0.632 * (i / 141));
    l.radius = 0.1;
    l.provisional = false;
    dense.push_back(l);
  }
  try
  {
    ConstellationMatcher m(dense, ConstellationConfig());
    FAIL() << "a 2.5 trees per square metre map was indexed";
  }
  catch (const std::invalid_argument& e)
  {
    const std::string what = e.what();
    EXPECT_NE(what.find("20000 trees make more than 20000000 pairs"), std::string::npos) << what;
    EXPECT_NE(what.find("2.5 trees per square metre"), std::string::npos) << what;
  }
  // The same number of trees at a forest's density (0.1 per square metre) is indexed.
  for (Landmark& l : dense)
    l.mean *= 5.0;
  EXPECT_NO_THROW(ConstellationMatcher(dense, ConstellationConfig()));
}

TEST(Constellation, TheLikelihoodOfATransformCountsItsDistancesAndWhatItLeavesUnexplained)
{
  const std::vector<Landmark> trees = randomStand(150, 60.0, 3);
  ConstellationConfig config;
  const ConstellationMatcher matcher(trees, config);
  const Pose2 truth(25.0, 30.0, 0.8);
  std::vector<TrunkPoint> seen = seenFrom(trees, truth, 12.0, 5);
  for (TrunkPoint& t : seen)  // exact positions: every distance 0
  {
    Eigen::Vector2d exact = t.center;
    double best = 1e9;
    for (const Landmark& l : trees)
    {
      Eigen::Vector2d local;
      truth.inverse().transformPoint(l.mean.x(), l.mean.y(), &local.x(), &local.y());
      if ((local - t.center).norm() < best)
      {
        best = (local - t.center).norm();
        exact = local;
      }
    }
    t.center = exact;
  }
  ASSERT_GE(seen.size(), 8u);
  EXPECT_NEAR(matcher.logLikelihood(seen, truth), 0.0, 1e-9);
  // A trunk the map does not hold costs what one at the gate does: 3 sigma, -4.5.
  std::vector<TrunkPoint> with_bush = seen;
  TrunkPoint bush = seen.front();
  bush.center += Eigen::Vector2d(1.3, 0.9);
  with_bush.push_back(bush);
  ASSERT_EQ(matcher.inliers(with_bush, truth), static_cast<int>(seen.size()));
  EXPECT_NEAR(matcher.logLikelihood(with_bush, truth), -4.5, 1e-9);
  // Shifted 0.1 m: every trunk within the gate, each costing 0.5 (0.1 / sigma)^2 with sigma = gate / 3.
  const Pose2 shifted = Pose2(0.1 * std::cos(0.3), 0.1 * std::sin(0.3), 0.0) * truth;
  ASSERT_EQ(matcher.inliers(seen, shifted), static_cast<int>(seen.size()));
  const double sigma = config.inlier_gate / 3.0;
  EXPECT_NEAR(matcher.logLikelihood(seen, shifted), -0.5 * seen.size() * 0.01 / (sigma * sigma), 1e-6);
  // Far off: nothing explained.
  EXPECT_NEAR(matcher.logLikelihood(seen, Pose2(500.0, 500.0, 0.0)), -4.5 * seen.size(), 1e-9);
}
