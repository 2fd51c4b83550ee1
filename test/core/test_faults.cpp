// Faults the core must survive: stamps that jump, dropouts in a scan, a standing robot, hours of history, absurd
// particle counts. Each test feeds the fault and checks that the state is what it must be afterwards.
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/forest_map/constellation.h"
#include "rbpf_slam/core/fastslam/fastslam.h"
#include "rbpf_slam/core/forest_map/gnss.h"
#include "rbpf_slam/core/grid/grid_slam.h"
#include "rbpf_slam/core/filter/history_chain.h"
#include "rbpf_slam/core/filter/stamp_gate.h"
#include "rbpf_slam/core/extraction/trunk_detector.h"
#include "rbpf_slam/core/trunk_slam/trunk_slam_pipeline.h"
#include "core/fastslam/fastslam_test_util.h"
#include "core/forest_map/gnss_test_util.h"
#include "core/grid/grid_test_world.h"

using namespace rbpf_slam::core;

TEST(StampGate, LateFutureDuplicateAndRealJumps)
{
  StampGate g(1.0);
  EXPECT_EQ(g.check(10.0, 10.0), StampVerdict::kAccept);
  EXPECT_EQ(g.check(10.1, 10.1), StampVerdict::kAccept);
  EXPECT_EQ(g.check(10.1, 10.2), StampVerdict::kDuplicate);
  EXPECT_EQ(g.check(9.6, 10.2), StampVerdict::kLate);  // 0.5 s late: dropped, no reset
  EXPECT_EQ(g.last(), 10.1);
  EXPECT_EQ(g.check(15.2, 10.2), StampVerdict::kFuture);  // 5 s ahead of the clock: dropped
  EXPECT_EQ(g.last(), 10.1);
  EXPECT_EQ(g.check(10.3, 10.3), StampVerdict::kAccept);  // the stream goes on as if nothing had come
  EXPECT_EQ(g.check(std::nan(""), 10.3), StampVerdict::kInvalid);
  EXPECT_EQ(g.check(2.0, 10.4), StampVerdict::kBack);  // 8.3 s back while the clock went on: not alone a new timeline
  EXPECT_EQ(g.last(), 10.3);
  EXPECT_EQ(g.check(2.0, 2.0), StampVerdict::kReset);  // a looped bag: the clock went back with the stamps
  EXPECT_EQ(g.last(), 2.0);
  EXPECT_EQ(g.check(2.1, 2.1), StampVerdict::kAccept);
  EXPECT_EQ(g.check(100.0), StampVerdict::kAccept);  // no clock: no future test
  g.reset();
  EXPECT_EQ(g.check(1.0), StampVerdict::kAccept);
}

TEST(TimelineGate, OneMessageBackIsDroppedAndOnlySeveralThatAgreeRestart)
{
  // Odometry at 20 Hz and a sweep at 10 Hz, no clock (a bag runner without record times, or stamps from another
  // clock): a message 2 s back among them is dropped, even every 4th one, and the streams go on.
  TimelineGate g(1.0);
  double t = 100.0;
  for (int k = 0; k < 200; ++k, t += 0.05)
  {
    const double stamp = k % 4 == 3 ? t - 2.0 : t;
    const StampVerdict v = g.check(k % 2 ? TimelineGate::kSensor : TimelineGate::kOdometry, stamp);
    EXPECT_EQ(v, k % 4 == 3 ? StampVerdict::kBack : StampVerdict::kAccept) << k;
  }
  EXPECT_EQ(g.restarts(), 0);
  // Two messages back that agree, then the old timeline goes on: still no restart.
  EXPECT_EQ(g.check(TimelineGate::kOdometry, 50.0), StampVerdict::kBack);
  EXPECT_EQ(g.check(TimelineGate::kSensor, 50.02), StampVerdict::kBack);
  EXPECT_EQ(g.check(TimelineGate::kOdometry, t), StampVerdict::kAccept);
  EXPECT_EQ(g.check(TimelineGate::kOdometry, 50.05), StampVerdict::kBack);  // counted afresh
  EXPECT_EQ(g.restarts(), 0);
  // Messages back that disagree (seconds apart) are no timeline either.
  EXPECT_EQ(g.check(TimelineGate::kSensor, 20.0), StampVerdict::kBack);
  EXPECT_EQ(g.check(TimelineGate::kSensor, 80.0), StampVerdict::kBack);
  EXPECT_EQ(g.restarts(), 0);
  // A looped bag: the same stream of messages from the start again, and they agree. The third restarts.
  EXPECT_EQ(g.check(TimelineGate::kOdometry, 10.0), StampVerdict::kBack);
  EXPECT_EQ(g.check(TimelineGate::kSensor, 10.02), StampVerdict::kBack);
  EXPECT_EQ(g.check(TimelineGate::kOdometry, 10.05), StampVerdict::kReset);
  EXPECT_EQ(g.restarts(), 1);
  EXPECT_EQ(g.check(TimelineGate::kSensor, 10.06), StampVerdict::kAccept);  // no second jump on the other stream
  // With a clock that went back with the stamps (a simulation restarted, a bag played with --clock), at once.
  EXPECT_EQ(g.check(TimelineGate::kOdometry, 12.0, 12.0), StampVerdict::kAccept);
  EXPECT_EQ(g.check(TimelineGate::kOdometry, 1.0, 1.0), StampVerdict::kReset);
  EXPECT_EQ(g.restarts(), 2);
}

