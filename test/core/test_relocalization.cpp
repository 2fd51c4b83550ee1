// Odometry drift carried by the particles, relocalisation when the cloud is wide, and the filter's health.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "fastslam_test_util.h"
#include "rbpf_slam/core/fastslam/fastslam.h"
#include "rbpf_slam/core/fastslam/filter_health.h"

using rbpf_slam::core::FastSlam;
using rbpf_slam::core::FastSlamConfig;
using rbpf_slam::core::FastSlamUpdateStats;
using rbpf_slam::core::FilterHealth;
using rbpf_slam::core::HealthLevel;
using rbpf_slam::core::Landmark;
using rbpf_slam::core::LandmarkMap;
using rbpf_slam::core::LandmarkObservation;
using rbpf_slam::core::OdometryIncrement;
using rbpf_slam::core::Pose2;
using rbpf_slam::test::observe;
using rbpf_slam::test::quietConfig;

namespace
{
double headingSpread(const FastSlam& f)
{
  return std::sqrt(f.poseCovariance()(2, 2));
}

/** A surveyed map: confirmed landmarks of radius 0.2 m with 2 cm position sigma. */
LandmarkMap surveyedMap(const std::vector<Eigen::Vector2d>& points)
{
  LandmarkMap map;
  int id = 0;
  for (const auto& pt : points)
  {
    Landmark l;
    l.mean = pt;
    l.covariance = Eigen::Matrix2d::Identity() * 0.02 * 0.02;
    l.radius = 0.2;
    l.radius_variance = 0.01 * 0.01;
    l.provisional = false;
    l.observations = 10;
    l.evidence = 3.0;
    l.id = id++;
    map.add(l);
  }
  return map;
}

const std::vector<Eigen::Vector2d> kTrees{ { 5, 3 }, { 6, -4 }, { 10, 1 }, { 3, -6 }, { 8, 6 } };

/** A filter whose particles, started at the origin, were spread along x by one noisy 1 m step. */
FastSlam spreadFilter(double relocalization_spread)
{
  FastSlamConfig c = quietConfig(300);
  c.motion.alpha3 = 0.5;   // 0.5 m of translation noise on the 1 m step
  c.motion.alpha2 = 0.01;  // and 0.01 rad of heading
  c.relocalization_spread = relocalization_spread;
  c.seed = 7;
  FastSlam f(c);
  f.initialize(Pose2(), surveyedMap(kTrees));
  OdometryIncrement u;
  u.trans = 1.0;
  f.predict(u);
  return f;
}

std::vector<LandmarkObservation> observeAll(const Pose2& sensor)
{
  std::vector<LandmarkObservation> obs;
  for (const auto& t : kTrees)
    obs.push_back(observe(sensor, t.x(), t.y()));
  return obs;
}
}  // namespace

TEST(OdometryDrift, TheCloudsHeadingSpreadGrowsWithTheDistanceNotItsRoot)
{
  FastSlamConfig c = quietConfig(4000);
  c.motion.heading_drift = 0.005;
  c.motion.drift_distance = 0.0;  // constant drifts
  FastSlam f(c);
  OdometryIncrement u;
  u.trans = 0.2;
  for (int i = 0; i < 250; ++i)  // 50 m
    f.predict(u);
  EXPECT_NEAR(headingSpread(f), 0.25, 0.02);
  for (int i = 0; i < 250; ++i)  // 100 m: twice the spread (a random walk would give sqrt(2) times)
    f.predict(u);
  EXPECT_NEAR(headingSpread(f), 0.5, 0.04);
}

TEST(OdometryDrift, WithoutDriftAndNoiseEveryParticleFollowsTheOdometry)
{
  FastSlamConfig c = quietConfig(50);
  FastSlam f(c);
  OdometryIncrement u;
  u.trans = 0.2;
  for (int i = 0; i < 100; ++i)
    f.predict(u);
  EXPECT_LT(headingSpread(f), 1e-12);
  EXPECT_NEAR(f.meanPose().x, 20.0, 1e-9);
}

TEST(OdometryDrift, AParticleThatMeasuresLongerHasItsStepShortened)
{
  FastSlamConfig c = quietConfig(1);
  c.motion.scale_drift = 0.02;
  c.motion.drift_distance = 0.0;
  c.seed = 3;
  FastSlam f(c);
  const double scale = f.particles()[0].scale_drift;
  ASSERT_NE(scale, 0.0);
  OdometryIncrement u;
  u.trans = 10.0;
  f.predict(u);
  EXPECT_NEAR(f.particles()[0].pose.x, 10.0 / (1.0 + scale), 1e-9);
}

TEST(Relocalization, AWideCloudFindsTheSurveyedLandmarksAndConvergesOnTheTruth)
{
  FastSlam f = spreadFilter(0.25);
  const Pose2 truth(1.6, 0.0, 0.0);  // 0.6 m ahead of the cloud's mean
  FastSlamUpdateStats first = f.update(observeAll(truth), Pose2());
  EXPECT_TRUE(first.relocalizing);
  EXPECT_GT(first.pose_spread, 0.3);
  EXPECT_EQ(first.created, 0);
  EXPECT_EQ(first.matched, static_cast<int>(kTrees.size()));
  for (int i = 0; i < 3; ++i)
  {
    const FastSlamUpdateStats s = f.update(observeAll(truth), Pose2());
    EXPECT_EQ(s.created, 0);
    EXPECT_EQ(s.deleted, 0);
  }
  const Pose2 m = f.meanPose();
  EXPECT_LT(std::hypot(m.x - truth.x, m.y - truth.y), 0.05);
  const Eigen::Matrix3d cov = f.moments().covariance;
  EXPECT_LT(cov(0, 0) + cov(1, 1), 0.05 * 0.05);
  EXPECT_EQ(f.best().map.size(), kTrees.size());
  // Converged: the next update is an ordinary one.
  EXPECT_FALSE(f.update(observeAll(truth), Pose2()).relocalizing);
}

