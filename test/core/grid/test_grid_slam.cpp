#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/eval/evaluation.h"
#include <memory>

#include "rbpf_slam/core/grid/grid_slam.h"
#include "rbpf_slam/core/filter/particle_filter.h"
#include "rbpf_slam/core/filter/random.h"
#include "rbpf_slam/core/filter/skid_steer_odometry.h"
#include "core/grid/grid_test_world.h"

using namespace rbpf_slam::core;
using namespace rbpf_slam::eval;
using namespace grid_test_world;

TEST(GridSlam, ScanScorePeaksAtTheTruePose)
{
  // The map made from exact poses; then the correlation of a scan from a known pose is largest there.
  OccupancyGrid map;
  const ScanLimits limits;
  const std::vector<Pose2> path = truePath();
  for (std::size_t i = 0; i < path.size(); i += 5)
    map.insertScan(path[i], simulateScan(path[i]), limits);
  const Pose2 truth(0.3, -0.4, 0.35);
  std::vector<std::pair<double, double>> ends;
  Random noise(3);
  GridSlam::scanEndPoints(simulateScan(truth, &noise), limits, 1, &ends);
  ASSERT_GT(ends.size(), 150u);
  const int at_truth = GridSlam::correlation(map, truth, Pose2(), ends);
  EXPECT_GT(at_truth, static_cast<int>(0.7 * ends.size()));
  int best = -1;
  Pose2 arg;
  for (int i = -6; i <= 6; ++i)
    for (int j = -6; j <= 6; ++j)
      for (int k = -6; k <= 6; ++k)
      {
        const Pose2 p(truth.x + 0.05 * i, truth.y + 0.05 * j, truth.theta + 0.02 * k);
        const int c = GridSlam::correlation(map, p, Pose2(), ends);
        if (c > best)
        {
          best = c;
          arg = p;
        }
      }
  EXPECT_NEAR(arg.x, truth.x, 0.051);
  EXPECT_NEAR(arg.y, truth.y, 0.051);
  EXPECT_NEAR(arg.theta, truth.theta, 0.021);
  // Far off the truth the score is much lower.
  EXPECT_LT(GridSlam::correlation(map, Pose2(truth.x + 0.3, truth.y + 0.3, truth.theta), Pose2(), ends), at_truth / 2);
  EXPECT_LT(GridSlam::correlation(map, Pose2(truth.x, truth.y, truth.theta + 0.12), Pose2(), ends), at_truth / 2);
}

namespace
{
struct RunResult
{
  std::vector<Pose2> poses;
  std::vector<std::int8_t> map;
  double final_error = 0.0;
  double odometry_error = 0.0;
};

RunResult runRoom(std::uint64_t seed, ResamplingMethod method)
{
  GridSlamConfig c;
  c.seed = seed;
  c.particles = 30;
  c.resampling.method = method;
  // A scan every 0.1 m (every second one of the 0.05 m path): the filter's own accuracy in a small room, which
  // the default thresholds (1 m, 0.5 rad: twenty path steps) would leave to the odometry between scans.
  c.linear_update = 0.1;
  c.angular_update = 0.05;
  const std::unique_ptr<GridSlam> slam = GridSlam::create(c);
  const std::vector<Pose2> path = truePath();
  // Odometry drifts: 2 % too long and 0.02 rad/m of heading.
  Random odo_noise(99);
  Pose2 odom = path.front();
  const Pose2 sensor(0.1, 0.0, 0.0);
  RunResult r;
  for (std::size_t i = 0; i < path.size(); ++i)
  {
    if (i > 0)
    {
      const Pose2 d = between(path[i - 1], path[i]);
      odom = odom * Pose2(d.x * 1.02, d.y, d.theta + 0.02 * std::hypot(d.x, d.y) + odo_noise.gaussian(0.002));
    }
    slam->update(odom, simulateScan(path[i] * sensor), sensor);
    r.poses.push_back(slam->mappingPose());
  }
  // Odometry starts at the true start pose and the map frame is the odometry frame: compare directly.
  const Pose2& truth_final = path.back();
  r.final_error = std::hypot(slam->mappingPose().x - truth_final.x, slam->mappingPose().y - truth_final.y);
  r.odometry_error = std::hypot(odom.x - truth_final.x, odom.y - truth_final.y);
  EXPECT_EQ(slam->particles().size(), 30u);
  int w, h;
  MapOrigin o;
  slam->map().exportProbabilities(&r.map, &w, &h, &o);
  return r;
}
}  // namespace

