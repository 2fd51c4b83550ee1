#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/evaluation.h"
#include <memory>

#include "rbpf_slam/core/grid_slam.h"
#include "rbpf_slam/core/particle_filter.h"
#include "rbpf_slam/core/random.h"
#include "rbpf_slam/core/skid_steer_odometry.h"
#include "grid_test_world.h"

using namespace rbpf_slam::core;
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
  m = GridSlamMode::kRbpf;
  EXPECT_TRUE(parseGridSlamMode("course", &m));  // the former name stays accepted
  EXPECT_EQ(m, GridSlamMode::kSingleMap);
  EXPECT_STREQ(gridSlamModeName(m), "single_map");
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
    // After it: every non-finite pose or angle is refused and changes nothing.
    const Pose2 moved(path[0].x + 0.5, path[0].y, path[0].theta);
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