TEST(Relocalization, NoLandmarkLosesEvidenceWhileThePoseIsThatUncertain)
{
  for (const double spread : { 0.25, 0.0 })
  {
    FastSlam f = spreadFilter(spread);
    const FastSlamUpdateStats s = f.update({}, Pose2());  // nothing seen, every landmark in scope
    EXPECT_EQ(s.relocalizing, spread > 0.0);
    double evidence = 0.0;
    for (std::size_t j = 0; j < f.best().map.size(); ++j)
      evidence += f.best().map[j].evidence;
    if (spread > 0.0)
      EXPECT_DOUBLE_EQ(evidence, 3.0 * kTrees.size());
    else
      EXPECT_LT(evidence, 3.0 * kTrees.size() - 1.0);  // the ordinary filter counts the misses
  }
}

TEST(FilterHealth, ANewMapIsHealthyARebuiltOneWarns)
{
  FilterHealth h;
  FastSlamUpdateStats s;
  // Exploring: every observation first makes a landmark, then matches it once confirmed.
  for (int i = 0; i < 100; ++i)
  {
    s = FastSlamUpdateStats();
    s.observations = 3;
    s.created = i % 20 == 0 ? 3 : 0;
    s.matched = 3 - s.created;
    s.matched_confirmed = i % 20 < 3 ? 0 : s.matched;
    s.neff = 80;
    EXPECT_EQ(h.add(s, 100).level, HealthLevel::kOk) << "update " << i << ": " << h.status().message;
  }
  // Lost: observations keep making landmarks where confirmed ones were deleted.
  for (int i = 0; i < 3; ++i)
  {
    s = FastSlamUpdateStats();
    s.observations = 2;
    s.created = 2;
    s.recreated = 1;
    h.add(s, 100);
  }
  EXPECT_EQ(h.status().level, HealthLevel::kWarn);
  EXPECT_NE(h.status().message.find("rebuilt"), std::string::npos);
  EXPECT_GT(h.warnings(), 0);
}

TEST(FilterHealth, FewMatchesToConfirmedLandmarksWithManyNewOnesWarn)
{
  FilterHealth h;
  FastSlamUpdateStats s;
  s.observations = 2;
  s.created = 2;  // nothing ever matches: every look makes new landmarks
  for (int i = 0; i < 99; ++i)
    EXPECT_EQ(h.add(s, 100).level, HealthLevel::kOk);  // a new map: no verdict before the window is full
  h.add(s, 100);
  EXPECT_EQ(h.status().level, HealthLevel::kWarn);
  EXPECT_DOUBLE_EQ(h.status().matched_confirmed_share, 0.0);
}

TEST(FilterHealth, InASavedMapFewMatchesToItsTreesWarnAfterAShortWindow)
{
  rbpf_slam::core::HealthConfig c;
  c.matched_prior_warn = 0.3;
  FilterHealth h(c);
  FastSlamUpdateStats s;
  s.neff = 80;
  s.observations = 10;
  s.matched = s.matched_confirmed = 7;
  s.matched_prior = 6;  // a second visit: two thirds matched to the saved trees, the rest new, clutter
  for (int i = 0; i < 200; ++i)
    EXPECT_EQ(h.add(s, 100).level, HealthLevel::kOk) << h.status().message;
  // Lost: the observations match the filter's own new landmarks (consistently), none of the saved map's.
  s.matched_prior = 0;
  int updates = 0;
  while (h.add(s, 100).level == HealthLevel::kOk && updates < 100)
    ++updates;
  EXPECT_EQ(h.status().level, HealthLevel::kWarn);
  EXPECT_NE(h.status().message.find("saved map not re-observed"), std::string::npos) << h.status().message;
  EXPECT_LE(updates, c.prior_window) << "warned after a short window, not the long one";
  EXPECT_GE(updates, 15) << "not on a few sweeps' dip";
  // Without a saved map the same figures are a healthy new map.
  FilterHealth fresh;
  for (int i = 0; i < 200; ++i)
    EXPECT_EQ(fresh.add(s, 100).level, HealthLevel::kOk);
}

TEST(FilterHealth, InnovationsBeyondTheClaimedUncertaintyWarn)
{
  FilterHealth h;
  FastSlamUpdateStats s;
  s.observations = 3;
  s.matched = 3;
  s.matched_confirmed = 3;
  s.neff = 80;
  s.claimed_matches = 3;
  s.claimed_nis = 3 * 2.1;  // chi-square, 2 dof: about 2 per match when the spread covers the error
  for (int i = 0; i < 100; ++i)
    EXPECT_EQ(h.add(s, 100).level, HealthLevel::kOk) << h.status().message;
  EXPECT_NEAR(h.status().claimed_nis, 2.1, 1e-12);
  s.claimed_nis = 3 * 30.0;  // errors about four times what the cloud claims
  for (int i = 0; i < 30; ++i)
    h.add(s, 100);
  EXPECT_EQ(h.status().level, HealthLevel::kWarn);
  EXPECT_TRUE(h.status().overconfident);
  EXPECT_NE(h.status().message.find("overconfident"), std::string::npos) << h.status().message;
}
