#include <algorithm>
#include <cmath>
#include <limits>
#include <iostream>
#include <vector>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "core/grid/grid_test_world.h"
#include <memory>

#include "rbpf_slam/core/grid/grid_slam.h"
#include "rbpf_slam/core/grid/occupancy_grid.h"
#include "rbpf_slam/core/grid/scan_matcher.h"

using namespace rbpf_slam::core;
using namespace grid_test_world;

namespace
{
OccupancyGrid roomMap(const OccupancyGridConfig& config = OccupancyGridConfig())
{
  OccupancyGrid map(config);
  const ScanLimits limits;
  const std::vector<Pose2> path = truePath();
  for (std::size_t i = 0; i < path.size(); i += 5)
    map.insertScan(path[i], simulateScan(path[i]), limits);
  return map;
}

bool sameCells(const OccupancyGrid& a, const OccupancyGrid& b)
{
  std::vector<std::int8_t> da, db;
  int wa, ha, wb, hb;
  MapOrigin oa, ob;
  a.exportProbabilities(&da, &wa, &ha, &oa);
  b.exportProbabilities(&db, &wb, &hb, &ob);
  return wa == wb && ha == hb && da == db;
}
}  // namespace

TEST(GridRbpf, CopyOnWriteKeepsParticleMapsIndependent)
{
  const OccupancyGrid original = roomMap();
  OccupancyGrid a = original;  // as resampling copies a particle: tile pointers only
  OccupancyGrid b = original;
  ASSERT_GT(original.tileCount(), 4u);
  for (int ty = a.tileY0(); ty < a.tileY0() + a.tilesY(); ++ty)
    for (int tx = a.tileX0(); tx < a.tileX0() + a.tilesX(); ++tx)
      EXPECT_EQ(a.sharesTileWith(b, tx, ty), original.tileAt(tx, ty) != nullptr);
  // A scan into one copy from a pose near the room's lower-left corner.
  const Pose2 pose(-3.0, -2.0, 0.3);
  a.insertScan(pose, simulateScan(pose), ScanLimits());
  EXPECT_TRUE(sameCells(b, original));  // the other copy never changes
  EXPECT_FALSE(sameCells(a, original));
  int cloned = 0, shared = 0;
  for (int ty = b.tileY0(); ty < b.tileY0() + b.tilesY(); ++ty)
    for (int tx = b.tileX0(); tx < b.tileX0() + b.tilesX(); ++tx)
    {
      if (!original.tileAt(tx, ty))
        continue;
      if (a.sharesTileWith(b, tx, ty))
        ++shared;
      else
        ++cloned;
      EXPECT_TRUE(b.sharesTileWith(original, tx, ty));
    }
  EXPECT_GT(cloned, 0);
  EXPECT_GT(shared, 0);  // tiles the scan did not touch stay shared
  // A write through the other copy: a's content stays as it was.
  OccupancyGrid a_before = a;
  b.addLogOdds(0, 0, 5.0f);
  EXPECT_TRUE(sameCells(a, a_before));
  EXPECT_FLOAT_EQ(b.logOdds(0, 0), original.logOdds(0, 0) + 5.0f);
  EXPECT_FLOAT_EQ(a.logOdds(0, 0), a_before.logOdds(0, 0));
}

TEST(GridRbpf, ScanMatcherRecoversAKnownOffset)
{
  const OccupancyGrid map = roomMap();
  const Pose2 truth(0.3, -0.4, 0.35);
  std::vector<std::pair<double, double>> ends;
  Random noise(3);
  GridSlam::scanEndPoints(simulateScan(truth, &noise), ScanLimits(), 1, &ends);
  ScanMatcher matcher;
  const ScanMatch at_truth = matcher.evaluate(map, truth, Pose2(), ends);
  EXPECT_GT(at_truth.matched, static_cast<int>(0.9 * ends.size()));
  const double deg = M_PI / 180.0;
  const Pose2 starts[] = { Pose2(truth.x + 0.2, truth.y, truth.theta + 5 * deg),
                           Pose2(truth.x - 0.1, truth.y + 0.15, truth.theta - 5 * deg),
                           Pose2(truth.x + 0.14, truth.y - 0.14, truth.theta + 3 * deg) };
  for (const Pose2& start : starts)
  {
    const ScanMatch m = matcher.match(map, start, Pose2(), ends);
    EXPECT_NEAR(m.pose.x, truth.x, 0.03);
    EXPECT_NEAR(m.pose.y, truth.y, 0.03);
    EXPECT_NEAR(wrapAngle(m.pose.theta - truth.theta), 0.0, 1.0 * deg);
    EXPECT_GE(m.score, matcher.evaluate(map, start, Pose2(), ends).score);
    EXPECT_GT(m.log_likelihood, matcher.evaluate(map, start, Pose2(), ends).log_likelihood);
  }
  // With a sensor mounted off the robot's centre, the robot pose is found (not the sensor's).
  const Pose2 sensor(0.2, 0.05, 0.1);
  GridSlam::scanEndPoints(simulateScan(truth * sensor), ScanLimits(), 1, &ends);
  const ScanMatch m = matcher.match(map, Pose2(truth.x - 0.2, truth.y + 0.05, truth.theta - 4 * deg), sensor, ends);
  EXPECT_NEAR(m.pose.x, truth.x, 0.03);
  EXPECT_NEAR(m.pose.y, truth.y, 0.03);
  EXPECT_NEAR(wrapAngle(m.pose.theta - truth.theta), 0.0, 1.0 * deg);
}