TEST(TimelineGate, ASensorsFirstMessageBackInTimeWithTheClockStartsANewTimeline)
{
  // Odometry alone (a bag without scans), then a bag with scans from an earlier time, played with its clock: the
  // first scan restarts, before the new odometry comes.
  TimelineGate g(1.0);
  for (double t = 1000.0; t < 1010.0; t += 0.05)
    ASSERT_EQ(g.check(TimelineGate::kOdometry, t, t), StampVerdict::kAccept);
  EXPECT_EQ(g.check(TimelineGate::kSensor, 1000.0, 1000.0), StampVerdict::kReset);
  EXPECT_EQ(g.restarts(), 1);
  EXPECT_EQ(g.check(TimelineGate::kOdometry, 1000.02, 1000.02), StampVerdict::kAccept);
  // A sensor that starts late behind its odometry, the clock going on: no new timeline.
  TimelineGate h(1.0);
  for (double t = 0.0; t < 10.0; t += 0.05)
    ASSERT_EQ(h.check(TimelineGate::kOdometry, t, t), StampVerdict::kAccept);
  EXPECT_EQ(h.check(TimelineGate::kSensor, 5.0, 10.0), StampVerdict::kAccept);
  // Without a clock, one message alone cannot tell.
  TimelineGate n(1.0);
  for (double t = 0.0; t < 10.0; t += 0.05)
    ASSERT_EQ(n.check(TimelineGate::kOdometry, t), StampVerdict::kAccept);
  EXPECT_EQ(n.check(TimelineGate::kSensor, 1.0), StampVerdict::kAccept);
  EXPECT_EQ(n.restarts(), 0);
}

namespace
{
/** Four trunks seen from base_link at (x, 0) looking along +x, in the sensor frame (the sensor on base_link). */
TrunkSweep fourTrunks(double stamp, double x)
{
  TrunkSweep sweep;
  sweep.stamp = stamp;
  const double xy[4][2] = { { 4.0, 1.0 }, { 6.0, -2.0 }, { 3.0, -3.0 }, { 7.0, 3.0 } };
  for (const auto& p : xy)
  {
    TrunkObservation t;
    t.center = Eigen::Vector2d(p[0] - x, p[1]);
    t.radius = 0.2;
    t.radius_variance = 1e-4;
    t.range = t.center.norm();
    t.bearing = std::atan2(t.center.y(), t.center.x());
    t.covariance = 1e-4 * Eigen::Matrix2d::Identity();
    sweep.trunks.push_back(t);
  }
  return sweep;
}

/** A pipeline that has mapped the four trunks over 20 sweeps of a slow straight drive from @p t0. */
void mapFourTrunks(TrunkSlamPipeline* p, double t0, int sweeps = 20)
{
  for (int k = 0; k <= 2 * sweeps + 2; ++k)
    p->addOdometry(t0 + 0.05 * k, Pose2(0.01 * k, 0.0, 0.0));
  for (int s = 0; s < sweeps; ++s)
    p->addTrunks(fourTrunks(t0 + 0.1 * s, 0.02 * s));
  p->process();
}
}  // namespace

