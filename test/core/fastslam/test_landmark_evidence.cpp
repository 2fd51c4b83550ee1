// Landmark existence on synthetic maps: the expected-miss test (scope, field of view, occlusion), evidence and
// removal.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "rbpf_slam/core/fastslam/data_association.h"
#include "rbpf_slam/core/fastslam/landmark_evidence.h"
#include "rbpf_slam/core/fastslam/landmark_map.h"
#include "rbpf_slam/core/fastslam/visibility_scope.h"

using namespace rbpf_slam::core;

namespace
{
Landmark trunkAt(double x, double y, double radius = 0.2, bool provisional = false)
{
  Landmark l;
  l.mean = Eigen::Vector2d(x, y);
  l.covariance = 0.01 * Eigen::Matrix2d::Identity();
  l.radius = radius;
  l.evidence = 1.0;
  l.observations = provisional ? 1 : 5;
  l.provisional = provisional;
  return l;
}

/** Candidates of @p map from the origin (heading 0) that took no observation. */
DataAssociation unseen(const LandmarkMap& map, const VisibilityScope& scope)
{
  DataAssociation a;
  a.selectCandidates(map, Pose2(), Pose2(), scope);
  a.associate(map, {}, {});
  return a;
}
}  // namespace

TEST(LandmarkEvidence, OcclusionNeedsATrunkClearlyInFrontCoveringTheBearing)
{
  // A 0.2 m trunk at 4 m shadows (0.2 + 0.15) / 4 = 0.0875 rad either side of its bearing.
  EXPECT_TRUE(occludedBy(8.0, 0.08, 0.2, 4.0, 0.0, 0.2));
  EXPECT_FALSE(occludedBy(8.0, 0.095, 0.2, 4.0, 0.0, 0.2));
  EXPECT_TRUE(occludedBy(8.0, M_PI - 0.01, 0.2, 4.0, -M_PI + 0.01, 0.2));  // across +-pi
  // Not clearly in front: centres less than the two radii + 0.1 m apart in range (a near-duplicate).
  EXPECT_FALSE(occludedBy(4.45, 0.0, 0.2, 4.0, 0.0, 0.2));
  EXPECT_TRUE(occludedBy(4.55, 0.0, 0.2, 4.0, 0.0, 0.2));
  // The trunk behind never hides the one in front.
  EXPECT_FALSE(occludedBy(4.0, 0.0, 0.2, 8.0, 0.0, 0.2));
}

TEST(LandmarkEvidence, LandmarkHiddenBehindANearerOneIsNotMissed)
{
  LandmarkMap map;
  map.add(trunkAt(4.0, 0.0));  // in front
  map.add(trunkAt(8.0, 0.0));  // straight behind it
  map.add(trunkAt(6.0, 3.0));  // to the side, in full view
  const VisibilityScope scope;
  const DataAssociation a = unseen(map, scope);
  ASSERT_EQ(a.candidates().size(), 3u);
  LandmarkEvidence evidence;
  EXPECT_EQ(evidence.classifyUnseen(a.candidates(), map, 0, scope), MissOutcome::kMissed);
  EXPECT_EQ(evidence.classifyUnseen(a.candidates(), map, 1, scope), MissOutcome::kHidden);
  EXPECT_EQ(evidence.classifyUnseen(a.candidates(), map, 2, scope), MissOutcome::kMissed);
  EXPECT_EQ(evidence.applyMisses(&map, a, scope), 0u);
  EXPECT_EQ(map[0].evidence, 0.0);
  EXPECT_EQ(map[1].evidence, 1.0);
  EXPECT_EQ(map[2].evidence, 0.0);
}

