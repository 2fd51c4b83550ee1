// The sensor's scope, the miss rule's detection probability and the filter's estimate, on cases whose answer is
// known.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/fastslam/fastslam_test_util.h"
#include "rbpf_slam/core/fastslam/fastslam.h"
#include "rbpf_slam/core/extraction/trunk_clustering.h"
#include "rbpf_slam/core/trunk_slam/trunk_slam_pipeline.h"
#include "rbpf_slam/core/fastslam/visibility_scope.h"

using namespace rbpf_slam::core;
using rbpf_slam::test::observe;
using rbpf_slam::test::quietConfig;

namespace
{
SensorScope forwardScope(double max_range, double half_fov, double detection_probability = NAN)
{
  SensorScope s;
  s.min_range = 0.5;
  s.max_range = max_range;
  s.fov_min = -half_fov;
  s.fov_max = half_fov;
  s.detection_probability = detection_probability;
  return s;
}
}  // namespace

TEST(SensorScope, TheSensorsScopeHoldsUnlessTheConfigurationBoundsIt)
{
  const VisibilityScope fallback = FastSlamConfig::fallbackScope();
  // Neither says: the fallback.
  VisibilityScope s = effectiveScope(SensorScope(), SensorScope(), fallback);
  EXPECT_DOUBLE_EQ(s.max_range, FastSlamConfig::kFallbackMaxRange);
  EXPECT_TRUE(s.fullTurn());
  // A 180 degree, 80 m scanner: its own scope.
  s = effectiveScope(SensorScope(), forwardScope(80.0, M_PI / 2), fallback);
  EXPECT_DOUBLE_EQ(s.max_range, 80.0);
  EXPECT_DOUBLE_EQ(s.min_range, 0.5);
  EXPECT_FALSE(s.contains(Eigen::Vector2d(10.0, 2.0)));  // behind
  EXPECT_TRUE(s.contains(Eigen::Vector2d(60.0, 1.0)));
  // A configured 12 m bounds it; a configured full turn does not widen it.
  FastSlamConfig c;
  c.max_range = 12.0;
  c.field_of_view = 2.0 * M_PI;
  s = effectiveScope(c.configuredScope(), forwardScope(80.0, M_PI / 2), fallback);
  EXPECT_DOUBLE_EQ(s.max_range, 12.0);
  EXPECT_FALSE(s.fullTurn());
  // A configured narrow view bounds a sensor that sees all round.
  c.field_of_view = 1.0;
  s = effectiveScope(c.configuredScope(), forwardScope(80.0, M_PI), fallback);
  EXPECT_TRUE(s.contains(Eigen::Vector2d(5.0, 0.4)));
  EXPECT_FALSE(s.contains(Eigen::Vector2d(5.0, 0.6)));
  // The detection probability: the configuration's, else the sensor's, else 1.
  EXPECT_DOUBLE_EQ(effectiveScope(SensorScope(), forwardScope(5.0, 0.6, 0.6), fallback).detection_probability, 0.6);
  c.detection_probability = 0.8;
  EXPECT_DOUBLE_EQ(effectiveScope(c.configuredScope(), forwardScope(5.0, 0.6, 0.6), fallback).detection_probability,
                   0.8);
  EXPECT_DOUBLE_EQ(fallback.detection_probability, 1.0);
}

TEST(SensorScope, ALandmarkOutsideANarrowSensorsViewIsNotMissed)
{
  // A camera that sees 5 m and 70 degrees: the landmark behind it and the one at 8 m are outside, not missed.
  FastSlam f(quietConfig());
  const SensorScope camera = forwardScope(5.0, 35.0 * M_PI / 180.0);
  f.update({ observe(Pose2(), 3.0, 0.0) }, Pose2(), camera);
  ASSERT_EQ(f.best().map.size(), 1u);
  // Turn around: the landmark is now behind the camera. However often it is not seen, it stays.
  f.predict(decomposeOdometry(Pose2(), Pose2(0, 0, M_PI)));
  for (int i = 0; i < 20; ++i)
    f.update({}, Pose2(), camera);
  EXPECT_EQ(f.best().map.size(), 1u);
  // The same with the all-round fallback scope: missed and removed.
  FastSlam g(quietConfig());
  g.update({ observe(Pose2(), 3.0, 0.0) }, Pose2());
  g.predict(decomposeOdometry(Pose2(), Pose2(0, 0, M_PI)));
  for (int i = 0; i < 20; ++i)
    g.update({}, Pose2());
  EXPECT_EQ(g.best().map.size(), 0u);
}