TEST(TrunkSlamPipelineFaults, OneLateMessageKeepsTheMapAndARealJumpKeepsTheOldOne)
{
  FastSlamConfig fc = rbpf_slam::test::quietConfig(20);
  TrunkSlamPipeline p(TrunkDetectorConfig(), fc);
  mapFourTrunks(&p, 100.0);
  ASSERT_EQ(p.filter().best().map.size(), 4u);
  // One odometry message and one sweep seconds late: dropped, the map and the timeline stay.
  EXPECT_EQ(p.addOdometry(98.0, Pose2()), StampVerdict::kBack);
  EXPECT_EQ(p.addTrunks(fourTrunks(95.0, 0.0)), StampVerdict::kBack);
  EXPECT_EQ(p.addOdometry(102.2, Pose2(0.44, 0.0, 0.0)), StampVerdict::kAccept);
  p.process();
  EXPECT_EQ(p.restarts(), 0);
  EXPECT_EQ(p.filter().best().map.size(), 4u);
  EXPECT_TRUE(p.takeEndedMaps().empty());
  // The bag starts again (three messages agree): a new map, and the old one is the caller's to save.
  EXPECT_EQ(p.addOdometry(100.0, Pose2()), StampVerdict::kBack);
  EXPECT_EQ(p.addOdometry(100.05, Pose2(0.01, 0.0, 0.0)), StampVerdict::kBack);
  EXPECT_EQ(p.addOdometry(100.1, Pose2(0.02, 0.0, 0.0)), StampVerdict::kReset);
  EXPECT_EQ(p.restarts(), 1);
  const std::vector<TimelineMap> ended = p.takeEndedMaps();
  ASSERT_EQ(ended.size(), 1u);
  EXPECT_EQ(ended[0].timeline, 0);
  EXPECT_EQ(ended[0].trees.size(), 4u);
  EXPECT_FALSE(ended[0].viewpoints.empty());
  EXPECT_TRUE(p.takeEndedMaps().empty());
  // Restarts nobody takes the maps of keep only the latest few: memory stays bounded.
  for (int r = 0; r < 5; ++r)
  {
    const double t0 = 50.0 - 10.0 * r;
    mapFourTrunks(&p, t0, 5);
    p.addOdometry(t0 - 5.0, Pose2(), t0 - 5.0);  // the clock went back with it: at once
  }
  EXPECT_EQ(p.takeEndedMaps().size(), TrunkSlamPipeline::kKeptEndedMaps);
}

TEST(TrunkSlamPipelineFaults, ArraysBeyondTheSensorsBoundAreDroppedAndTheMapIsBounded)
{
  FastSlamConfig fc = rbpf_slam::test::quietConfig(20);
  fc.max_landmarks = 3;
  TrunkSlamPipeline p(TrunkDetectorConfig(), fc);
  for (int k = 0; k <= 10; ++k)
    p.addOdometry(100.0 + 0.05 * k, Pose2());
  // 10000 trunks in one array: far beyond what a sensor can see; dropped before anything is queued, its stamp not
  // taken (the next array at the same stamp is accepted).
  TrunkSweep huge = fourTrunks(100.1, 0.0);
  huge.trunks.resize(10000, huge.trunks[0]);
  EXPECT_EQ(p.addTrunks(huge), StampVerdict::kOverLimit);
  EXPECT_EQ(p.pending(), 0u);
  EXPECT_EQ(p.addTrunks(fourTrunks(100.1, 0.0)), StampVerdict::kAccept);
  const std::vector<PipelineUpdate> done = p.process();
  ASSERT_EQ(done.size(), 1u);
  // Four trees seen, three landmarks allowed: the fourth is said, not made.
  EXPECT_EQ(p.filter().best().map.size(), 3u);
  EXPECT_EQ(done[0].stats.map_full, 1);
  // A saved map beyond the bound is refused.
  std::vector<Landmark> saved(4);
  for (std::size_t i = 0; i < saved.size(); ++i)
  {
    saved[i].id = static_cast<int>(i);
    saved[i].mean = Eigen::Vector2d(2.0 * i, 0.0);
    saved[i].covariance = 1e-4 * Eigen::Matrix2d::Identity();
  }
  EXPECT_THROW(p.setPriorMap(saved, Pose2()), std::invalid_argument);
}