TEST(LandmarkEvidence, LandmarkOutsideTheFieldOfViewIsNotMissed)
{
  // A forward-looking sensor (+-pi/2): candidates reach 0.1 rad further, but only those inside are missed.
  LandmarkMap map;
  const double outside = M_PI / 2 + 0.05, inside = M_PI / 2 - 0.05;
  map.add(trunkAt(5.0 * std::cos(outside), 5.0 * std::sin(outside)));
  map.add(trunkAt(5.0 * std::cos(inside), -5.0 * std::sin(inside)));
  map.add(trunkAt(0.7, 0.0));   // nearer than min_range, within the candidates' margin
  const VisibilityScope scope(1.0, 12.0, M_PI);
  const DataAssociation a = unseen(map, scope);
  ASSERT_EQ(a.candidates().size(), 3u);
  LandmarkEvidence evidence;
  EXPECT_EQ(evidence.classifyUnseen(a.candidates(), map, 0, scope), MissOutcome::kOutOfScope);
  EXPECT_EQ(evidence.classifyUnseen(a.candidates(), map, 1, scope), MissOutcome::kMissed);
  EXPECT_EQ(evidence.classifyUnseen(a.candidates(), map, 2, scope), MissOutcome::kOutOfScope);
  evidence.applyMisses(&map, a, scope);
  EXPECT_EQ(map[0].evidence, 1.0);
  EXPECT_EQ(map[1].evidence, 0.0);
  EXPECT_EQ(map[2].evidence, 1.0);
}

TEST(LandmarkEvidence, ProvisionalLandmarkLeavingTheFarEdgeIsDroppedAConfirmedOneKept)
{
  LandmarkMap map;
  map.add(trunkAt(12.3, 0.0, 0.2, true));   // provisional, just beyond the 12 m ring
  map.add(trunkAt(0.0, 12.3, 0.2, false));  // confirmed, same range
  map.add(trunkAt(-12.3, 0.0, 0.2, true));  // provisional, but outside a forward view: may come back
  EvidenceConfig config;
  LandmarkEvidence evidence(config);
  const VisibilityScope all_round;
  DataAssociation a = unseen(map, all_round);
  EXPECT_EQ(evidence.classifyUnseen(a.candidates(), map, 0, all_round), MissOutcome::kLeavingUnconfirmed);
  EXPECT_EQ(evidence.classifyUnseen(a.candidates(), map, 1, all_round), MissOutcome::kOutOfScope);
  const VisibilityScope forward(1.0, 12.0, M_PI);
  a.selectCandidates(map, Pose2(), Pose2(), forward);
  a.associate(map, {}, {});
  ASSERT_EQ(a.candidates().size(), 2u);  // the one behind is no candidate at all
  // Switched off, the provisional one is only out of scope.
  config.drop_unconfirmed_leaving_scope = false;
  EXPECT_EQ(LandmarkEvidence(config).classifyUnseen(a.candidates(), map, 0, forward), MissOutcome::kOutOfScope);
  EXPECT_EQ(evidence.applyMisses(&map, a, forward), 1u);
  ASSERT_EQ(map.size(), 2u);
  EXPECT_EQ(map[0].mean.x(), -12.3);  // the last landmark moved into the hole
  EXPECT_EQ(map[1].mean.y(), 12.3);
}

TEST(LandmarkEvidence, HitsConfirmAndCapMissesRemove)
{
  EvidenceConfig config;  // hit +1, miss -1, ceiling 6, removed below -1.5, confirmed at 3
  LandmarkEvidence evidence(config);
  Landmark l;
  evidence.initialize(&l);
  EXPECT_EQ(l.observations, 1);
  EXPECT_EQ(l.evidence, 1.0);
  EXPECT_TRUE(l.provisional);
  evidence.recordHit(&l);
  EXPECT_TRUE(l.provisional);
  evidence.recordHit(&l);
  EXPECT_FALSE(l.provisional);
  for (int i = 0; i < 10; ++i)
    evidence.recordHit(&l);
  EXPECT_EQ(l.evidence, 6.0);
  // A landmark seen once, then missed: 1 -> 0 -> -1 -> -2, removed at the third miss.
  LandmarkMap map;
  Landmark once = trunkAt(5.0, 0.0);
  evidence.initialize(&once);
  map.add(once);
  const VisibilityScope scope;
  for (int miss = 1; miss <= 3; ++miss)
  {
    const DataAssociation a = unseen(map, scope);
    EXPECT_EQ(evidence.applyMisses(&map, a, scope), miss == 3 ? 1u : 0u);
  }
  EXPECT_TRUE(map.empty());
}