TEST(GridRbpf, CoarseToFineWidensTheCaptureRange)
{
  // Starts on rings of growing offset (position and heading together): the coarse climb (3 x 3 coarse cells,
  // wide score) must recover every start up to 0.3 m / 8 deg, and clearly more starts of all
  // rings (to 0.6 m / 16 deg) than the fine climb alone.
  const OccupancyGrid map = roomMap();
  const Pose2 truth(0.3, -0.4, 0.35);
  std::vector<std::pair<double, double>> ends;
  GridSlam::scanEndPoints(simulateScan(truth), ScanLimits(), 1, &ends);
  const double deg = M_PI / 180.0;
  // The shipped matcher (rbpf/* of config/grid_slam_advanced.yaml), with and without its coarse level.
  ScanMatcherConfig fine_only;
  fine_only.linear_step = fine_only.angular_step = 0.1;
  fine_only.refinements = 2;
  ScanMatcherConfig coarse = fine_only;
  coarse.coarse_kernel = 1;
  coarse.coarse_sigma = 0.15;
  coarse.coarse_beam_step = 4;
  coarse.coarse_refinements = 2;
  ASSERT_EQ(coarse.validate(), "");
  const ScanMatcher fine_matcher(fine_only), coarse_matcher(coarse);
  // Per axis within 4 cm: the likelihood field measures to cell centres, so a match can sit half a cell (2.5 cm)
  // plus a last step (6 mm) off.
  const auto recovered = [&](const ScanMatch& m) {
    return std::abs(m.pose.x - truth.x) < 0.04 && std::abs(m.pose.y - truth.y) < 0.04 &&
           std::abs(wrapAngle(m.pose.theta - truth.theta)) < 1.0 * deg;
  };
  int fine_ok = 0, coarse_ok = 0;
  for (const double scale : { 0.5, 1.0, 1.5, 2.0 })
    for (int k = 0; k < 8; ++k)
    {
      const double a = k * M_PI / 4.0;
      const Pose2 start(truth.x + scale * 0.3 * std::cos(a), truth.y + scale * 0.3 * std::sin(a),
                        truth.theta + (k % 2 ? 1 : -1) * scale * 8 * deg);
      const ScanMatch cm = coarse_matcher.match(map, start, Pose2(), ends);
      const bool c = recovered(cm);
      if (scale <= 1.0)
      {
        EXPECT_TRUE(c) << "offset scale " << scale << ", direction " << k;
      }
      coarse_ok += c;
      fine_ok += recovered(fine_matcher.match(map, start, Pose2(), ends));
    }
  EXPECT_GE(coarse_ok, fine_ok + 6);  // measured: 29 and 20
  std::cout << "recovered of 32 starts: coarse-to-fine " << coarse_ok << ", fine only " << fine_ok << std::endl;
}