TEST(SensorScope, AMissWeighsTheDetectionProbability)
{
  FastSlamConfig c = quietConfig();
  c.delete_evidence = -100.0;  // nothing is removed: the evidence itself is compared
  FastSlam full(c), camera(c);
  full.update({ observe(Pose2(), 3.0, 0.0) }, Pose2(), forwardScope(5.0, 1.0, 1.0));
  camera.update({ observe(Pose2(), 3.0, 0.0) }, Pose2(), forwardScope(5.0, 1.0, 0.6));
  const double e0 = full.best().map[0].evidence;
  ASSERT_DOUBLE_EQ(camera.best().map[0].evidence, e0);
  full.update({}, Pose2(), forwardScope(5.0, 1.0, 1.0));
  camera.update({}, Pose2(), forwardScope(5.0, 1.0, 0.6));
  EXPECT_NEAR(e0 - full.best().map[0].evidence, c.evidence_miss, 1e-12);
  EXPECT_NEAR(e0 - camera.best().map[0].evidence, 0.6 * c.evidence_miss, 1e-12);
}

TEST(SensorScope, ALandmarkPredictedAtTheRangeEdgeIsNotMissed)
{
  // A landmark seen once at 4.0 m (its prediction uncertain by a few centimetres) and then predicted 0.01 m inside
  // a 4.0 m range: it may lie outside; one predicted 1 m inside is missed.
  FastSlamConfig c = quietConfig();
  c.delete_evidence = -100.0;
  FastSlam f(c);
  f.update({ observe(Pose2(), 4.0, 0.0, 0.05, 0.003), observe(Pose2(), 3.0, 1.0, 0.05, 0.003) }, Pose2(),
           forwardScope(10.0, 1.0));
  ASSERT_EQ(f.best().map.size(), 2u);
  const double e_edge = f.best().map[0].evidence, e_inside = f.best().map[1].evidence;
  f.update({}, Pose2(), forwardScope(4.01, 1.0));
  EXPECT_DOUBLE_EQ(f.best().map[0].evidence, e_edge);
  EXPECT_LT(f.best().map[1].evidence, e_inside);
}

TEST(FastSlamEstimate, TheBestParticleIsFollowedThroughResamplingNotTakenAsTheFirst)
{
  // Particles spread by a noisy motion; one known landmark seen from the true pose. A twin filter that never
  // resamples (same seed, so the same particles) shows which particle weighs most; the filter that resamples at
  // this update must keep that particle's pose as its best, not the first of the equal-weight copies.
  FastSlamConfig c = quietConfig(50);
  c.motion.alpha2 = 0.005;
  c.motion.alpha3 = 0.03;
  c.use_radius = false;
  c.seed = 7;
  FastSlamConfig never = c;
  never.resampling.neff_ratio = 0.0;
  FastSlamConfig always = c;
  always.resampling.neff_ratio = 1.0;
  FastSlam twin(never), f(always);
  for (FastSlam* g : { &twin, &f })
  {
    g->update({ observe(Pose2(), 5.0, 0.0) }, Pose2());  // equal weights: no resampling yet
    g->predict(decomposeOdometry(Pose2(), Pose2(1.0, 0.0, 0.0)));
  }
  const LandmarkObservation z = observe(Pose2(1.0, 0.0, 0.0), 5.0, 0.0);
  EXPECT_FALSE(twin.update({ z }, Pose2()).resampled);
  ASSERT_TRUE(f.update({ z }, Pose2()).resampled);
  const Pose2 expected = twin.best().pose;
  ASSERT_GT(std::abs(expected.x - twin.particles()[0].pose.x), 1e-6);  // not particle 0: the test can fail
  EXPECT_DOUBLE_EQ(f.best().pose.x, expected.x);
  EXPECT_DOUBLE_EQ(f.best().pose.y, expected.y);
  // Its history: its pose after each of the two updates, the last one its present pose.
  const std::vector<Pose2> h = f.bestHistory();
  ASSERT_EQ(h.size(), 2u);
  EXPECT_DOUBLE_EQ(h.back().x, expected.x);
  EXPECT_DOUBLE_EQ(h.front().x, 0.0);
  // The estimate is the weighted mean by default; "best" gives the best particle's pose.
  EXPECT_DOUBLE_EQ(f.estimate().x, f.meanPose().x);
  FastSlamConfig b = always;
  b.estimate = PoseEstimate::kBest;
  FastSlam fb(b);
  fb.update({ observe(Pose2(), 5.0, 0.0) }, Pose2());
  fb.predict(decomposeOdometry(Pose2(), Pose2(1.0, 0.0, 0.0)));
  fb.update({ z }, Pose2());
  EXPECT_DOUBLE_EQ(fb.estimate().x, expected.x);
}