TEST(GridSlam, SameSeedSameResultAndBeatsDriftingOdometry)
{
  const RunResult a = runRoom(7, ResamplingMethod::kMultinomial);
  const RunResult b = runRoom(7, ResamplingMethod::kMultinomial);
  ASSERT_EQ(a.poses.size(), b.poses.size());
  for (std::size_t i = 0; i < a.poses.size(); ++i)
  {
    ASSERT_EQ(a.poses[i].x, b.poses[i].x) << i;
    ASSERT_EQ(a.poses[i].theta, b.poses[i].theta) << i;
  }
  EXPECT_EQ(a.map, b.map);
  const RunResult c = runRoom(8, ResamplingMethod::kMultinomial);
  EXPECT_NE(a.poses.back().x, c.poses.back().x);
  // In a room it has mapped from the start, the correlation holds the pose where odometry drifts away.
  EXPECT_GT(a.odometry_error, 0.5);
  EXPECT_LT(a.final_error, 0.5 * a.odometry_error);
  const RunResult d = runRoom(7, ResamplingMethod::kLowVariance);
  EXPECT_LT(d.final_error, 0.5 * d.odometry_error);
}

TEST(GridSlam, ValidatesItsConfiguration)
{
  GridSlamConfig c;
  EXPECT_TRUE(c.validate().empty());
  c.particles = 0;
  EXPECT_NE(c.validate().find("particles"), std::string::npos);
  c = GridSlamConfig();
  c.limits.range_max = 0.1;
  EXPECT_NE(c.validate().find("range_max"), std::string::npos);
  EXPECT_THROW(GridSlam::create(c), std::invalid_argument);
  GridSlamMode m = GridSlamMode::kRbpf;
  EXPECT_TRUE(parseGridSlamMode("single_map", &m));
  EXPECT_EQ(m, GridSlamMode::kSingleMap);
  EXPECT_STREQ(gridSlamModeName(m), "single_map");
  EXPECT_TRUE(parseGridSlamMode("rbpf", &m));
  EXPECT_EQ(m, GridSlamMode::kRbpf);
  EXPECT_STREQ(gridSlamModeName(m), "rbpf");
  EXPECT_FALSE(parseGridSlamMode("course", &m));  // no other names: a former alias is refused
  EXPECT_EQ(m, GridSlamMode::kRbpf);              // and the mode is left as it was
  EXPECT_FALSE(parseGridSlamMode("gmapping", &m));
}

TEST(GridSlam, RefusesNonFinitePosesAndKeepsItsState)
{
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (const GridSlamMode mode : { GridSlamMode::kSingleMap, GridSlamMode::kRbpf })
  {
    GridSlamConfig c;
    c.mode = mode;
    c.particles = 5;
    const std::unique_ptr<GridSlam> slam = GridSlam::create(c);
    const std::vector<Pose2> path = truePath();
    const ScanData scan = simulateScan(path[0]);
    // Before the first scan: nothing starts.
    EXPECT_THROW(slam->update(Pose2(nan, 0.0, 0.0), scan, Pose2()), std::invalid_argument);
    EXPECT_FALSE(slam->initialised());
    slam->update(path[0], scan, Pose2());
    ASSERT_TRUE(slam->initialised());
    const std::size_t tiles = slam->map().tileCount();
    // After it: every non-finite pose or angle is refused and changes nothing. (moved: past the default angular
    // threshold, 0.5 rad, so that the last scan below is processed.)
    const Pose2 moved(path[0].x + 0.5, path[0].y, path[0].theta + 0.6);
    EXPECT_THROW(slam->update(Pose2(nan, 0.0, 0.0), scan, Pose2()), std::invalid_argument);
    EXPECT_THROW(slam->update(Pose2(0.0, -inf, 0.0), scan, Pose2()), std::invalid_argument);
    EXPECT_THROW(slam->update(Pose2(0.0, 0.0, nan), scan, Pose2()), std::invalid_argument);
    EXPECT_THROW(slam->update(moved, scan, Pose2(0.1, nan, 0.0)), std::invalid_argument);
    ScanData bad_angles = scan;
    bad_angles.angle_increment = nan;
    EXPECT_THROW(slam->update(moved, bad_angles, Pose2()), std::invalid_argument);
    try
    {
      slam->update(Pose2(nan, 1.0, 2.0), scan, Pose2());
    }
    catch (const std::invalid_argument& e)
    {
      EXPECT_NE(std::string(e.what()).find("odometry pose is not finite"), std::string::npos) << e.what();
    }
    EXPECT_EQ(slam->lastOdometry().x, path[0].x);
    EXPECT_EQ(slam->map().tileCount(), tiles);
    for (const auto& p : slam->particles())
      EXPECT_TRUE(std::isfinite(p.pose.x) && std::isfinite(p.pose.y) && std::isfinite(p.pose.theta));
    // And the next good scan is processed as usual.
    EXPECT_NO_THROW(slam->update(moved, simulateScan(moved), Pose2()));
    EXPECT_EQ(slam->lastOdometry().x, moved.x);
  }
}