namespace
{
struct RbpfRun
{
  std::vector<Pose2> poses;
  std::vector<std::vector<Pose2>> particles;
  std::vector<bool> resampled;
  std::vector<double> neff;
  std::vector<std::int8_t> map;
  double final_error = 0.0, odometry_error = 0.0, worst_error = 0.0;
  std::vector<Pose2> history;
};

RbpfRun runRoomRbpf(std::uint64_t seed, double neff_ratio = 0.5, double motion_weight = 0.0)
{
  GridSlamConfig c;
  c.mode = GridSlamMode::kRbpf;
  c.seed = seed;
  c.particles = 10;
  c.resampling.method = ResamplingMethod::kLowVariance;
  c.resampling.neff_ratio = neff_ratio;
  c.proposal_motion_weight = motion_weight;
  c.linear_update = c.angular_update = 0.0;  // every scan: the algorithm itself (thresholds: test_faults.cpp)
  const std::unique_ptr<GridSlam> slam = GridSlam::create(c);
  const std::vector<Pose2> path = truePath();
  Random odo_noise(99);
  Pose2 odom = path.front();
  const Pose2 sensor(0.1, 0.0, 0.0);
  RbpfRun r;
  for (std::size_t i = 0; i < path.size(); ++i)
  {
    if (i > 0)
    {
      const Pose2 d = between(path[i - 1], path[i]);
      odom = odom * Pose2(d.x * 1.02, d.y, d.theta + 0.02 * std::hypot(d.x, d.y) + odo_noise.gaussian(0.002));
    }
    const GridSlamStep step = slam->update(odom, simulateScan(path[i] * sensor), sensor);
    r.poses.push_back(slam->mappingPose());
    r.resampled.push_back(step.resampled);
    r.neff.push_back(step.neff);
    std::vector<Pose2> ps;
    for (const auto& p : slam->particles())
      ps.push_back(p.pose);
    r.particles.push_back(ps);
    r.worst_error = std::max(r.worst_error, std::hypot(slam->mappingPose().x - path[i].x, slam->mappingPose().y - path[i].y));
  }
  r.final_error = std::hypot(slam->mappingPose().x - path.back().x, slam->mappingPose().y - path.back().y);
  r.odometry_error = std::hypot(odom.x - path.back().x, odom.y - path.back().y);
  int w, h;
  MapOrigin o;
  slam->map().exportProbabilities(&r.map, &w, &h, &o);
  r.history = slam->bestTrajectory();
  EXPECT_EQ(r.history.size(), path.size());
  return r;
}
}  // namespace

TEST(GridRbpf, SameSeedSameResultAndFollowsTheTruth)
{
  const RbpfRun a = runRoomRbpf(7);
  const RbpfRun b = runRoomRbpf(7);
  ASSERT_EQ(a.poses.size(), b.poses.size());
  for (std::size_t i = 0; i < a.poses.size(); ++i)
  {
    ASSERT_EQ(a.poses[i].x, b.poses[i].x) << i;
    ASSERT_EQ(a.poses[i].y, b.poses[i].y) << i;
    ASSERT_EQ(a.poses[i].theta, b.poses[i].theta) << i;
  }
  EXPECT_EQ(a.map, b.map);
  const RbpfRun c = runRoomRbpf(8);
  EXPECT_NE(a.poses.back().x, c.poses.back().x);
  // Scan matching against its own map holds every particle on the truth while odometry drifts away.
  EXPECT_GT(a.odometry_error, 0.5);
  EXPECT_LT(a.final_error, 0.1);
  EXPECT_LT(a.worst_error, 0.15);
  EXPECT_LT(c.final_error, 0.1);
  EXPECT_LT(c.worst_error, 0.15);
}

TEST(GridRbpf, MotionWeightedProposalChangesTheWeightsAndFollowsTheTruth)
{
  // The motion model in the weight (proposal_motion_weight of config/grid_slam_advanced.yaml) changes the weights,
  // hence the run, and the filter still holds the drifting-odometry loop.
  const RbpfRun plain = runRoomRbpf(7);
  const RbpfRun weighted = runRoomRbpf(7, 0.5, 1.0);
  bool differs = false;
  for (std::size_t i = 0; i < plain.neff.size() && !differs; ++i)
    differs = std::abs(plain.neff[i] - weighted.neff[i]) > 1e-9;
  EXPECT_TRUE(differs);
  EXPECT_GT(weighted.odometry_error, 0.5);
  EXPECT_LT(weighted.final_error, 0.1);
  EXPECT_LT(weighted.worst_error, 0.15);
  GridSlamConfig bad;
  bad.proposal_motion_weight = -1.0;
  EXPECT_NE(bad.validate(), "");
}