TEST(SensorScope, AzimuthStepAndReachOfASpinningLidar)
{
  // 16 rings 2 degrees apart, 0.2 degree azimuth steps, a cylinder wall at 10 m: the step is found, and a 0.15 m
  // trunk gives 6 points on one ring out to 2 * 0.15 / (6 * 0.2 deg) = 14.3 m.
  std::vector<Eigen::Vector3f> points;
  const double step = 0.2 * M_PI / 180.0;
  for (int ring = 0; ring < 16; ++ring)
  {
    const double elevation = (-15.0 + 2.0 * ring) * M_PI / 180.0;
    for (int k = 0; k < 1800; k += 3)  // a third of the beams: the median gap is still one step
      for (int j = 0; j < 2; ++j)
      {
        const double az = -M_PI + (k + j) * step;
        points.emplace_back(10.0 * std::cos(az), 10.0 * std::sin(az), 10.0 * std::tan(elevation));
      }
  }
  const double found = estimateAzimuthStep(points);
  EXPECT_NEAR(found, step, 0.01 * step);
  EXPECT_NEAR(singleRingReach(0.15, 6, found), 14.3, 0.2);
  EXPECT_TRUE(std::isnan(estimateAzimuthStep({ Eigen::Vector3f(1, 0, 0) })));
}

TEST(SensorScope, AScansScopeIsItsAnglesAndRangesWithinTheDetectors)
{
  PlanarScan scan;
  scan.ranges.assign(361, 5.0f);
  scan.angle_min = -M_PI / 2;
  scan.angle_increment = M_PI / 360.0;
  scan.range_min = 0.1;
  scan.range_max = 80.0;
  TrunkDetectorConfig d;
  d.max_range = 30.0;
  d.min_range = 0.5;
  d.detection_probability = 0.7;
  const SensorScope s = scanScope(scan, d);
  EXPECT_NEAR(s.fov_min, -M_PI / 2, 1e-12);
  EXPECT_NEAR(s.fov_max, M_PI / 2, 1e-12);
  EXPECT_DOUBLE_EQ(s.min_range, 0.5);
  EXPECT_DOUBLE_EQ(s.max_range, 30.0);
  EXPECT_DOUBLE_EQ(s.detection_probability, 0.7);
  scan.range_max = 8.0;
  EXPECT_DOUBLE_EQ(scanScope(scan, d).max_range, 8.0);
}

TEST(KnownIds, AnObservationUpdatesTheLandmarkOfItsIdWhereverItLies)
{
  FastSlamConfig c = quietConfig();
  c.use_known_ids = true;
  FastSlam f(c);
  LandmarkObservation a = observe(Pose2(), 4.0, 0.0), b = observe(Pose2(), 4.0, 1.0);
  a.id = 7;
  b.id = 3;
  f.update({ a, b }, Pose2());
  ASSERT_EQ(f.best().map.size(), 2u);
  // Id 7 seen 0.8 m off (far outside the gate) and id 3 where 7 is: each updates its own landmark, none is new.
  LandmarkObservation a2 = observe(Pose2(), 4.0, -0.8), b2 = observe(Pose2(), 4.0, 0.0);
  a2.id = 7;
  b2.id = 3;
  const FastSlamUpdateStats st = f.update({ a2, b2 }, Pose2());
  EXPECT_EQ(st.matched, 2);
  EXPECT_EQ(st.created, 0);
  ASSERT_EQ(f.best().map.size(), 2u);
  for (std::size_t j = 0; j < 2; ++j)
  {
    const Landmark& l = f.best().map[j];
    if (l.id == 7)
      EXPECT_LT(l.mean.y(), -0.1);  // pulled towards its own observation
    else
      EXPECT_EQ(l.id, 3);
  }
  // Without known ids the same observations are associated by distance (b2 takes landmark 7).
  FastSlamConfig u = quietConfig();
  FastSlam g(u);
  g.update({ a, b }, Pose2());
  const FastSlamUpdateStats su = g.update({ a2, b2 }, Pose2());
  EXPECT_EQ(su.created, 1);
}