TEST(GridSlam, DefaultTravelThresholdsAreGMappings)
{
  const GridSlamConfig c;
  EXPECT_EQ(c.linear_update, 1.0);   // GMapping's linearUpdate
  EXPECT_EQ(c.angular_update, 0.5);  // angularUpdate
  EXPECT_EQ(c.temporal_update, 0.0);  // temporalUpdate off (GMapping: -1)
}

namespace
{
/** Every particle's pose and weights and the best map, for comparing a filter's state before and after. */
struct FilterState
{
  std::vector<GridParticle> particles;
  std::vector<std::int8_t> map;
  std::vector<std::size_t> tiles;  // each particle's map
  GridMapMemory memory;
};

FilterState stateOf(const GridSlam& slam)
{
  FilterState s;
  s.particles = slam.particles();
  int w, h;
  MapOrigin o;
  slam.map().exportProbabilities(&s.map, &w, &h, &o);
  for (std::size_t i = 0; i < slam.particles().size(); ++i)
    s.tiles.push_back(slam.particleMap(i).tileCount());
  s.memory = slam.mapMemory();
  return s;
}

void expectSameState(const FilterState& a, const FilterState& b)
{
  ASSERT_EQ(a.particles.size(), b.particles.size());
  for (std::size_t i = 0; i < a.particles.size(); ++i)
  {
    EXPECT_EQ(a.particles[i].pose.x, b.particles[i].pose.x) << i;
    EXPECT_EQ(a.particles[i].pose.y, b.particles[i].pose.y) << i;
    EXPECT_EQ(a.particles[i].pose.theta, b.particles[i].pose.theta) << i;
    EXPECT_EQ(a.particles[i].weight, b.particles[i].weight) << i;
    EXPECT_EQ(a.particles[i].log_weight, b.particles[i].log_weight) << i;
  }
  EXPECT_EQ(a.map, b.map);
  EXPECT_EQ(a.tiles, b.tiles);
  EXPECT_EQ(a.memory.tiles, b.memory.tiles);
  EXPECT_EQ(a.memory.bytes, b.memory.bytes);
  EXPECT_EQ(a.memory.best_tiles, b.memory.best_tiles);
}
}  // namespace

TEST(GridSlam, AStandingRobotChangesNothingUnderTheDefaultThresholds)
{
  for (const GridSlamMode mode : { GridSlamMode::kSingleMap, GridSlamMode::kRbpf })
  {
    SCOPED_TRACE(gridSlamModeName(mode));
    GridSlamConfig c;  // the default travel thresholds
    c.mode = mode;
    c.particles = 10;
    const std::unique_ptr<GridSlam> slam = GridSlam::create(c);
    const Pose2 start(-1.0, -1.5, 0.0), stand(0.0, -1.5, 0.0);
    const Pose2 sensor(0.1, 0.0, 0.0);
    EXPECT_TRUE(slam->update(start, simulateScan(start * sensor), sensor, 0.0).initialised);
    // A drive of 1 m is one update.
    const ScanData scan = simulateScan(stand * sensor);
    const GridSlamStep driven = slam->update(stand, scan, sensor, 1.0);
    EXPECT_FALSE(driven.skipped);
    EXPECT_EQ(slam->lastOdometry().x, stand.x);
    const FilterState before = stateOf(*slam);
    ASSERT_GT(before.memory.tiles, 0u);
    // Then the robot stands: the same scan at the same odometry pose, 1000 times, 25 ms apart.
    for (int i = 1; i <= 1000; ++i)
      ASSERT_TRUE(slam->update(stand, scan, sensor, 1.0 + 0.025 * i).skipped) << i;
    expectSameState(before, stateOf(*slam));
    EXPECT_NEAR(slam->mappingPose().x, slam->poseAt(stand).x, 1e-12);  // the pose stays the mapping pose
    // Less than the thresholds is no update either (0.9 m, 0.45 rad); 1 m more is.
    EXPECT_TRUE(slam->update(Pose2(stand.x + 0.9, stand.y, stand.theta + 0.45), scan, sensor, 30.0).skipped);
    expectSameState(before, stateOf(*slam));
    const Pose2 on(stand.x + 1.0, stand.y, stand.theta);
    EXPECT_FALSE(slam->update(on, simulateScan(on * sensor), sensor, 31.0).skipped);
    EXPECT_EQ(slam->lastOdometry().x, on.x);
    // So does a turn of 0.5 rad on the spot.
    const Pose2 turned(on.x, on.y, on.theta + 0.5);
    EXPECT_FALSE(slam->update(turned, simulateScan(turned * sensor), sensor, 32.0).skipped);
  }
}

