// The trunk SLAM pipeline (core/trunk_slam/trunk_slam_pipeline.h): its map frame, a saved map to start from,
// relocalization when the health says the robot is lost, evidence counted once per view.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/filter/random.h"
#include "rbpf_slam/core/trunk_slam/trunk_slam_pipeline.h"

using namespace rbpf_slam::core;

TEST(TrunkSlamPipeline, TheMapFrameIsTheOdometryFrameAtTheFirstUpdate)
{
  FastSlamConfig fc;
  fc.particles = 10;
  TrunkSlamPipeline p(TrunkDetectorConfig(), fc);
  p.addOdometry(0.0, Pose2(5.0, -2.0, 0.3));
  p.addOdometry(0.2, Pose2(5.2, -2.0, 0.3));
  TrunkSweep sweep;
  sweep.stamp = 0.0;
  sweep.period = 0.1;
  EXPECT_EQ(p.addTrunks(sweep), StampVerdict::kAccept);
  const std::vector<PipelineUpdate> done = p.process();
  ASSERT_EQ(done.size(), 1u);
  // map -> odom starts as the identity: the estimate is the odometry pose at the sweep's middle.
  EXPECT_NEAR(done[0].odometry.x, 5.05, 1e-12);
  EXPECT_NEAR(done[0].estimate.x, done[0].odometry.x, 1e-12);
  EXPECT_NEAR(done[0].estimate.y, done[0].odometry.y, 1e-12);
  EXPECT_NEAR(done[0].estimate.theta, done[0].odometry.theta, 1e-12);
  // A malformed period or tilt from a foreign detector is taken as none.
  sweep.stamp = 0.1;
  sweep.period = NAN;
  sweep.tilt_roll = INFINITY;
  EXPECT_EQ(p.addTrunks(sweep), StampVerdict::kAccept);
  ASSERT_EQ(p.process().size(), 1u);
}

