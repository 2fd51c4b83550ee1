// Data association on synthetic maps whose answer is known: candidates, gate, likelihood, stable matching.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Dense>

#include "rbpf_slam/core/fastslam/data_association.h"
#include "rbpf_slam/core/fastslam/landmark_map.h"

using namespace rbpf_slam::core;

namespace
{
constexpr double kLog2Pi = 1.8378770664093453;

Landmark landmarkAt(double x, double y, double sigma = 0.0, double radius = 0.2)
{
  Landmark l;
  l.mean = Eigen::Vector2d(x, y);
  l.covariance = sigma * sigma * Eigen::Matrix2d::Identity();
  l.radius = radius;
  l.radius_variance = 0.0;  // radius unknown unless a test sets it
  return l;
}

/** An exact observation of map point (x, y) from a sensor at the origin, heading 0. */
LandmarkObservation observeFromOrigin(double x, double y)
{
  LandmarkObservation o;
  o.range = std::hypot(x, y);
  o.bearing = std::atan2(y, x);
  o.covariance.setZero();
  return o;
}
}  // namespace

TEST(DataAssociation, CandidatesAreTheLandmarksInTheScopeWithItsMargins)
{
  LandmarkMap map;
  map.add(landmarkAt(12.4, 0.0));   // 0: 0.4 m beyond the ring, inside the 0.5 m margin
  map.add(landmarkAt(12.6, 0.0));   // 1: beyond the margin
  map.add(landmarkAt(0.6, 0.0));    // 2: 0.4 m inside the near edge, within the margin
  map.add(landmarkAt(0.4, 0.0));    // 3: too near even with the margin
  const double in = M_PI / 2 + 0.05, out = M_PI / 2 + 0.15;  // the view is +-pi/2, the margin 0.1 rad
  map.add(landmarkAt(5.0 * std::cos(in), 5.0 * std::sin(in)));    // 4
  map.add(landmarkAt(5.0 * std::cos(out), 5.0 * std::sin(out)));  // 5
  map.add(landmarkAt(6.0, 1.0));    // 6: well inside
  const VisibilityScope scope(1.0, 12.0, M_PI);
  DataAssociation a;
  a.selectCandidates(map, Pose2(), Pose2(), scope);
  std::vector<std::size_t> got;
  for (const auto& cd : a.candidates())
    got.push_back(cd.index);
  EXPECT_EQ(got, (std::vector<std::size_t>{ 0, 2, 4, 6 }));
  // Each candidate carries its predicted observation and, without a pose covariance, A = H P H^T.
  const AssociationCandidate& c6 = a.candidates()[3];
  EXPECT_NEAR(c6.z.x(), std::hypot(6.0, 1.0), 1e-12);
  EXPECT_NEAR(c6.z.y(), std::atan2(1.0, 6.0), 1e-12);
  EXPECT_TRUE(c6.pose_term.isZero(0.0));
  // Turned by pi the sensor looks along -x: only the two landmarks beyond the y axis are in its view.
  a.selectCandidates(map, Pose2(0.0, 0.0, M_PI), Pose2(), scope);
  got.clear();
  for (const auto& cd : a.candidates())
    got.push_back(cd.index);
  EXPECT_EQ(got, (std::vector<std::size_t>{ 4, 5 }));
}

TEST(DataAssociation, PoseCovarianceWidensTheInnovation)
{
  LandmarkMap map;
  map.add(landmarkAt(5.0, 0.0, 0.1));
  // Heading uncertainty only, no lever arm: the bearing's variance grows by exactly the heading's.
  Eigen::Matrix3d pose_cov = Eigen::Matrix3d::Zero();
  pose_cov(2, 2) = 0.01;
  DataAssociation a;
  a.selectCandidates(map, Pose2(), Pose2(), VisibilityScope(), &pose_cov);
  ASSERT_EQ(a.candidates().size(), 1u);
  const AssociationCandidate& cd = a.candidates()[0];
  EXPECT_NEAR(cd.pose_term(1, 1), 0.01, 1e-15);
  EXPECT_NEAR(cd.pose_term(0, 0), 0.0, 1e-15);
  EXPECT_NEAR(cd.A(0, 0), 0.01, 1e-15);                  // range: the landmark's 0.1 m
  EXPECT_NEAR(cd.A(1, 1), 0.01 / 25.0 + 0.01, 1e-15);    // bearing: (0.1 / 5)^2 + the heading's
}

