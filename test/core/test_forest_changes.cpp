// Change between a saved map and a later visit: felled, new and changed trees, and what is not a change.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/forest_changes.h"

using namespace rbpf_slam::core;

namespace
{
Landmark tree(int id, double x, double r)
{
  Landmark l;
  l.id = id;
  l.mean = Eigen::Vector2d(x, 0.0);
  l.radius = r;
  l.radius_variance = 0.002 * 0.002;
  l.provisional = false;
  l.observations = 40;
  return l;
}
}  // namespace

TEST(ForestChanges, FelledNewAndGrownTreesAreReportedWithTheirEvidence)
{
  std::vector<Landmark> before = { tree(0, 0.0, 0.20), tree(1, 5.0, 0.15), tree(2, 10.0, 0.30), tree(3, 15.0, 0.1) };
  before[3].provisional = true;  // a glimpse of the last visit
  std::vector<Landmark> after;
  Landmark kept = before[0];  // seen again, the same radius
  kept.visit_radius = 0.201;
  kept.visit_radius_variance = 0.002 * 0.002;
  kept.visit_observations = 30;
  after.push_back(kept);
  Landmark grown = before[2];  // 2 cm more radius
  grown.visit_radius = 0.32;
  grown.visit_radius_variance = 0.002 * 0.002;
  grown.visit_observations = 30;
  after.push_back(grown);
  Landmark planted = tree(7, 20.0, 0.06);
  planted.visit_observations = 25;
  after.push_back(planted);
  Landmark glimpse = tree(8, 25.0, 0.06);  // seen too few times to be called new
  glimpse.visit_observations = 3;
  after.push_back(glimpse);
  Landmark unseen = tree(9, 30.0, 0.06);  // not confirmed
  unseen.provisional = true;
  unseen.visit_observations = 30;
  after.push_back(unseen);

  const std::vector<TreeChange> c = detectChanges(before, after);
  ASSERT_EQ(c.size(), 3u);
  EXPECT_EQ(c[0].kind, ChangeKind::kFelled);
  EXPECT_EQ(c[0].id, 1);
  EXPECT_DOUBLE_EQ(c[0].dbh_before, 0.30);
  EXPECT_TRUE(std::isnan(c[0].dbh_after));
  EXPECT_EQ(c[1].kind, ChangeKind::kChanged);
  EXPECT_EQ(c[1].id, 2);
  EXPECT_NEAR(c[1].dbh_after - c[1].dbh_before, 0.04, 1e-12);
  EXPECT_NE(c[1].evidence.find("+20.0 mm"), std::string::npos) << c[1].evidence;
  EXPECT_EQ(c[2].kind, ChangeKind::kNew);
  EXPECT_EQ(c[2].id, 7);
  EXPECT_EQ(std::string(toString(c[2].kind)), "new");
}

TEST(ForestChanges, AGrowthWithinItsUncertaintyIsNoChange)
{
  Landmark b = tree(0, 0.0, 0.20);
  b.radius_variance = 0.005 * 0.005;
  Landmark a = b;
  a.visit_radius = 0.21;  // 1 cm: within 3 sigma (7 mm) + 5 mm
  a.visit_radius_variance = 0.003 * 0.003;
  a.visit_observations = 50;
  EXPECT_TRUE(detectChanges({ b }, { a }).empty());
  a.visit_radius = 0.24;
  EXPECT_EQ(detectChanges({ b }, { a }).size(), 1u);
}

TEST(ForestChanges, ATreeRemovedAndMadeAgainBesideItselfIsNoChange)
{
  const Landmark saved = tree(3, 10.0, 0.15);  // its saved position was 0.4 m off
  Landmark again = tree(12, 10.4, 0.155);
  again.visit_observations = 40;
  EXPECT_TRUE(detectChanges({ saved }, { again }).empty());
  Landmark sapling = tree(12, 10.4, 0.05);  // a thin tree planted where a thick one was felled: both are reported
  sapling.visit_observations = 40;
  EXPECT_EQ(detectChanges({ saved }, { sapling }).size(), 2u);
}