TEST(TrunkSlamPipeline, StartsFromASavedMapInItsFrameAndStampsTheTrees)
{
  // Four trees of a saved map, the robot put at a known pose in that map's frame; the odometry frame is another.
  std::vector<Landmark> saved;
  const double xy[4][2] = { { 14.0, 6.0 }, { 12.0, 9.0 }, { 16.5, 3.0 }, { 9.0, 2.0 } };
  for (int i = 0; i < 4; ++i)
  {
    Landmark l;
    l.id = 40 + i;
    l.mean = Eigen::Vector2d(xy[i][0], xy[i][1]);
    l.covariance = 1e-4 * Eigen::Matrix2d::Identity();
    l.radius = 0.2;
    l.radius_variance = 1e-4;
    l.observations = 30;
    l.provisional = false;
    l.first_seen = 100.0;
    l.last_seen = 200.0;
    saved.push_back(l);
  }
  const Pose2 start(10.0, 5.0, 0.5);
  FastSlamConfig fc;
  fc.particles = 30;
  TrunkSlamPipeline p(TrunkDetectorConfig(), fc);
  p.setPriorMap(saved, start);
  ASSERT_TRUE(p.hasPriorMap());
  Viewpoint looked;  // where the saved map was looked at from
  looked.sensor = Pose2(-20.0, 3.0, 0.0);
  p.setMapViewpoints({ looked });
  const Pose2 odom0(5.0, -2.0, 0.3);
  for (int k = 0; k <= 40; ++k)
    p.addOdometry(1000.0 + 0.05 * k, odom0 * Pose2(0.05 * k, 0.0, 0.0));  // 1 m/s straight ahead
  for (int s = 0; s < 10; ++s)
  {
    TrunkSweep sweep;
    sweep.stamp = 1000.0 + 0.1 * s;
    sweep.period = 0.0;
    const Pose2 truth = start * Pose2(0.1 * s, 0.0, 0.0);  // base_link in the saved map's frame
    for (const Landmark& l : saved)
    {
      TrunkObservation t;
      truth.inverse().transformPoint(l.mean.x(), l.mean.y(), &t.center.x(), &t.center.y());
      t.radius = 0.2;
      t.radius_variance = 1e-4;
      t.range = t.center.norm();
      t.bearing = std::atan2(t.center.y(), t.center.x());
      t.covariance = 1e-4 * Eigen::Matrix2d::Identity();
      sweep.trunks.push_back(t);
    }
    ASSERT_EQ(p.addTrunks(sweep), StampVerdict::kAccept);
  }
  const std::vector<PipelineUpdate> done = p.process();
  ASSERT_EQ(done.size(), 10u);
  const Pose2 truth = start * Pose2(0.9, 0.0, 0.0);
  EXPECT_NEAR(done.back().estimate.x, truth.x, 0.05);
  EXPECT_NEAR(done.back().estimate.y, truth.y, 0.05);
  EXPECT_NEAR(done.back().estimate.theta, truth.theta, 0.02);
  // The saved trees were matched, none was added, and each keeps its id and first sighting.
  const LandmarkMap& map = p.filter().best().map;
  ASSERT_EQ(map.size(), 4u);
  for (std::size_t j = 0; j < map.size(); ++j)
  {
    EXPECT_GE(map[j].id, 40);
    EXPECT_EQ(map[j].first_seen, 100.0);
    EXPECT_NEAR(map[j].last_seen, 1000.9, 1e-9) << "the last sweep's time";
    EXPECT_EQ(map[j].observations, 40);
  }
  // The saved map's viewpoint and this visit's own (0.9 m of travel inside one metre's cell: one, at its start).
  ASSERT_EQ(p.viewpoints().size(), 2u);
  EXPECT_DOUBLE_EQ(p.viewpoints()[0].sensor.x, -20.0);
  EXPECT_NEAR(p.viewpoints()[1].sensor.x, done.front().estimate.x, 1e-9);
  EXPECT_NEAR(p.viewpoints()[1].sensor.y, done.front().estimate.y, 1e-9);
  EXPECT_DOUBLE_EQ(p.viewpoints()[1].scope.max_range, p.filter().scope().max_range);
}