TEST(FastSlamFaults, ASweepWithUnreadableDetectionsIsNoEvidenceOfAbsence)
{
  // Five landmarks mapped; then ten sweeps that report nothing. Complete sweeps delete the landmarks as missed;
  // sweeps that dropped unreadable detections (SensorScope::complete false) keep them all.
  for (const bool complete : { false, true })
  {
    FastSlam f(rbpf_slam::test::quietConfig(10));
    f.initialize();
    const Pose2 sensor;
    std::vector<LandmarkObservation> seen;
    for (int i = 0; i < 5; ++i)
      seen.push_back(rbpf_slam::test::observe(Pose2(), 3.0 + i, i % 2 ? 2.0 : -2.0));
    SensorScope scope;
    scope.min_range = 1.0;
    scope.max_range = 12.0;
    for (int k = 0; k < 5; ++k)
      f.update(seen, sensor, scope);
    ASSERT_EQ(f.best().map.size(), 5u);
    scope.complete = complete;
    for (int k = 0; k < 10; ++k)
      f.update({}, sensor, scope);
    if (complete)
      EXPECT_LT(f.best().map.size(), 5u) << "a complete empty sweep is evidence of absence";
    else
      EXPECT_EQ(f.best().map.size(), 5u) << "an incomplete sweep deleted landmarks";
  }
}

TEST(ConstellationFaults, AHugeMapBuildsItsPairsFromNeighboursAndTheSearchIsBounded)
{
  // The pairs from the grid of neighbours equal the pairs of the quadratic search on a random stand.
  Random rng(7);
  std::vector<Landmark> trees;
  for (int i = 0; i < 400; ++i)
  {
    Landmark l;
    l.id = i;
    l.mean = Eigen::Vector2d(rng.uniform(-100.0, 100.0), rng.uniform(-100.0, 100.0));
    l.radius = rng.uniform(0.1, 0.3);
    l.radius_variance = 1e-4;
    l.provisional = false;
    trees.push_back(l);
  }
  ConstellationConfig cc;
  std::size_t brute = 0;
  for (std::size_t a = 0; a < trees.size(); ++a)
    for (std::size_t b = a + 1; b < trees.size(); ++b)
    {
      const double d = (trees[a].mean - trees[b].mean).norm();
      brute += d >= cc.min_pair_length - cc.pair_tolerance && d <= cc.max_pair_length + cc.pair_tolerance ? 1 : 0;
    }
  EXPECT_EQ(ConstellationMatcher(trees, cc).mapPairs(), brute);
  // A regular plantation of 20000 trees (the largest map the filter takes): every seen pair matches thousands of map
  // pairs; the search stops at its work bound.
  std::vector<Landmark> rows;
  for (int i = 0; i < 20000; ++i)
  {
    Landmark l;
    l.id = i;
    l.mean = Eigen::Vector2d(3.0 * (i % 100), 3.0 * (i / 100));
    l.radius = 0.2;
    l.provisional = false;
    rows.push_back(l);
  }
  cc.max_candidates = 5000;
  const ConstellationMatcher m(rows, cc);
  std::vector<TrunkPoint> seen;
  for (int i = 0; i < 12; ++i)
  {
    TrunkPoint t;
    t.center = Eigen::Vector2d(3.0 * (i % 4), 3.0 * (i / 4));
    t.radius = 0.2;
    seen.push_back(t);
  }
  const ConstellationResult r = m.match(seen);
  EXPECT_TRUE(r.bounded);
  EXPECT_LE(r.candidates, cc.max_candidates);
}