TEST(GridRbpf, SelectiveResamplingLeavesParticlesAloneAboveTheThreshold)
{
  // Ratio 0.5: a step resamples exactly when Neff < N / 2 (10 particles); above it the particles are left alone.
  const RbpfRun half = runRoomRbpf(7, 0.5);
  int kept = 0;
  for (std::size_t i = 1; i < half.resampled.size(); ++i)
  {
    ASSERT_EQ(half.resampled[i], half.neff[i] < 5.0) << i << " neff " << half.neff[i];
    kept += half.resampled[i] ? 0 : 1;
  }
  EXPECT_GT(kept, 0);
  // Ratio 0: Neff is never below 0, so no step resamples.
  const RbpfRun never = runRoomRbpf(7, 0.0);
  for (std::size_t i = 0; i < never.resampled.size(); ++i)
    ASSERT_FALSE(never.resampled[i]) << i;
  // Ratio 1: Neff < N on any step whose weights are not exactly uniform: resampling happens.
  const RbpfRun always = runRoomRbpf(7, 1.0);
  int count = 0;
  for (bool r : always.resampled)
    count += r ? 1 : 0;
  EXPECT_GT(count, 10);
}

TEST(GridRbpf, ResamplingIsSkippedWhenNeffIsAboveTheThreshold)
{
  // One step with uniform-ish weights: with two particles in the same place, the weights are equal, Neff = N.
  GridSlamConfig c;
  c.mode = GridSlamMode::kRbpf;
  c.particles = 5;
  c.motion = OdometryMotionNoise{ 0.0, 0.0, 0.0, 0.0 };
  c.proposal_sigma_xy = 0.0;
  c.proposal_sigma_theta = 0.0;
  c.linear_update = c.angular_update = 0.0;  // every scan: the 5 cm step below is weighed, not skipped
  const std::unique_ptr<GridSlam> slam = GridSlam::create(c);
  const Pose2 p0(0.0, 0.0, 0.0), p1(0.05, 0.0, 0.0);
  slam->update(p0, simulateScan(p0), Pose2());
  const GridSlamStep s = slam->update(p1, simulateScan(p1), Pose2());
  EXPECT_NEAR(s.neff, 5.0, 1e-9);
  EXPECT_FALSE(s.resampled);
  for (const auto& p : slam->particles())
  {
    EXPECT_NEAR(p.weight, 0.2, 1e-12);
    EXPECT_NEAR(p.pose.x, slam->particles()[0].pose.x, 1e-12);
  }
  // Each particle has its own map; untouched-by-anyone tiles stay shared between them.
  EXPECT_EQ(&slam->particleMap(0), &slam->map());
}

TEST(GridRbpf, ParsesTheMode)
{
  GridSlamMode m = GridSlamMode::kSingleMap;
  EXPECT_TRUE(parseGridSlamMode("rbpf", &m));
  EXPECT_EQ(m, GridSlamMode::kRbpf);
  EXPECT_FALSE(parseGridSlamMode("gmapping", &m));
  GridSlamConfig c;
  c.matcher.beam_step = 0;
  EXPECT_NE(c.validate().find("beam_step"), std::string::npos);
}

TEST(GridRbpf, TrackedHitPointsLieWhereTheBeamsEnd)
{
  OccupancyGridConfig tracking;
  tracking.track_hits = true;
  const OccupancyGrid map = roomMap(tracking);
  // The room's south wall lies at y = -3 m, on the edge of its cells (centres at -2.975 m): their mean hit points
  // lie on it.
  int ix, iy;
  map.cellOf(0.01, -2.999, &ix, &iy);
  ASSERT_TRUE(map.occupied(ix, iy));
  double hx, hy;
  map.hitPoint(ix, iy, &hx, &hy);
  EXPECT_NEAR(hy, -3.0, 0.002);
  EXPECT_GE(hx, ix * map.resolution());
  EXPECT_LT(hx, (ix + 1) * map.resolution());
  OccupancyGrid untracked = roomMap();  // without track_hits: the centre
  untracked.hitPoint(ix, iy, &hx, &hy);
  EXPECT_NEAR(hy, -3.0 + 0.5 * map.resolution(), 0.001);
}