namespace
{
/**
 * @brief A drive through a random stand (150 trees, radii 0.1-0.4 m, 60 x 60 m) in its saved map: 50 m straight at
 * 1 m/s, trunks 1-12 m away seen at 10 Hz with 2 cm noise; at 10 s the wheel odometry jumps (3 m forward and 0.4 rad
 * that did not happen: a slip, or a reset). Returns the final position error in the map.
 */
double driveThroughAnOdometryJump(bool when_lost, std::string* summary)
{
  Random rng(11);
  std::vector<Landmark> saved;
  while (saved.size() < 150)
  {
    const Eigen::Vector2d c(rng.uniform(0.0, 60.0), rng.uniform(0.0, 60.0));
    bool clear = true;
    for (const Landmark& l : saved)
      clear = clear && (l.mean - c).norm() > 2.0;
    if (!clear || std::abs(c.y() - 30.0) < 1.5)  // the track along y = 30 stays clear of trunks
      continue;
    Landmark l;
    l.id = static_cast<int>(saved.size());
    l.mean = c;
    l.covariance = 1e-4 * Eigen::Matrix2d::Identity();
    l.radius = rng.uniform(0.1, 0.4);
    l.radius_variance = 1e-4;
    l.observations = 30;
    l.provisional = false;
    saved.push_back(l);
  }
  FastSlamConfig fc;
  fc.particles = 30;
  fc.seed = 3;
  fc.relocalize_when_lost = when_lost;
  TrunkSlamPipeline p(TrunkDetectorConfig(), fc);
  const Pose2 start(5.0, 30.0, 0.0);
  p.setPriorMap(saved, start);
  const Pose2 jump(3.0, 0.0, 0.4);
  auto truthAt = [&](double t) { return start * Pose2(t, 0.0, 0.0); };
  auto odomAt = [&](double t) {
    return t < 10.0 ? truthAt(t) : truthAt(10.0) * jump * between(truthAt(10.0), truthAt(t));
  };
  int recoveries = 0, warned = 0, searching = 0, updates = 0;
  std::string reason;
  Pose2 last;
  for (int k = 0; k < 500; ++k)
  {
    const double t = 0.1 * k;
    for (int j = 0; j < 2; ++j)
      p.addOdometry(1000.0 + t + 0.05 * j, odomAt(t + 0.05 * j));
    p.addOdometry(1000.0 + t + 0.1, odomAt(t + 0.1));
    TrunkSweep sweep;
    sweep.stamp = 1000.0 + t;
    const Pose2 inv = truthAt(t).inverse();
    for (const Landmark& l : saved)
    {
      TrunkObservation o;
      inv.transformPoint(l.mean.x(), l.mean.y(), &o.center.x(), &o.center.y());
      if (o.center.norm() < 1.0 || o.center.norm() > 12.0)
        continue;
      o.center += Eigen::Vector2d(rng.gaussian(0.02), rng.gaussian(0.02));
      o.radius = l.radius + rng.gaussian(0.01);
      o.radius_variance = 1e-4;
      o.range = o.center.norm();
      o.bearing = std::atan2(o.center.y(), o.center.x());
      o.covariance = 4e-4 * Eigen::Matrix2d::Identity();
      sweep.trunks.push_back(o);
    }
    p.addTrunks(sweep);
    for (const PipelineUpdate& u : p.process())
    {
      recoveries += u.relocalization.recovered ? 1 : 0;
      warned += u.health.level == HealthLevel::kWarn ? 1 : 0;
      searching += u.relocalization.lost ? 1 : 0;
      ++updates;
      if (u.relocalization.lost)
        reason = u.relocalization.reason;
      last = u.estimate;
    }
  }
  *summary = "recoveries " + std::to_string(recoveries) + " (" + std::to_string(updates) + " updates, " +
             std::to_string(warned) + " warned, " + std::to_string(searching) + " searching: " + reason + ")";
  const Pose2 truth = truthAt(49.9);
  return std::hypot(last.x - truth.x, last.y - truth.y);
}
}  // namespace

TEST(TrunkSlamPipeline, FindsTheRobotAgainInItsSavedMapWhenTheHealthSaysItIsLost)
{
  std::string with, without;
  const double lost = driveThroughAnOdometryJump(false, &without);
  const double found = driveThroughAnOdometryJump(true, &with);
  EXPECT_GT(lost, 1.0) << "without the search the jump stays in the estimate; " << without;
  EXPECT_LT(found, 0.3) << with;
  EXPECT_EQ(with.substr(0, 13), "recoveries 1 ") << with;
}

namespace
{
TrunkObservation trunkSeenAt(double x, double y)
{
  TrunkObservation t;
  t.center = Eigen::Vector2d(x, y);
  t.radius = 0.2;
  t.radius_variance = 1e-4;
  t.range = t.center.norm();
  t.bearing = std::atan2(y, x);
  t.covariance = 1e-3 * Eigen::Matrix2d::Identity();
  return t;
}

/** Runs @p sweeps sweeps 0.1 s apart of trunks at fixed places while the odometry moves @p speed m/s ahead. */
std::vector<PipelineUpdate> driveBy(const FastSlamConfig& fc, int sweeps, double speed)
{
  TrunkSlamPipeline p(TrunkDetectorConfig(), fc);
  for (int k = 0; k <= 2 * sweeps + 2; ++k)
    p.addOdometry(0.05 * k, Pose2(speed * 0.05 * k, 0.0, 0.0));
  const Eigen::Vector2d trees[3] = { { 8.0, 3.0 }, { 12.0, -4.0 }, { 15.0, 2.0 } };
  for (int s = 0; s < sweeps; ++s)
  {
    TrunkSweep sweep;
    sweep.stamp = 0.1 * s;
    sweep.period = 0.0;
    const double x = speed * 0.1 * s;
    for (const Eigen::Vector2d& t : trees)
      sweep.trunks.push_back(trunkSeenAt(t.x() - x, t.y()));
    EXPECT_EQ(p.addTrunks(sweep), StampVerdict::kAccept);
  }
  return p.process(NAN, true);
}

int filtered(const std::vector<PipelineUpdate>& updates)
{
  int n = 0;
  for (const PipelineUpdate& u : updates)
    n += u.filtered ? 1 : 0;
  return n;
}
}  // namespace