TEST(DataAssociation, GateRejectsAPairJustOutsideIt)
{
  // An exactly known landmark (zero covariance): S = R, d2 = dr^2 / sigma_r^2 for a pure range error.
  LandmarkMap map;
  map.add(landmarkAt(5.0, 0.0));
  AssociationConfig config;
  config.gate = 13.8;
  DataAssociation a(config);
  const double sigma_r = 0.1, sigma_b = 0.01;
  Eigen::Matrix2d R;
  R << sigma_r * sigma_r, 0, 0, sigma_b * sigma_b;
  const double edge = std::sqrt(config.gate) * sigma_r;  // range error on the gate
  for (const double f : { 0.99, 1.01 })
  {
    LandmarkObservation o = observeFromOrigin(5.0 + f * edge, 0.0);
    a.selectCandidates(map, Pose2(), Pose2(), VisibilityScope());
    a.associate(map, { o }, { R });
    if (f < 1.0)
    {
      EXPECT_EQ(a.match(0), 0);
      EXPECT_TRUE(a.gated(0));
      EXPECT_TRUE(a.taken(0));
      const double d2 = f * f * config.gate;
      EXPECT_NEAR(a.logLikelihood(0, 0), -0.5 * d2 - kLog2Pi - 0.5 * std::log(R.determinant()), 1e-9);
      EXPECT_NEAR(a.innovation(0, 0).x(), f * edge, 1e-12);
      EXPECT_NEAR(a.innovationInverse(0, 0)(0, 0), 1.0 / (sigma_r * sigma_r), 1e-6);
    }
    else
    {
      EXPECT_EQ(a.match(0), -1);
      EXPECT_FALSE(a.gated(0));
      EXPECT_FALSE(a.taken(0));
      EXPECT_EQ(a.logLikelihood(0, 0), -std::numeric_limits<double>::infinity());
    }
  }
}

TEST(DataAssociation, InconsistentRadiusRejectsAPairInsideThePositionGate)
{
  LandmarkMap map;
  Landmark l = landmarkAt(5.0, 0.0, 0.05, 0.20);
  l.radius_variance = 0.01 * 0.01;
  map.add(l);
  Eigen::Matrix2d R = Eigen::Matrix2d::Identity() * 1e-4;
  AssociationConfig config;
  DataAssociation a(config);
  // Same position; radius variances 1e-4 + 1e-4 + floor 4e-4 = 6e-4: a 0.05 m difference gives 4.2 (inside),
  // 0.10 m gives 16.7 (outside the 13.8 gate).
  LandmarkObservation o = observeFromOrigin(5.0, 0.0);
  o.radius_variance = 0.01 * 0.01;
  o.radius = 0.25;
  a.selectCandidates(map, Pose2(), Pose2(), VisibilityScope());
  a.associate(map, { o }, { R });
  EXPECT_EQ(a.match(0), 0);
  o.radius = 0.30;
  a.associate(map, { o }, { R });
  EXPECT_EQ(a.match(0), -1);
  // Without the radius term the same pair is matched.
  config.use_radius = false;
  DataAssociation b(config);
  b.selectCandidates(map, Pose2(), Pose2(), VisibilityScope());
  b.associate(map, { o }, { R });
  EXPECT_EQ(b.match(0), 0);
}

TEST(DataAssociation, StableMatchingResolvesAConflictAmongThreeObservations)
{
  // Three trees 1 m apart across the view, each known to 0.3 m. O0 lies between L1 and L2 but nearer L1;
  // O1 lies next to L1; O2 next to L0. O0 and O1 both want L1: L1 keeps O1 (the better fit) and O0 takes its
  // second choice L2. A greedy pass in observation order would give L1 to O0 and leave L2 unexplained.
  LandmarkMap map;
  map.add(landmarkAt(5.0, -1.0, 0.3));
  map.add(landmarkAt(5.0, 0.0, 0.3));
  map.add(landmarkAt(5.0, 1.0, 0.3));
  const std::vector<LandmarkObservation> obs{ observeFromOrigin(5.0, 0.45), observeFromOrigin(5.0, 0.05),
                                              observeFromOrigin(5.0, -0.95) };
  const Eigen::Matrix2d R = Eigen::Matrix2d::Identity() * 1e-4;
  DataAssociation a;
  a.selectCandidates(map, Pose2(), Pose2(), VisibilityScope());
  a.associate(map, obs, { R, R, R });
  // The conflict is real: O0 prefers L1 to L2, and L1 prefers O1 to O0.
  ASSERT_GT(a.logLikelihood(0, 1), a.logLikelihood(0, 2));
  ASSERT_GT(a.logLikelihood(1, 1), a.logLikelihood(0, 1));
  EXPECT_EQ(a.match(0), 2);
  EXPECT_EQ(a.match(1), 1);
  EXPECT_EQ(a.match(2), 0);
  for (std::size_t k = 0; k < 3; ++k)
    EXPECT_TRUE(a.taken(k));
  // The same table through the public entry point gives the same matching.
  std::vector<std::vector<double>> table(3, std::vector<double>(3));
  for (std::size_t i = 0; i < 3; ++i)
    for (std::size_t k = 0; k < 3; ++k)
      table[i][k] = a.logLikelihood(i, k);
  EXPECT_EQ(DataAssociation::stableMatching(table), (std::vector<int>{ 2, 1, 0 }));
}