TEST(GridRbpf, ThreadsGiveTheSameResult)
{
  // The random draws are made before the matches, in particle order: two or three threads give the one-thread run.
  const std::vector<Pose2> path = truePath();
  std::vector<std::vector<Pose2>> runs;
  for (int threads : { 1, 2, 3 })
  {
    GridSlamConfig config;
    config.mode = GridSlamMode::kRbpf;
    config.particles = 7;
    config.threads = threads;
    config.linear_update = config.angular_update = 0.0;
    auto slam = GridSlam::create(config);
    Random drift(4);
    Pose2 odometry;
    for (std::size_t i = 0; i < path.size(); i += 3)
    {
      if (i > 0)
        odometry = odometry * (path[i - 3].inverse() * path[i]) * Pose2(0.002, 0.0, drift.gaussian(0.01));
      slam->update(odometry, simulateScan(path[i]), Pose2());
    }
    runs.push_back(slam->bestTrajectory());
  }
  ASSERT_GT(runs[0].size(), 10u);
  for (std::size_t r = 1; r < runs.size(); ++r)
  {
    ASSERT_EQ(runs[r].size(), runs[0].size());
    for (std::size_t k = 0; k < runs[0].size(); ++k)
    {
      EXPECT_EQ(runs[r][k].x, runs[0][k].x);
      EXPECT_EQ(runs[r][k].y, runs[0][k].y);
      EXPECT_EQ(runs[r][k].theta, runs[0][k].theta);
    }
  }
  GridSlamConfig bad;
  bad.threads = 0;
  EXPECT_NE(bad.validate(), "");
}

namespace
{
// A corridor 2 m wide along +x, closed behind the start (x = -1 m), seen by a 181-beam scanner that reaches 4 m:
// every scan ends a metre beyond what the map holds, and the match slides back onto the mapped walls.
ScanData corridorScan(const Pose2& sensor)
{
  const auto cast = [](double x, double y, double a) {
    const double dx = std::cos(a), dy = std::sin(a);
    double r = std::numeric_limits<double>::infinity();
    if (std::abs(dy) > 1e-9)
      r = std::min(r, ((dy > 0 ? 1.0 : -1.0) - y) / dy);
    if (dx < -1e-9)
      r = std::min(r, (-1.0 - x) / dx);
    return r;
  };
  return castScan(sensor, cast, 4.0);
}

struct CorridorRun
{
  double final_error = 0.0, odometry_error = 0.0;
  int vetoed = 0, trusted = 0;
};

// 40 m down the corridor, a scan processed per metre (the node's default travel threshold), odometry 1 % short.
CorridorRun driveCorridor(double veto)
{
  GridSlamConfig c;
  c.mode = GridSlamMode::kRbpf;
  c.particles = 5;
  c.seed = 3;
  c.odometry_veto = veto;
  c.linear_update = c.angular_update = 0.0;
  const std::unique_ptr<GridSlam> slam = GridSlam::create(c);
  CorridorRun r;
  Pose2 truth, odom;
  for (int i = 0; i <= 40; ++i)
  {
    if (i > 0)
    {
      truth = Pose2(truth.x + 1.0, 0.0, 0.0);
      odom = Pose2(odom.x + 0.99, 0.0, 0.0);
    }
    const GridSlamStep s = slam->update(odom, corridorScan(truth), Pose2());
    r.vetoed += s.matches_vetoed;
    r.trusted += s.matches_trusted;
  }
  r.final_error = std::hypot(slam->mappingPose().x - truth.x, slam->mappingPose().y - truth.y);
  r.odometry_error = std::hypot(odom.x - truth.x, odom.y - truth.y);
  return r;
}
}  // namespace

TEST(GridRbpf, TheOdometryVetoesAMatchThatSlidesBackAlongACorridor)
{
  // Without the veto the matches slide back towards where the map ends, up to a metre a scan: the estimate falls
  // behind by more than 10 m over 40 m (measured 17.6 m; the odometry is off by 0.4 m).
  const CorridorRun slid = driveCorridor(0.0);
  EXPECT_NEAR(slid.odometry_error, 0.4, 1e-9);
  EXPECT_GT(slid.final_error, 10.0);
  EXPECT_EQ(slid.vetoed, 0);
  // With the default bound (10 standard deviations) the slides beyond it are refused: the particle keeps the
  // odometry's position and matches only its heading. The slides within it still add up (measured 3.8 m).
  const CorridorRun held = driveCorridor(GridSlamConfig().odometry_veto);
  EXPECT_GT(held.vetoed, 30);  // of 5 particles x 40 scans
  EXPECT_LT(held.final_error, 5.0);
  // A bound of 99.9 % (chi-square, 3 degrees of freedom) refuses the smaller slides too (measured 0.9 m).
  const CorridorRun tight = driveCorridor(16.27);
  EXPECT_GT(tight.vetoed, held.vetoed);
  EXPECT_LT(tight.final_error, 2.0);
  GridSlamConfig bad;
  bad.odometry_veto = -1.0;
  EXPECT_NE(bad.validate().find("odometry_veto"), std::string::npos);
}