namespace
{
/** The fusion settings of the fault tests: an anchor once 20 fixes have come. */
GnssFusionConfig anchorAfter20()
{
  GnssFusionConfig gc;
  gc.anchor_min_fixes = 20;
  return gc;
}
}  // namespace

/** An anchor estimator and a map frame 30 degrees from east at a known origin. */
class GnssFaults : public ::testing::Test
{
protected:
  GnssFusionConfig gc = anchorAfter20();
  GeoAnchorEstimator est{ gc };
  const LocalTangentPlane plane{ GeoPoint{ 61.0, 24.0, 100.0 } };
  const double yaw = 30.0 * M_PI / 180.0;
  const Eigen::Matrix2d R = Eigen::Rotation2Dd(yaw).toRotationMatrix();
};

TEST_F(GnssFaults, WildFirstFixesAreLeftOutOfTheAnchor)
{
  // The receiver's first 20 fixes lie 1000 km east (before any anchor exists, so no gate refuses them), then 60
  // good ones along an L of 600 m legs: the 20 are left out (counted) and the anchor lands where the good fixes put
  // it, though the tangent plane the fit works in is at the first, wild, fix.
  Random rng(5);
  for (int i = 0; i < 80; ++i)
  {
    const int k = std::max(0, i - 20);
    const Eigen::Vector2d map = k < 30 ? Eigen::Vector2d(20.0 * k, 0.0) : Eigen::Vector2d(580.0, 20.0 * (k - 29));
    Eigen::Vector2d en = R * map + Eigen::Vector2d(rng.gaussian(1.0), rng.gaussian(1.0));
    if (i < 20)
      en += Eigen::Vector2d(1e6, 0.0);
    est.add(rbpf_slam::test::validFix(plane.toGeo(en, 100.0), 10.0 * i), map);
  }
  int outliers = 0;
  const GeoAnchor a = est.anchor(&outliers);
  ASSERT_TRUE(a.valid);
  EXPECT_EQ(outliers, 20);
  const Eigen::Vector2d off = plane.toEastNorth(a.latitude, a.longitude);
  EXPECT_LT(off.norm(), 1.0) << "origin moved " << off.transpose();
  EXPECT_LT(std::abs(std::remainder(a.yaw - yaw, 2.0 * M_PI)), 0.05);
}

TEST_F(GnssFaults, WildFixesMoveNeitherTheAnchorNorTheFilter)
{
  // A drive of 60 fixes along an L (the antenna's map positions), the map frame 30 degrees from east at a known
  // origin; 10 of the fixes jump 1000 km away in a row (a receiver's fault).
  Random rng(3);
  for (int i = 0; i < 60; ++i)
  {
    const Eigen::Vector2d map = i < 30 ? Eigen::Vector2d(1.0 * i, 0.0) : Eigen::Vector2d(29.0, 1.0 * (i - 29));
    Eigen::Vector2d en = R * map + Eigen::Vector2d(rng.gaussian(1.0), rng.gaussian(1.0));
    if (i >= 40 && i < 50)
      en += Eigen::Vector2d(1e6, 0.0);  // 1000 km east
    est.add(rbpf_slam::test::validFix(plane.toGeo(en, 100.0), 10.0 * i), map);
  }
  int outliers = 0;
  const GeoAnchor a = est.anchor(&outliers);
  ASSERT_TRUE(a.valid);
  EXPECT_EQ(outliers, 10);
  const Eigen::Vector2d off = plane.toEastNorth(a.latitude, a.longitude);
  EXPECT_LT(off.norm(), 2.0) << "origin moved " << off.transpose();
  EXPECT_LT(std::abs(std::remainder(a.yaw - yaw, 2.0 * M_PI)), 0.05);
  EXPECT_LT(a.sigma, 2.0);
  // The innovation gate: a fix where the anchor and the filter put the antenna passes, one 1000 km off does not.
  GnssFix good;
  good.valid = true;
  good.latitude = 61.0;
  good.longitude = 24.0;
  good.covariance = Eigen::Matrix2d::Identity();
  EXPECT_LT(gnssInnovation(good, a, 1.0, geoToAnchored(a, 61.0, 24.0), 0.01 * Eigen::Matrix2d::Identity()), kGnssGate2);
  const GeoPoint far = plane.toGeo(Eigen::Vector2d(1e6, 0.0), 100.0);
  GnssFix wild = good;
  wild.latitude = far.latitude;
  wild.longitude = far.longitude;
  EXPECT_GT(gnssInnovation(wild, a, 1.0, geoToAnchored(a, 61.0, 24.0), 0.01 * Eigen::Matrix2d::Identity()), kGnssGate2);
  // A negative sigma bound is refused.
  gc.max_sigma = -5.0;
  EXPECT_NE(gc.validate().find("gps/max_sigma"), std::string::npos);
  TrunkSlamConfig fc;
  fc.gnss.max_sigma = -5.0;
  EXPECT_FALSE(fc.validate().empty());
  // The filter alone does not know the fixes: the pipeline that owns them refuses them.
  EXPECT_TRUE(static_cast<const FastSlamConfig&>(fc).validate().empty());
  EXPECT_THROW(TrunkSlamPipeline(TrunkDetectorConfig(), fc), std::invalid_argument);
}