TEST(TrunkSlamPipeline, StandingStillAddsNoEvidence)
{
  FastSlamConfig fc;
  fc.particles = 10;  // the default view rule
  const std::vector<PipelineUpdate> still = driveBy(fc, 40, 0.0);
  ASSERT_EQ(still.size(), 40u);
  EXPECT_EQ(filtered(still), 1);  // the first look only
  // Driving at 1 m/s past trunks about 12 m away: every sweep is given to the filter, each weighed as a share.
  const std::vector<PipelineUpdate> moving = driveBy(fc, 40, 1.0);
  EXPECT_EQ(filtered(moving), 40);
}

TEST(TrunkSlamPipeline, EvidenceShareIsTheNewViewASweepBrings)
{
  FastSlamConfig fc;
  fc.evidence_view_change = 0.2;
  const std::vector<TrunkObservation> trunks{ trunkSeenAt(10.0, 0.0), trunkSeenAt(0.0, 4.0), trunkSeenAt(-20.0, 0.0) };
  // Median range 10 m: a new view after 2 m.
  EXPECT_NEAR(evidenceShare(fc, trunks, Pose2(1.0, 0.0, 0.0)), 0.5, 1e-12);
  EXPECT_NEAR(evidenceShare(fc, trunks, Pose2(0.0, 0.2, 0.3)), 0.1, 1e-12);  // turning on the spot adds no view
  EXPECT_DOUBLE_EQ(evidenceShare(fc, trunks, Pose2(5.0, 0.0, 0.0)), 1.0);
  EXPECT_DOUBLE_EQ(evidenceShare(fc, {}, Pose2()), 1.0);  // no trunk: nothing to count twice
  fc.evidence_view_change = 0.0;
  EXPECT_DOUBLE_EQ(evidenceShare(fc, trunks, Pose2()), 1.0);
}

TEST(TrunkSlamPipeline, SkippedLooksAreFusedIntoTheNextUpdateAsOneLook)
{
  LandmarkObservation o;
  o.range = 5.0;
  o.bearing = 0.0;
  o.covariance << 0.01, 0.0, 0.0, 0.0004;
  o.radius = 0.2;
  const Pose2 sensor(1.0, 0.0, 0.0);  // odometry frame: the trunk is at (6, 0)
  std::vector<std::vector<LookPoint>> skipped(2);
  skipped[0].push_back({ Eigen::Vector2d(6.1, 0.0), 0.3, -1 });
  skipped[0].push_back({ Eigen::Vector2d(9.0, 0.0), 0.2, -1 });  // another trunk
  skipped[1].push_back({ Eigen::Vector2d(5.9, 0.03), 0.1, -1 });
  std::vector<LandmarkObservation> obs{ o };
  EXPECT_EQ(fuseSkippedLooks(&obs, sensor, skipped, 13.8), 2);
  EXPECT_NEAR(obs[0].range, std::hypot(5.0, 0.01), 1e-9);
  EXPECT_NEAR(obs[0].radius, 0.2, 1e-12);
  EXPECT_TRUE(obs[0].covariance.isApprox(o.covariance)) << "counted as one look";
  // Looks of another id are not the same trunk.
  o.id = 4;
  skipped[1][0].id = 5;
  std::vector<LandmarkObservation> named{ o };
  EXPECT_EQ(fuseSkippedLooks(&named, sensor, skipped, 13.8), 1);
}