TEST(GridRbpf, AMatchsInformationIsNearZeroAlongACorridorAndLargeAcrossIt)
{
  // The corridor of the veto's test, mapped from x = 0 to 10 m; its end wall (x = -1) is beyond the 4 m reach
  // from x = 5: nothing there fixes the position along it.
  OccupancyGrid corridor{ OccupancyGridConfig() };
  for (int i = 0; i <= 10; ++i)
    corridor.insertScan(Pose2(i, 0.0, 0.0), corridorScan(Pose2(i, 0.0, 0.0)), ScanLimits());
  std::vector<std::pair<double, double>> ends;
  const Pose2 at(5.0, 0.0, 0.0);
  GridSlam::scanEndPoints(corridorScan(at), ScanLimits(), 1, &ends);
  const ScanMatcher matcher;
  int evaluations = 0;
  const Eigen::Matrix3d info = matcher.information(corridor, at, Pose2(), ends, &evaluations);
  EXPECT_EQ(evaluations, 18);
  EXPECT_GT(info(1, 1), 1000.0);  // across [1/m^2]: the walls
  EXPECT_GT(info(2, 2), 100.0);   // the heading
  EXPECT_LT(info(0, 0), 0.01 * info(1, 1));  // along: nearly none
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(info).eigenvalues().minCoeff(), -1e-9);  // PSD

  // In the room every direction is fixed.
  const OccupancyGrid room = roomMap();
  const Pose2 inside(1.0, 0.5, 0.3);
  GridSlam::scanEndPoints(simulateScan(inside), ScanLimits(), 1, &ends);
  const Eigen::Matrix3d fixed = matcher.information(room, inside, Pose2(), ends, &evaluations);
  EXPECT_GT(fixed(0, 0), 0.1 * fixed(1, 1));
  EXPECT_GT(fixed(1, 1), 0.1 * fixed(0, 0));
}

namespace
{
// Around the room, every scan processed; at step @p slip_at the odometry reports a turn of 0.2 rad that did not
// happen (a wheel slip), and keeps it. Returns the final position error of the estimate and the matches taken by
// the particles' common correction.
std::pair<double, int> driveThroughASlip(bool consensus, bool with_slip)
{
  GridSlamConfig c;
  c.mode = GridSlamMode::kRbpf;
  c.particles = 10;
  c.seed = 5;
  c.linear_update = c.angular_update = 0.0;
  c.veto_consensus = consensus;
  const std::unique_ptr<GridSlam> slam = GridSlam::create(c);
  const std::vector<Pose2> path = truePath();
  const std::size_t slip_at = 60;
  const Pose2 slip(0.0, 0.0, with_slip ? 0.2 : 0.0);
  int taken = 0;
  for (std::size_t i = 0; i < path.size(); i += 2)
  {
    // The odometry: the true path, turned by the slip from slip_at on (about the pose where it happened).
    Pose2 odom = path[i];
    if (i >= slip_at)
      odom = path[slip_at] * slip * (path[slip_at].inverse() * path[i]);
    taken += slam->update(odom, simulateScan(path[i]), Pose2()).matches_consensus;
  }
  const Pose2& end = slam->mappingPose();
  return { std::hypot(end.x - path.back().x, end.y - path.back().y), taken };
}
}  // namespace

TEST(GridRbpf, WhenTheOdometrySlipsEveryParticlesMatchIsRefusedAndTheirCommonCorrectionIsTaken)
{
  // No slip: nothing is refused by most particles, the consensus takes nothing and changes nothing.
  const auto plain = driveThroughASlip(false, false), plain_consensus = driveThroughASlip(true, false);
  EXPECT_EQ(plain_consensus.second, 0);
  EXPECT_DOUBLE_EQ(plain.first, plain_consensus.first);
  EXPECT_LT(plain.first, 0.1);
  // A 0.2 rad slip at a 5 cm step is far beyond the veto (its heading spread there is about 0.01 rad): every
  // particle's match is refused, the estimate keeps the slip and the map is built turned.
  const auto refused = driveThroughASlip(false, true);
  EXPECT_GT(refused.first, 0.3);  // measured 0.49 m
  // The consensus takes the matches the particles agree on: the estimate follows the scan.
  const auto taken = driveThroughASlip(true, true);
  EXPECT_GT(taken.second, 5);
  EXPECT_LT(taken.first, 0.1);
}