TEST(HistoryNode, MillionsOfEntriesAreFreedWithoutRecursion)
{
  // The recursive release overflowed an 8 MB stack between 500k and 700k entries; 3M would need ~200 MB of stack.
  using Node = HistoryNode<Pose2>;
  Node::Ptr head;
  for (int i = 0; i < 3000000; ++i)
    head = std::make_shared<const Node>(Pose2(i, 0.0, 0.0), std::move(head));
  Node::Ptr branch = std::make_shared<const Node>(Pose2(-1.0, 0.0, 0.0), head);  // shares all of them
  head.reset();  // nothing freed: the branch holds the chain
  int n = 0;
  for (const Node* p = branch.get(); p; p = p->parent.get())
    ++n;
  EXPECT_EQ(n, 3000001);
  branch.reset();  // all freed here, iteratively
  SUCCEED();
}

namespace
{
PlanarScan wallScan()
{
  // A straight wall 3 m ahead seen by a 270-degree, 0.25-degree scanner.
  PlanarScan scan;
  scan.angle_min = -0.75 * M_PI;
  scan.angle_increment = M_PI / 720.0;
  scan.range_min = 0.05;
  scan.range_max = 30.0;
  for (int i = 0; i < 1081; ++i)
  {
    const double a = scan.angle_min + i * scan.angle_increment;
    scan.ranges.push_back(std::cos(a) > 0.1 ? static_cast<float>(3.0 / std::cos(a))
                                            : std::numeric_limits<float>::infinity());
  }
  return scan;
}
}  // namespace

TEST(TrunkDetectorFaults, DropoutsInAWallMakeNoTrunks)
{
  TrunkDetectorConfig c;
  TrunkDetector det(c);
  ASSERT_EQ(det.detectScan(wallScan()).size(), 0u) << "the intact wall";
  const float bad[] = { std::numeric_limits<float>::quiet_NaN(), -std::numeric_limits<float>::infinity(), 0.0f, 0.01f };
  for (const int every : { 5, 10, 20, 2 })
    for (const float value : bad)
    {
      PlanarScan scan = wallScan();
      for (std::size_t i = 0; i < scan.ranges.size(); i += static_cast<std::size_t>(every))
        scan.ranges[i] = value;
      EXPECT_EQ(det.detectScan(scan).size(), 0u) << "every " << every << "th beam " << value;
    }
}