TEST(DataAssociation, NewTrunkOverlappingACandidateIsSuppressed)
{
  LandmarkMap map;
  map.add(landmarkAt(5.0, 0.0, 0.1, 0.2));
  DataAssociation a;
  a.selectCandidates(map, Pose2(), Pose2(), VisibilityScope());
  // Radii 0.2 + 0.2 and a 0.1 m gap: centres nearer than 0.5 m overlap.
  EXPECT_TRUE(a.overlapsCandidate(map, Eigen::Vector2d(5.45, 0.0), 0.2, 0.1));
  EXPECT_FALSE(a.overlapsCandidate(map, Eigen::Vector2d(5.55, 0.0), 0.2, 0.1));
  EXPECT_FALSE(a.overlapsCandidate(map, Eigen::Vector2d(5.45, 0.0), 0.2, 0.0));
}

TEST(DataAssociation, RepredictFromADrawnPoseRecomputesTheMatchedPairs)
{
  LandmarkMap map;
  map.add(landmarkAt(5.0, 0.0, 0.1));
  const Eigen::Matrix2d R = Eigen::Matrix2d::Identity() * 1e-4;
  const std::vector<LandmarkObservation> obs{ observeFromOrigin(5.0, 0.0) };
  DataAssociation a;
  a.selectCandidates(map, Pose2(), Pose2(), VisibilityScope());
  a.associate(map, obs, { R });
  ASSERT_EQ(a.match(0), 0);
  const double at_origin = a.logLikelihood(0, 0);
  EXPECT_NEAR(a.innovation(0, 0).x(), 0.0, 1e-12);
  // The pose drawn 0.1 m forward: the landmark is predicted at 4.9 m, the innovation is 0.1 m. S = H P H^T + R
  // = diag(0.01 + 1e-4, 0.01 / 4.9^2 + 1e-4).
  const double s_rr = 0.01 + 1e-4, s_bb = 0.01 / (4.9 * 4.9) + 1e-4;
  a.repredict(map, Pose2(0.1, 0.0, 0.0), obs, { R }, false);
  EXPECT_NEAR(a.candidates()[0].z.x(), 4.9, 1e-12);
  EXPECT_NEAR(a.innovation(0, 0).x(), 0.1, 1e-12);
  EXPECT_NEAR(a.innovationInverse(0, 0)(1, 1), 1.0 / s_bb, 1e-6);
  EXPECT_EQ(a.logLikelihood(0, 0), at_origin);  // kept: the likelihood under the prior
  a.repredict(map, Pose2(0.1, 0.0, 0.0), obs, { R }, true);
  EXPECT_NEAR(a.logLikelihood(0, 0), -0.5 * 0.01 / s_rr - kLog2Pi - 0.5 * std::log(s_rr * s_bb), 1e-9);
}

TEST(DataAssociation, AnObservationWithAnIdFindsItsLandmarkWhereverItIsPredicted)
{
  LandmarkMap map;
  Landmark near = landmarkAt(4.0, 0.0, 0.05);
  near.id = 7;
  near.known_id = true;
  Landmark beyond = landmarkAt(13.0, 0.0, 0.05);  // predicted beyond the 12 m ring and its margin
  beyond.id = 9;
  beyond.known_id = true;
  Landmark behind = landmarkAt(-5.0, 0.0, 0.05);  // behind a forward-looking sensor
  behind.id = 11;
  behind.known_id = true;
  map.add(near);
  map.add(beyond);
  map.add(behind);
  const VisibilityScope scope(1.0, 12.0, M_PI);
  AssociationConfig config;
  config.use_known_ids = true;
  DataAssociation a(config);
  a.selectCandidates(map, Pose2(), Pose2(), scope);
  ASSERT_EQ(a.candidates().size(), 1u);
  // The detector saw id 9 at 11.8 m (the landmark is off by more than the gate) and id 7.
  std::vector<LandmarkObservation> obs{ observeFromOrigin(11.8, 0.0), observeFromOrigin(4.0, 0.0) };
  obs[0].id = 9;
  obs[1].id = 7;
  const std::vector<Eigen::Matrix2d> R(2, 0.01 * Eigen::Matrix2d::Identity());
  a.addNamedCandidates(map, Pose2(), Pose2(), obs);
  ASSERT_EQ(a.candidates().size(), 2u);  // 11 is named by no observation
  EXPECT_EQ(a.candidates()[0].index, 0u);
  EXPECT_EQ(a.candidates()[1].index, 1u);
  a.associate(map, obs, R);
  ASSERT_GE(a.match(0), 0);
  EXPECT_EQ(map[a.candidates()[static_cast<std::size_t>(a.match(0))].index].id, 9);
  ASSERT_GE(a.match(1), 0);
  EXPECT_EQ(map[a.candidates()[static_cast<std::size_t>(a.match(1))].index].id, 7);
}
