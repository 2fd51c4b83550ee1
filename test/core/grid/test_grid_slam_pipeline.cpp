// The pipelines' time handling (core/filter/sensor_pipeline.h) in grid SLAM's pipeline: waiting for odometry, the
// stamp rule, restarts that flush the old timeline, bounded waiting, the odometry wait, a stopped odometry.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "core/grid/grid_test_world.h"
#include "rbpf_slam/core/grid/grid_slam_pipeline.h"
#include "rbpf_slam/core/filter/random.h"

using namespace rbpf_slam::core;
using grid_test_world::simulateScan;

using grid_test_world::simulateScan;

namespace
{
GridSlamConfig smallGrid()
{
  GridSlamConfig c;
  c.particles = 5;
  c.linear_update = 0.0;  // every scan
  c.angular_update = 0.0;
  return c;
}
}  // namespace

TEST(GridSlamPipeline, AScanWaitsUntilOdometryCoversIt)
{
  GridSlamPipeline p(smallGrid());
  EXPECT_EQ(p.addOdometry(0.0, Pose2()), StampVerdict::kAccept);
  EXPECT_EQ(p.addScan(0.05, simulateScan(Pose2()), Pose2()), StampVerdict::kAccept);
  EXPECT_TRUE(p.process().empty());  // odometry ends before the scan
  EXPECT_EQ(p.pending(), 1u);
  EXPECT_EQ(p.addOdometry(0.1, Pose2(0.02, 0.0, 0.0)), StampVerdict::kAccept);
  const std::vector<GridPipelineUpdate> done = p.process();
  ASSERT_EQ(done.size(), 1u);
  EXPECT_TRUE(done[0].error.empty());
  EXPECT_DOUBLE_EQ(done[0].stamp, 0.05);
  EXPECT_NEAR(done[0].odometry.x, 0.01, 1e-12);  // interpolated at the scan's stamp
  EXPECT_EQ(done[0].timeline, 0);
  EXPECT_TRUE(p.filter().initialised());
}

TEST(GridSlamPipeline, StampRuleDropsLateDuplicateAndNonFinite)
{
  GridSlamPipeline p(smallGrid());
  EXPECT_EQ(p.addOdometry(1.0, Pose2()), StampVerdict::kAccept);
  EXPECT_EQ(p.addOdometry(1.0, Pose2()), StampVerdict::kDuplicate);
  EXPECT_EQ(p.addOdometry(0.5, Pose2()), StampVerdict::kLate);
  EXPECT_EQ(p.addOdometry(1.1, Pose2(NAN, 0.0, 0.0)), StampVerdict::kInvalid);
  EXPECT_EQ(p.addOdometry(NAN, Pose2()), StampVerdict::kInvalid);
  EXPECT_EQ(p.addOdometry(5.0, Pose2(), 2.0), StampVerdict::kFuture);  // 3 s ahead of the clock
  EXPECT_EQ(p.restarts(), 0);
  EXPECT_EQ(p.odometry().size(), 1u);
}

TEST(GridSlamPipeline, AJumpBackFlushesTheOldTimelineThenRestarts)
{
  GridSlamPipeline p(smallGrid());
  p.addOdometry(100.0, Pose2());
  p.addScan(100.05, simulateScan(Pose2()), Pose2());
  p.addOdometry(100.1, Pose2(0.02, 0.0, 0.0));
  ASSERT_EQ(p.process().size(), 1u);
  p.addScan(100.15, simulateScan(Pose2(0.03, 0.0, 0.0)), Pose2());  // waits: odometry ends at 100.1
  // The bag starts again: the waiting scan is processed with the old odometry, then the map starts over.
  EXPECT_EQ(p.addOdometry(10.0, Pose2(), 10.0), StampVerdict::kReset);  // the clock went back with it
  EXPECT_EQ(p.restarts(), 1);
  EXPECT_FALSE(p.filter().initialised());
  EXPECT_EQ(p.addScan(10.05, simulateScan(Pose2()), Pose2()), StampVerdict::kAccept);  // no second jump
  p.addOdometry(10.1, Pose2(0.02, 0.0, 0.0));
  const std::vector<GridPipelineUpdate> done = p.process();
  ASSERT_EQ(done.size(), 2u);
  EXPECT_DOUBLE_EQ(done[0].stamp, 100.15);
  EXPECT_EQ(done[0].timeline, 0);
  EXPECT_DOUBLE_EQ(done[1].stamp, 10.05);
  EXPECT_EQ(done[1].timeline, 1);
  EXPECT_TRUE(done[1].step.initialised);  // the new timeline's first scan starts a new map
}

TEST(GridSlamPipeline, WaitingIsBoundedAndTheWaitEnds)
{
  PipelineTiming timing;
  timing.max_pending = 2;
  timing.odometry_wait = 0.5;
  GridSlamPipeline p(smallGrid(), timing);
  p.addOdometry(0.0, Pose2());
  for (int k = 1; k <= 3; ++k)
    p.addScan(0.1 * k, simulateScan(Pose2()), Pose2(), NAN, 10.0 + k);  // arrival on the caller's clock
  EXPECT_EQ(p.pending(), 2u);
  EXPECT_EQ(p.droppedPending(), 1u);  // the oldest
  EXPECT_TRUE(p.process(12.4).empty());  // the oldest waiting scan arrived at 12: not yet 0.5 s
  const std::vector<GridPipelineUpdate> done = p.process(12.6);  // it has waited: the newest odometry is used
  ASSERT_EQ(done.size(), 1u);
  EXPECT_DOUBLE_EQ(done[0].stamp, 0.2);
  EXPECT_EQ(p.process(NAN, true).size(), 1u);  // the end of the input flushes the rest
}