TEST(TrunkDetectorFaults, ATrunkWithDropoutsIsStillOneTrunk)
{
  PlanarScan scan;
  scan.angle_min = -0.5;
  scan.angle_increment = M_PI / 720.0;
  scan.range_min = 0.05;
  scan.range_max = 30.0;
  const Eigen::Vector2d c(4.0, 0.0);
  for (int i = 0; i < 400; ++i)
  {
    const double a = scan.angle_min + i * scan.angle_increment;
    const Eigen::Vector2d d(std::cos(a), std::sin(a));
    const double b = d.dot(c), disc = b * b - (c.squaredNorm() - 0.2 * 0.2);
    scan.ranges.push_back(disc >= 0.0 ? static_cast<float>(b - std::sqrt(disc)) : std::numeric_limits<float>::infinity());
  }
  int hits = 0;
  for (auto& r : scan.ranges)
    if (std::isfinite(r) && ++hits % 4 == 0)
      r = std::numeric_limits<float>::quiet_NaN();
  TrunkDetectorConfig cfg;
  cfg.min_points = 3;
  const auto obs = TrunkDetector(cfg).detectScan(scan);
  ASSERT_EQ(obs.size(), 1u);
  EXPECT_NEAR(obs[0].center.x(), 4.0, 0.05);
  EXPECT_NEAR(obs[0].radius, 0.2, 0.05);
}

TEST(GridSlamFaults, AStandingRobotAddsNothing)
{
  for (const GridSlamMode mode : { GridSlamMode::kSingleMap, GridSlamMode::kRbpf })
  {
    GridSlamConfig c;
    c.mode = mode;
    c.particles = 5;
    const std::unique_ptr<GridSlam> slam = GridSlam::create(c);
    const Pose2 parked(1.0, 0.5, 0.3);
    const ScanData scan = grid_test_world::simulateScan(parked);
    slam->update(parked, scan, Pose2(), 0.0);
    std::vector<std::int8_t> before, after;
    int w, h;
    MapOrigin o;
    slam->map().exportProbabilities(&before, &w, &h, &o);
    const std::vector<GridParticle> particles = slam->particles();
    // 2000 scans of the parked robot (odometry jitters by a millimetre): the map and the particles stay as they are.
    for (int i = 1; i <= 2000; ++i)
    {
      const Pose2 jitter(parked.x + 0.001 * std::sin(i), parked.y, parked.theta + 0.001 * std::cos(i));
      EXPECT_TRUE(slam->update(jitter, scan, Pose2(), 0.025 * i).skipped);
    }
    slam->map().exportProbabilities(&after, &w, &h, &o);
    EXPECT_EQ(before, after);
    ASSERT_EQ(slam->particles().size(), particles.size());
    for (std::size_t i = 0; i < particles.size(); ++i)
      EXPECT_EQ(slam->particles()[i].pose.x, particles[i].pose.x);
    // The pose still follows the odometry in between.
    const Pose2 moved = slam->poseAt(Pose2(parked.x + 0.05, parked.y, parked.theta));
    EXPECT_NEAR(std::hypot(moved.x - slam->mappingPose().x, moved.y - slam->mappingPose().y), 0.05, 1e-9);
    // Moving past the threshold (the default, 1 m), or waiting past temporal_update, processes again.
    EXPECT_FALSE(slam->update(Pose2(parked.x + 1.05, parked.y, parked.theta), scan, Pose2(), 60.0).skipped);
    c.temporal_update = 5.0;
    const std::unique_ptr<GridSlam> timed = GridSlam::create(c);
    timed->update(parked, scan, Pose2(), 0.0);
    EXPECT_TRUE(timed->update(parked, scan, Pose2(), 4.0).skipped);
    EXPECT_FALSE(timed->update(parked, scan, Pose2(), 5.5).skipped);
  }
}

TEST(ConfigFaults, ParticleCountsAreBounded)
{
  GridSlamConfig g;
  g.particles = 10000000;
  EXPECT_NE(g.validate().find("particles must be in 1..5000"), std::string::npos) << g.validate();
  EXPECT_THROW(GridSlam::create(g), std::invalid_argument);
  g.particles = GridSlamConfig::kMaxParticles;
  EXPECT_TRUE(g.validate().empty());
  g.linear_update = -1.0;
  EXPECT_NE(g.validate().find("linear_update"), std::string::npos);
  FastSlamConfig f;
  f.particles = 10000000;
  EXPECT_NE(f.validate().find("particles must be in 1..100000"), std::string::npos) << f.validate();
  EXPECT_THROW(FastSlam{ f }, std::invalid_argument);
  f.particles = -5;
  EXPECT_FALSE(f.validate().empty());
}