namespace
{
/** One beam along the sensor's x axis, @p range long (a hit). */
ScanData oneBeam(float range)
{
  ScanData s;
  s.ranges = { range };
  s.angle_min = 0.0;
  s.angle_increment = 0.01;
  s.range_max = 30.0;
  return s;
}
}  // namespace

TEST(GridSlam, MapMemoryCountsSharedTilesOnce)
{
  for (const bool hits : { false, true })
  {
    SCOPED_TRACE(hits ? "with hit points" : "without hit points");
    GridSlamConfig c;
    c.mode = GridSlamMode::kRbpf;
    c.particles = 3;
    c.grid.track_hits = hits;
    c.linear_update = c.angular_update = 0.0;  // every scan
    c.motion = OdometryMotionNoise{ 0.0, 0.0, 0.0, 0.0 };
    c.proposal_sigma_xy = c.proposal_sigma_theta = 0.0;
    c.resampling.neff_ratio = 0.0;  // never resample: each particle keeps its own map
    const std::unique_ptr<GridSlam> slam = GridSlam::create(c);
    const std::size_t tile_bytes = sizeof(OccupancyGrid::Tile) + (hits ? 64 * 64 * sizeof(std::uint16_t) : 0);
    const double tile_area = std::pow(64 * 0.05, 2);  // 3.2 m x 3.2 m
    EXPECT_EQ(slam->mapMemory().tiles, 0u);
    EXPECT_EQ(slam->mapMemory().megabytesPerParticlePer1000SquareMetres(), 0.0);
    // Tile (0, 0) spans [0, 3.2) m on both axes. From its centre, a 3 m beam along x ends in tile (1, 0): the first
    // scan makes two tiles, which all three particles share.
    const Pose2 centre(1.6, 1.6, 0.0);
    slam->update(centre, oneBeam(3.0f), Pose2(), 0.0);
    GridMapMemory m = slam->mapMemory();
    EXPECT_EQ(m.tiles, 2u);
    EXPECT_EQ(m.bytes, 2 * tile_bytes);
    EXPECT_EQ(m.best_tiles, 2u);
    EXPECT_NEAR(m.best_area, 2 * tile_area, 1e-9);
    EXPECT_EQ(m.particles, 3);
    EXPECT_NEAR(m.megabytesPerParticlePer1000SquareMetres(), 2 * tile_bytes * 1e-6 / 3 / (2 * tile_area * 1e-3), 1e-12);
    // A 1 m beam along y from the same place writes tile (0, 0) only: each particle then owns a copy of it, and
    // tile (1, 0) stays shared: 3 + 1 distinct tiles, though each particle's map holds two.
    const Pose2 up(1.6, 1.6, M_PI / 2);
    EXPECT_FALSE(slam->update(up, oneBeam(1.0f), Pose2(), 1.0).skipped);
    std::size_t held = 0;
    for (std::size_t i = 0; i < 3; ++i)
    {
      held += slam->particleMap(i).tileCount();
      EXPECT_TRUE(slam->particleMap(i).sharesTileWith(slam->particleMap((i + 1) % 3), 1, 0));
      EXPECT_FALSE(slam->particleMap(i).sharesTileWith(slam->particleMap((i + 1) % 3), 0, 0));
    }
    EXPECT_EQ(held, 6u);
    m = slam->mapMemory();
    EXPECT_EQ(m.tiles, 4u);
    EXPECT_EQ(m.bytes, 4 * tile_bytes);
    EXPECT_EQ(m.best_tiles, 2u);
    EXPECT_NEAR(m.best_area, 2 * tile_area, 1e-9);
  }
  // single_map: one map for all particles, its tiles counted once.
  GridSlamConfig c;
  c.particles = 30;
  const std::unique_ptr<GridSlam> slam = GridSlam::create(c);
  slam->update(Pose2(1.6, 1.6, 0.0), oneBeam(3.0f), Pose2(), 0.0);
  const GridMapMemory m = slam->mapMemory();
  EXPECT_EQ(m.tiles, 2u);
  EXPECT_EQ(m.bytes, 2 * sizeof(OccupancyGrid::Tile));
  EXPECT_EQ(m.particles, 30);
}