TEST(GridSlamPipeline, StoppedOdometryIsReportedOnceWithItsDurationAndTheMapIsKept)
{
  // The robot drives along x at 0.5 m/s; its odometry stops after 1.9 s and returns at 5 s while the scans go on
  // (each waits 0.5 s on the caller's clock, then is processed with the newest odometry).
  PipelineTiming timing;
  timing.odometry_wait = 0.5;
  GridSlamPipeline p(smallGrid(), timing);
  const auto truth = [](double t) { return Pose2(-1.0 + 0.5 * t, -1.5, 0.0); };
  const auto image = [&p]() {
    std::vector<std::int8_t> cells;
    int w, h;
    MapOrigin o;
    p.filter().map().exportProbabilities(&cells, &w, &h, &o);
    return cells;
  };
  std::vector<std::int8_t> map_at_stop;
  int began = 0, ended = 0, stopped = 0, reported = 0;
  for (int k = 0; k <= 70; ++k)
  {
    const double t = 0.1 * k;
    if (k < 20 || k >= 50)
      p.addOdometry(t, truth(t), t);
    if (k % 2 == 1)
      p.addScan(t - 0.05, simulateScan(truth(t - 0.05)), Pose2(), t, t);
    for (const GridPipelineUpdate& u : p.process(t))
    {
      EXPECT_TRUE(u.error.empty());
      if (u.outage_began)
      {
        ++began;
        map_at_stop = image();
      }
      if (u.odometry_stopped)
      {
        ++stopped;
        EXPECT_GT(u.stamp - 1.9, GridSlamPipeline::kOdometryStopped);
        EXPECT_TRUE(u.step.skipped);
        EXPECT_EQ(image(), map_at_stop);  // the scans left out do not touch the map
      }
      if (u.outage_scans > 0)
      {
        ++ended;
        reported = u.outage_scans;
        EXPECT_NEAR(u.outage_seconds, u.stamp - 1.9, 1e-9);  // since the newest odometry before it
        EXPECT_FALSE(u.odometry_stopped);
        EXPECT_FALSE(u.step.skipped);  // the map goes on
      }
    }
  }
  EXPECT_EQ(began, 1);  // reported once
  EXPECT_EQ(ended, 1);
  EXPECT_GE(stopped, 8);
  EXPECT_EQ(reported, stopped);
  EXPECT_EQ(p.outage().scans, 0);  // ended
  EXPECT_LT(std::hypot(p.filter().mappingPose().x - truth(6.85).x, p.filter().mappingPose().y - truth(6.85).y), 0.1);
}

TEST(GridSlamPipeline, AScanOlderThanTheFirstOdometryIsDropped)
{
  GridSlamPipeline p(smallGrid());
  p.addScan(0.0, simulateScan(Pose2()), Pose2());
  p.addOdometry(0.02, Pose2());
  const std::vector<GridPipelineUpdate> done = p.process();
  ASSERT_EQ(done.size(), 1u);
  EXPECT_FALSE(done[0].error.empty());
  EXPECT_FALSE(p.filter().initialised());
}

TEST(GridSlamPipeline, OdometryIsForgottenOnlyWhileNoScanWaitsForIt)
{
  GridSlamPipeline p(smallGrid());
  for (int k = 0; k <= 100; ++k)  // x = 0.1 t
    ASSERT_EQ(p.addOdometry(0.1 * k, Pose2(0.01 * k, 0.0, 0.0)), StampVerdict::kAccept);
  EXPECT_EQ(p.addScan(9.95, simulateScan(Pose2()), Pose2()), StampVerdict::kAccept);
  const std::size_t kept = p.odometry().size();
  p.forgetOdometryBefore(9.99);
  EXPECT_EQ(p.odometry().size(), kept);  // the scan at 9.95 s waits for its process()
  const std::vector<GridPipelineUpdate> done = p.process();
  ASSERT_EQ(done.size(), 1u);
  EXPECT_NEAR(done[0].odometry.x, 0.995, 1e-12);
  for (int k = 101; k <= 200; ++k)  // the scanner is silent from here
    ASSERT_EQ(p.addOdometry(0.1 * k, Pose2(0.01 * k, 0.0, 0.0)), StampVerdict::kAccept);
  EXPECT_GT(p.odometry().size(), 100u);
  // Nothing waits: what came before 15 s goes, the last sample at or before it stays.
  p.forgetOdometryBefore(15.01);
  EXPECT_NEAR(p.odometry().earliest(), 15.0, 1e-9);
  EXPECT_EQ(p.odometry().size(), 51u);
  EXPECT_NEAR(p.odometry().at(15.05).x, 1.505, 1e-12);
}
