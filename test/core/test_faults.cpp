// Faults the core must survive: stamps that jump, dropouts in a scan, a standing robot, hours of history, absurd
// particle counts. Each test feeds the fault and checks that the state is what it must be afterwards.
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/fastslam.h"
#include "rbpf_slam/core/grid_slam.h"
#include "rbpf_slam/core/history_chain.h"
#include "rbpf_slam/core/stamp_gate.h"
#include "rbpf_slam/core/trunk_detector.h"
#include "grid_test_world.h"

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
  EXPECT_EQ(g.check(2.0, 2.0), StampVerdict::kReset);  // a looped bag: 8.3 s back
  EXPECT_EQ(g.last(), 2.0);
  EXPECT_EQ(g.check(2.1, 2.1), StampVerdict::kAccept);
  EXPECT_EQ(g.check(100.0), StampVerdict::kAccept);  // no clock: no future test
  g.reset();
  EXPECT_EQ(g.check(1.0), StampVerdict::kAccept);
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