TEST(LandmarkEvidence, LooksCountOncePerView)
{
  EvidenceConfig config;
  config.view_change = 0.17;
  config.confirm_observations = 3;
  const LandmarkEvidence evidence(config);
  Landmark l = trunkAt(10.0, 0.0, 0.2, true);
  evidence.initialize(&l, Eigen::Vector2d(0.0, 0.0));
  EXPECT_EQ(l.views, 1);
  const double first = l.evidence;
  // A hundred sweeps from within a few centimetres: one view, no more evidence, still provisional.
  for (int i = 0; i < 100; ++i)
    evidence.recordHit(&l, Eigen::Vector2d(0.001 * i, 0.0));
  EXPECT_EQ(l.observations, 101);
  EXPECT_EQ(l.views, 1);
  EXPECT_DOUBLE_EQ(l.evidence, first);
  EXPECT_TRUE(l.provisional);
  // Sideways by 2 m at 10 m (11 degrees): a new view; then closer by a fifth of the range: another.
  evidence.recordHit(&l, Eigen::Vector2d(0.0, 2.0));
  EXPECT_EQ(l.views, 2);
  evidence.recordHit(&l, Eigen::Vector2d(1.8, 2.0));
  EXPECT_EQ(l.views, 3);
  EXPECT_FALSE(l.provisional);
  EXPECT_GT(l.evidence, first);
  // Without a view rule (or without a sensor position) every look counts, as before.
  const LandmarkEvidence every{ EvidenceConfig() };
  Landmark m = trunkAt(10.0, 0.0, 0.2, true);
  every.initialize(&m, Eigen::Vector2d(0.0, 0.0));
  every.recordHit(&m, Eigen::Vector2d(0.0, 0.0));
  every.recordHit(&m);
  EXPECT_EQ(m.views, 3);
  EXPECT_FALSE(m.provisional);
}

TEST(LandmarkEvidence, MissesCountOncePerViewAndOnlyWhereTheTrunkWasSeenFrom)
{
  EvidenceConfig config;
  config.view_change = 0.17;
  LandmarkEvidence evidence(config);
  const VisibilityScope scope(1.0, 30.0, 2.0 * M_PI);
  LandmarkMap map;
  Landmark seen_near = trunkAt(5.0, 0.0);
  seen_near.seen_range = 6.0;   // seen from 6 m at most: at 5 m it is expected
  Landmark seen_far = trunkAt(0.0, 20.0);
  seen_far.seen_range = 8.0;    // predicted at 20 m, beyond where this thin trunk was ever seen
  map.add(seen_near);
  map.add(seen_far);
  const double before = map[0].evidence;
  const DataAssociation a = unseen(map, scope);
  EXPECT_EQ(evidence.classifyUnseen(a.candidates(), map, 0, scope), MissOutcome::kMissed);
  EXPECT_EQ(evidence.classifyUnseen(a.candidates(), map, 1, scope), MissOutcome::kOutOfScope);
  // Fifty sweeps from the same place: one miss.
  for (int i = 0; i < 50; ++i)
    evidence.applyMisses(&map, a, scope, nullptr, Eigen::Vector2d(0.0, 0.0));
  EXPECT_DOUBLE_EQ(map[0].evidence, before - config.miss * scope.detection_probability);
  EXPECT_DOUBLE_EQ(map[1].evidence, before);
  // The old rule (every sweep a look) would have removed it.
  LandmarkEvidence every{ EvidenceConfig() };
  LandmarkMap old_map;
  old_map.add(seen_near);
  const DataAssociation b = unseen(old_map, scope);
  for (int i = 0; i < 50 && old_map.size() > 0; ++i)
    every.applyMisses(&old_map, b, scope);
  EXPECT_EQ(old_map.size(), 0u);
}

TEST(LandmarkEvidence, ALandmarkNamedByItsIdIsNeverMissed)
{
  LandmarkEvidence evidence;
  const VisibilityScope scope(1.0, 30.0, 2.0 * M_PI);
  LandmarkMap map;
  Landmark named = trunkAt(5.0, 0.0, 0.2, true);
  named.known_id = true;
  named.id = 12;
  map.add(named);
  const DataAssociation a = unseen(map, scope);
  for (int i = 0; i < 20; ++i)
    EXPECT_EQ(evidence.applyMisses(&map, a, scope), 0u);
  EXPECT_EQ(map.size(), 1u);
}