TEST(Resampling, MultinomialDrawsInProportionToTheWeights)
{
  Random r(5);
  const std::vector<double> w = { 0.1, 0.6, 0.0, 0.3 };
  std::vector<int> count(4, 0);
  for (int k = 0; k < 2000; ++k)
    for (int i : multinomialResample(w, r))
      ++count[static_cast<std::size_t>(i)];
  const double total = 2000.0 * 4;
  EXPECT_NEAR(count[0] / total, 0.1, 0.01);
  EXPECT_NEAR(count[1] / total, 0.6, 0.01);
  EXPECT_EQ(count[2], 0);
  EXPECT_NEAR(count[3] / total, 0.3, 0.01);
  ResamplingMethod m = ResamplingMethod::kLowVariance;
  EXPECT_TRUE(parseResamplingMethod("multinomial", &m));
  EXPECT_EQ(m, ResamplingMethod::kMultinomial);
  EXPECT_FALSE(parseResamplingMethod("systematic?", &m));
  EXPECT_STREQ(resamplingMethodName(ResamplingMethod::kLowVariance), "low_variance");
  // Low variance: each particle exactly floor or ceil of N w_i times.
  const std::vector<int> lv = resample({ 0.25, 0.5, 0.25, 0.0 }, ResamplingMethod::kLowVariance, r);
  EXPECT_EQ(std::count(lv.begin(), lv.end(), 1), 2);
}

TEST(Evaluation, AbsoluteTrajectoryRmseComparesPositionsByIndex)
{
  // The in-process runs' ATE: no fit (the start is known), the common length of the two, headings ignored.
  const std::vector<Pose2> ref{ Pose2(0, 0, 0), Pose2(1, 0, 0), Pose2(2, 0, 0), Pose2(3, 0, 0) };
  std::vector<Pose2> est = ref;
  EXPECT_NEAR(absoluteTrajectoryRmse(est, ref), 0.0, 1e-12);
  est[1].y = 0.4;      // one of four 0.4 m off: sqrt(0.16 / 4)
  est[2].theta = 1.0;  // a heading error alone is no position error
  EXPECT_NEAR(absoluteTrajectoryRmse(est, ref), 0.2, 1e-12);
  est.push_back(Pose2(100, 100, 0));  // beyond the reference's end: not compared
  EXPECT_NEAR(absoluteTrajectoryRmse(est, ref), 0.2, 1e-12);
  EXPECT_EQ(absoluteTrajectoryRmse({}, ref), 0.0);
}

TEST(SkidSteerOdometry, EncodersAndGyroFusion)
{
  SkidSteerConfig c;
  c.effective_track = 0.5;
  SkidSteerOdometry enc(c);
  // Straight 1 m, then a turn on the spot of (e_R - e_L) / w = 0.2 / 0.5 = 0.4 rad.
  for (int i = 1; i <= 10; ++i)
    ASSERT_TRUE(enc.addEncoders(0.1 * i, 0.1, 0.1));
  EXPECT_NEAR(enc.pose().x, 1.0, 1e-12);
  EXPECT_TRUE(enc.addEncoders(1.1, -0.1, 0.1));
  EXPECT_NEAR(enc.pose().theta, 0.4, 1e-12);
  EXPECT_NEAR(enc.pose().x, 1.0, 1e-12);
  EXPECT_FALSE(enc.addEncoders(1.0, 0.1, 0.1));  // backwards in time
  EXPECT_FALSE(enc.addEncoders(1.2, std::nan(""), 0.1));

  // Gyro only (weight 1) with a 0.01 rad/s bias, learned while standing still for 2 s; then the wheels
  // slip (encoders say 0.8 rad) while the gyro says 0.3 rad: the fused heading follows the gyro.
  c.imu_weight = 1.0;
  SkidSteerOdometry fused(c);
  double t = 0.0;
  for (int i = 0; i < 200; ++i, t += 0.01)
  {
    fused.addGyro(t, 0.01);
    if (i % 4 == 3)
      fused.addEncoders(t, 0.0, 0.0);
  }
  EXPECT_NEAR(fused.gyroBias(), 0.01, 1e-9);
  EXPECT_NEAR(fused.pose().theta, 0.0, 1e-12);  // standing still: no heading change at all
  const double t0 = t - 0.01;
  for (int i = 0; i <= 100; ++i, t += 0.01)
    fused.addGyro(t, 0.3 + 0.01);
  fused.addEncoders(t0 + 1.0, -0.2, 0.2);  // encoders: 0.4 / 0.5 = 0.8 rad
  EXPECT_NEAR(fused.pose().theta, 0.3, 0.011);
  c.imu_weight = 1.5;
  EXPECT_NE(c.validate().find("imu_weight"), std::string::npos);
}
