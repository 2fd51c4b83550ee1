// Change between a saved map and a later visit: felled, new and changed trees, and what is not a change.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/forest_map/forest_changes.h"

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
  // Made again where the saved map's viewpoints did not see (e.g. hidden behind its old self): still the same tree.
  std::vector<Viewpoint> far_away(1);
  far_away[0].sensor = Pose2(10.0, 40.0, 0.0);
  EXPECT_TRUE(detectChanges({ saved }, { again }, ChangeConfig(), far_away).empty());
  const std::vector<TreeChange> felled = detectChanges({ saved }, { sapling }, ChangeConfig(), far_away);
  ASSERT_EQ(felled.size(), 1u) << "the sapling, where the map had not looked, is not reported new";
  EXPECT_EQ(felled[0].kind, ChangeKind::kFelled);
}

TEST(ForestChanges, ATreeIsNewOnlyWhereTheSavedMapHadItsPlaceInView)
{
  // The saved map was made driving along y = 0 from x = 0 to 10 with a 360-degree lidar of 1-12 m.
  std::vector<Viewpoint> viewpoints;
  ViewpointLog log;
  for (double x = 0.0; x <= 10.0; x += 0.25)
    log.add(Pose2(x, 0.0, 0.0), VisibilityScope(1.0, 12.0, 2.0 * M_PI));
  viewpoints = log.viewpoints();
  EXPECT_EQ(viewpoints.size(), 11u) << "one viewpoint per metre of ground";
  Landmark screen = tree(1, 5.0, 0.6);  // a thick saved trunk at (5, 4): what stands behind it was hidden
  screen.mean = Eigen::Vector2d(5.0, 4.0);
  Landmark aside = tree(0, 3.0, 0.2);
  aside.mean.y() = 15.0;
  const std::vector<Landmark> before = { aside, screen };
  auto planted = [](int id, double x, double y) {
    Landmark l = tree(id, x, 0.06);
    l.mean = Eigen::Vector2d(x, y);
    l.visit_observations = 30;
    return l;
  };
  // In view from the path, 6 m off it: new. 20 m off the path: the saved map never saw it, not reported.
  // Right behind the thick trunk: counted only from where it was in the clear.
  const Landmark seen = planted(10, 6.0, -6.0), far = planted(11, 6.0, 20.0), hidden = planted(12, 5.0, 8.0);
  EXPECT_GE(timesInView(viewpoints, before, seen.mean, 0.06, 0.5), 10);
  EXPECT_EQ(timesInView(viewpoints, before, far.mean, 0.06, 0.5), 0);
  const int behind = timesInView(viewpoints, before, hidden.mean, 0.06, 0.5);
  EXPECT_LT(behind, timesInView(viewpoints, { aside }, hidden.mean, 0.06, 0.5))
      << "the saved trunk hides the spot behind it from some viewpoints";
  EXPECT_EQ(timesInView(viewpoints, before, seen.mean, 0.06, 0.5, 3), 3) << "stops at enough";

  const std::vector<TreeChange> with = detectChanges(before, { before[0], screen, seen, far }, ChangeConfig(),
                                                     viewpoints);
  ASSERT_EQ(with.size(), 1u);
  EXPECT_EQ(with[0].id, 10);
  EXPECT_NE(with[0].evidence.find("in view from at least 3 viewpoints"), std::string::npos) << with[0].evidence;
  // Without viewpoints (a surveyed map) every place counts as looked at.
  EXPECT_EQ(detectChanges(before, { before[0], screen, seen, far }).size(), 2u);
}

TEST(ForestChanges, APartialViewKeepsAViewpointPerHeading)
{
  ViewpointLog log;
  const VisibilityScope front(0.5, 30.0, M_PI);
  EXPECT_TRUE(log.add(Pose2(0.2, 0.2, 0.0), front));
  EXPECT_FALSE(log.add(Pose2(0.7, 0.4, 0.1), front)) << "the same cell and heading";
  EXPECT_TRUE(log.add(Pose2(0.7, 0.4, M_PI), front)) << "the same cell looking back sees other ground";
  EXPECT_FALSE(log.add(Pose2(NAN, 0.0, 0.0), front));
  log.reset(std::vector<Viewpoint>(1, log.viewpoints()[0]));
  EXPECT_EQ(log.viewpoints().size(), 1u);
  EXPECT_TRUE(log.add(Pose2(0.7, 0.4, M_PI), front));
}
