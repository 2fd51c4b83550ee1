// The smoother that closes loops (core::TrunkSmoother, core::LoopClosing, FastSlam::redraw): a drive around a square
// stand whose odometry turns a little too much, mapped twice; the second pass's trees are the first's, as the loop
// says. The smoothed path ends where the robot is and the map holds each tree once; a loop that pairs the wrong
// trees is refused with its chi-square; a path that does not match the records is refused.
#include <atomic>
#include <cmath>
#include <thread>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/fastslam/fastslam.h"
#include "rbpf_slam/core/trunk_slam/trunk_slam_pipeline.h"
#include "rbpf_slam/core/forest_map/loop_closing.h"
#include "rbpf_slam/core/forest_map/trunk_smoother.h"

using rbpf_slam::core::between;
using rbpf_slam::core::chiSquareQuantile;
using rbpf_slam::core::FastSlam;
using rbpf_slam::core::FastSlamConfig;
using rbpf_slam::core::TrunkSlamConfig;
using rbpf_slam::core::Landmark;
using rbpf_slam::core::LandmarkMap;
using rbpf_slam::core::LandmarkObservation;
using rbpf_slam::core::LoopEvent;
using rbpf_slam::core::Pose2;
using rbpf_slam::core::SmoothedRun;
using rbpf_slam::core::SmootherConfig;
using rbpf_slam::core::TrunkSmoother;
using rbpf_slam::core::TrunkDetectorConfig;
using rbpf_slam::core::TrunkObservation;
using rbpf_slam::core::TrunkSlamPipeline;
using rbpf_slam::core::TrunkSweep;
using rbpf_slam::core::wrapAngle;

namespace
{
/** @brief A drive around a 20 m square, its truth, its drifting odometry, observations and the map a filter that
 * followed the odometry would have made (the second pass's trees new ones). */
struct LoopDrive
{
  std::vector<Pose2> truth, odometry;
  std::vector<std::vector<LandmarkObservation>> observations;
  std::vector<Eigen::Vector2d> stand;
  std::vector<double> radii;
  std::vector<Landmark> trees;                 ///< mapped along the odometry
  std::vector<std::pair<int, int>> identities; ///< (second pass id, first pass id)
  std::vector<std::pair<int, int>> wrong;      ///< each second pass tree paired with another tree
};

LoopDrive makeLoopDrive(double heading_bias_per_metre, double side = 20.0)  // [rad/m] on the open side, [m]
{
  LoopDrive d;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  // Trees 4 m outside and inside three of the square's sides, every 5 m; the fourth side is open ground, where the
  // odometry turns too much.
  // Jittered, of several radii, so that the stand is no plantation.
  std::uniform_real_distribution<double> jitter(-0.8, 0.8), radius(0.1, 0.35);
  for (double s = 2.5; s < side; s += 5.0)
    for (double off : { -4.0, 4.0 })
    {
      d.stand.emplace_back(s + jitter(rng), off + jitter(rng));
      d.stand.emplace_back(s + jitter(rng), side - off + jitter(rng));
      d.stand.emplace_back(side - off + jitter(rng), s + 1.0 + jitter(rng));
    }
  for (std::size_t j = 0; j < d.stand.size(); ++j)
    d.radii.push_back(radius(rng));
  const double step = 0.25, length = 4.0 * side + 40.0;
  Pose2 odo;
  for (double s = 0.0; s <= length; s += step)
  {
    const double u = std::fmod(s, 4.0 * side);
    const int leg = static_cast<int>(u / side);
    const double a = u - leg * side;
    const Pose2 corners[4] = { Pose2(0, 0, 0), Pose2(side, 0, M_PI / 2), Pose2(side, side, M_PI),
                               Pose2(0, side, -M_PI / 2) };
    const Pose2 t = corners[leg] * Pose2(a, 0.0, 0.0);
    if (!d.truth.empty())
    {
      const Pose2 inc = between(d.truth.back(), t);
      const double bias = leg == 3 ? heading_bias_per_metre : 0.0;
      odo = odo * Pose2(inc.x, inc.y, inc.theta + bias * std::hypot(inc.x, inc.y));
    }
    d.truth.push_back(t);
    d.odometry.push_back(odo);
    std::vector<LandmarkObservation> obs;
    for (const Eigen::Vector2d& tree : d.stand)
    {
      const double dx = tree.x() - t.x, dy = tree.y() - t.y, r = std::hypot(dx, dy);
      if (r < 1.0 || r > 8.0)
        continue;
      LandmarkObservation o;
      o.range = r + 0.02 * noise(rng);
      o.bearing = wrapAngle(std::atan2(dy, dx) - t.theta + 0.005 * noise(rng));
      o.covariance = Eigen::Vector2d(0.02 * 0.02, 0.005 * 0.005).asDiagonal();
      o.radius = d.radii[static_cast<std::size_t>(&tree - d.stand.data())];
      o.radius_variance = 0.01 * 0.01;
      obs.push_back(o);
    }
    d.observations.push_back(obs);
  }
  // The map along the odometry: a tree of a pass at the mean of its projections; a new id on the second pass.
  // The second pass begins where the odometry starts to drift (the open side): its trees are mapped anew.
  const double pass_end = 3.0 * side / step;
  std::map<std::pair<int, int>, std::vector<Eigen::Vector2d>> seen;  // (tree, pass) -> projections
  std::map<std::pair<int, int>, double> first_time, last_time;
  for (std::size_t i = 0; i < d.truth.size(); ++i)
  {
    const int pass = i < pass_end ? 0 : 1;
    for (std::size_t j = 0; j < d.stand.size(); ++j)
    {
      const double r = (d.stand[j] - Eigen::Vector2d(d.truth[i].x, d.truth[i].y)).norm();
      if (r < 1.0 || r > 8.0)
        continue;
      const Eigen::Vector2d local = [&] {
        double x = 0.0, y = 0.0;
        d.truth[i].inverse().transformPoint(d.stand[j].x(), d.stand[j].y(), &x, &y);
        return Eigen::Vector2d(x, y);
      }();
      double x = 0.0, y = 0.0;
      d.odometry[i].transformPoint(local.x(), local.y(), &x, &y);
      const auto key = std::make_pair(static_cast<int>(j), pass);
      seen[key].emplace_back(x, y);
      if (!first_time.count(key))
        first_time[key] = static_cast<double>(i);
      last_time[key] = static_cast<double>(i);
    }
  }
  int id = 0;
  std::map<std::pair<int, int>, int> ids;
  for (const auto& s : seen)
  {
    Landmark l;
    l.id = id++;
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    for (const auto& p : s.second)
      sum += p;
    l.mean = sum / static_cast<double>(s.second.size());
    l.covariance = 0.1 * 0.1 * Eigen::Matrix2d::Identity();
    l.radius = 0.2;
    l.radius_variance = 0.02 * 0.02;
    l.provisional = false;
    l.observations = static_cast<int>(s.second.size());
    l.first_seen = first_time[s.first];
    l.last_seen = last_time[s.first];
    ids[s.first] = l.id;
    d.trees.push_back(l);
  }
  for (const auto& k : ids)
    if (k.first.second == 1 && ids.count({ k.first.first, 0 }))
    {
      d.identities.emplace_back(k.second, ids[{ k.first.first, 0 }]);
      const int other = (k.first.first + 5) % static_cast<int>(d.stand.size());
      if (ids.count({ other, 0 }))
        d.wrong.emplace_back(k.second, ids[{ other, 0 }]);
    }
  return d;
}

TrunkSmoother recorded(const LoopDrive& d, const FastSlamConfig& fc, const SmootherConfig& sc = SmootherConfig())
{
  TrunkSmoother smoother(sc, fc);
  for (std::size_t i = 0; i < d.truth.size(); ++i)
    smoother.add(static_cast<double>(i), d.odometry[i], Pose2(), d.observations[i], 1.0);
  return smoother;
}

double positionError(const Pose2& a, const Pose2& b)
{
  return std::hypot(a.x - b.x, a.y - b.y);
}
}  // namespace

TEST(ChiSquare, QuantilesMatchTheTables)
{
  EXPECT_NEAR(chiSquareQuantile(0.999, 2), -2.0 * std::log(0.001), 1e-6);
  EXPECT_NEAR(chiSquareQuantile(0.95, 1), 3.841, 1e-3);
  EXPECT_NEAR(chiSquareQuantile(0.95, 10), 18.307, 1e-3);
  EXPECT_NEAR(chiSquareQuantile(0.999, 40), 73.402, 1e-3);
  EXPECT_NEAR(chiSquareQuantile(0.5, 200), 199.334, 1e-3);
}

TEST(TrunkSmoother, ClosesTheLoopOfADriftingDrive)
{
  const LoopDrive d = makeLoopDrive(0.01);
  FastSlamConfig fc;
  const TrunkSmoother smoother = recorded(d, fc);
  const double before = positionError(d.odometry.back(), d.truth.back());
  ASSERT_GT(before, 1.5) << "the drive must drift for the test to mean anything";
  ASSERT_GE(d.identities.size(), 6u);
  const SmoothedRun run = smoother.solve(d.odometry, d.trees, d.identities);
  ASSERT_TRUE(run.ok) << run.reason;
  EXPECT_GT(run.keyframes, 90);
  EXPECT_GT(run.observations, 1000);
  EXPECT_LT(run.factors, run.observations) << "a keyframe's observations of a tree are one factor";
  EXPECT_GE(run.identities, 6);
  EXPECT_LE(run.identity_chi2, run.identity_bound);
  ASSERT_EQ(run.poses.size(), d.truth.size());
  const double after = positionError(run.poses.back(), d.truth.back());
  EXPECT_LT(after, 0.3) << "before " << before;
  // Every update's pose within 0.4 m of the truth, each tree once and where it stands.
  for (std::size_t i = 0; i < d.truth.size(); ++i)
    EXPECT_LT(positionError(run.poses[i], d.truth[i]), 0.4) << "update " << i;
  EXPECT_EQ(run.trees.size(), d.trees.size() - static_cast<std::size_t>(run.identities));
  for (const Landmark& l : run.trees)
  {
    double nearest = 1e9;
    for (const Eigen::Vector2d& t : d.stand)
      nearest = std::min(nearest, (l.mean - t).norm());
    EXPECT_LT(nearest, 0.4) << "tree " << l.id;
  }
  EXPECT_TRUE(run.has_covariance);
  EXPECT_GT(run.last_covariance(0, 0), 0.0);
}

TEST(TrunkSmoother, TheLastPosesMarginalIsTheOdometrysDriftWhenNothingElseTiesIt)
{
  // A drive of 20 m in 0.25 m steps that bends by 0.6 rad, with no trees: the smoothed path is the odometry, and the
  // last keyframe's marginal covariance is the drift of the odometry from the first pose (held), the motion noise
  // class propagated along the updates, whatever way the smoother computes it.
  TrunkSmoother smoother{ SmootherConfig(), FastSlamConfig() };
  std::vector<Pose2> path;
  Pose2 odo;
  for (int i = 0; i <= 80; ++i)
  {
    path.push_back(odo);
    smoother.add(static_cast<double>(i), odo, Pose2(), {}, 1.0);
    odo = odo * Pose2(0.25, 0.0, 0.0075);
  }
  const SmoothedRun run = smoother.solve(path, {}, {});
  ASSERT_TRUE(run.ok) << run.reason;
  ASSERT_TRUE(run.has_covariance);
  ASSERT_GT(run.keyframes, 15);
  // The last update is a keyframe when the records end on one; otherwise compare with the drift up to it.
  Pose2 then;
  const Eigen::Matrix3d drift = smoother.driftSince(0.0, &then);
  ASSERT_GT(drift(0, 0), 0.0);
  EXPECT_NEAR(then.x, 0.0, 1e-12);
  const double relative = (run.last_covariance - drift).norm() / drift.norm();
  EXPECT_LT(relative, 0.05) << "smoother:\n" << run.last_covariance << "\nodometry:\n" << drift;
  // The marginal is the pose's, not the information's: it grows with the drive.
  EXPECT_GT(run.last_covariance(1, 1), run.last_covariance(0, 0));
}

TEST(TrunkSmoother, RefusesALoopThatPairsTheWrongTrees)
{
  const LoopDrive d = makeLoopDrive(0.01);
  const TrunkSmoother smoother = recorded(d, FastSlamConfig());
  ASSERT_GE(d.wrong.size(), 6u);
  const SmoothedRun run = smoother.solve(d.odometry, d.trees, d.wrong);
  EXPECT_FALSE(run.ok);
  EXPECT_GT(run.identity_chi2, run.identity_bound);
  EXPECT_NE(run.reason.find("chi-square"), std::string::npos) << run.reason;
  EXPECT_TRUE(run.inconsistent) << "the map disagrees with the revisit: the health is told";
}

TEST(TrunkSmoother, ALookAlikePairAmongALoopsTreesIsDroppedNotTheLoop)
{
  const LoopDrive d = makeLoopDrive(0.01);
  ASSERT_GE(d.identities.size(), 6u);
  // The loop's true pairs and one look-alike: a second pass tree paired with a tree 5 places away.
  std::vector<std::pair<int, int>> pairs = d.identities;
  pairs.push_back(d.wrong.front());
  SmootherConfig once;
  once.loop_rounds = 1;
  const SmoothedRun refused = recorded(d, FastSlamConfig(), once).solve(d.odometry, d.trees, pairs);
  ASSERT_FALSE(refused.ok) << "with one solve, the look-alike refuses the whole loop";
  EXPECT_GT(refused.identity_chi2, refused.identity_bound);
  EXPECT_EQ(refused.identities_dropped, 0);

  const SmoothedRun run = recorded(d, FastSlamConfig()).solve(d.odometry, d.trees, pairs);
  ASSERT_TRUE(run.ok) << run.reason;
  EXPECT_EQ(run.identities_dropped, 1);
  EXPECT_EQ(run.identities, static_cast<int>(d.identities.size()));
  EXPECT_LE(run.identity_chi2, run.identity_bound);
  EXPECT_LT(positionError(run.poses.back(), d.truth.back()), 0.3);
  // Each tree once and where it stands: the look-alike's old tree was not dragged onto another.
  EXPECT_EQ(run.trees.size(), d.trees.size() - d.identities.size());
  for (const Landmark& l : run.trees)
  {
    double nearest = 1e9;
    for (const Eigen::Vector2d& t : d.stand)
      nearest = std::min(nearest, (l.mean - t).norm());
    EXPECT_LT(nearest, 0.4) << "tree " << l.id;
  }
}

TEST(TrunkSmoother, RefusesAGraphBeyondItsBoundOrUnconverged)
{
  const LoopDrive d = makeLoopDrive(0.01);
  SmootherConfig small;
  small.max_factors = 10;
  const TrunkSmoother budget = recorded(d, FastSlamConfig(), small);
  SmootherConfig short_config;
  short_config.max_iterations = 1;
  const TrunkSmoother iterations = recorded(d, FastSlamConfig(), short_config);
  const SmoothedRun a = budget.solve(d.odometry, d.trees, d.identities);
  EXPECT_FALSE(a.ok);
  EXPECT_NE(a.reason.find("max_factors"), std::string::npos) << a.reason;
  EXPECT_TRUE(a.poses.empty()) << "nothing to apply";
  EXPECT_FALSE(a.inconsistent) << "refused for its size, not for what the map says";
  const SmoothedRun b = iterations.solve(d.odometry, d.trees, d.identities);
  EXPECT_FALSE(b.ok);
  EXPECT_NE(b.reason.find("did not converge"), std::string::npos) << b.reason;
  EXPECT_TRUE(b.trees.empty());
  EXPECT_TRUE(b.inconsistent) << "a loop the solve could not bring together within its iterations";
}

TEST(TrunkSmoother, RefusesAPathThatDoesNotMatchTheRecords)
{
  const LoopDrive d = makeLoopDrive(0.01);
  const TrunkSmoother smoother = recorded(d, FastSlamConfig());
  std::vector<Pose2> short_path(d.odometry.begin(), d.odometry.end() - 1);
  const SmoothedRun run = smoother.solve(short_path, d.trees, d.identities);
  EXPECT_FALSE(run.ok);
  EXPECT_NE(run.reason.find("does not match"), std::string::npos) << run.reason;
}

TEST(TrunkSmoother, WithoutALoopNoTreeMerges)
{
  const LoopDrive d = makeLoopDrive(0.01);
  const TrunkSmoother smoother = recorded(d, FastSlamConfig());
  const SmoothedRun run = smoother.solve(d.odometry, d.trees, {});
  ASSERT_TRUE(run.ok) << run.reason;
  EXPECT_EQ(run.identities, 0);
  EXPECT_DOUBLE_EQ(run.identity_chi2, 0.0);
  EXPECT_EQ(run.trees.size(), d.trees.size());
  ASSERT_EQ(run.stamps.size(), d.truth.size());
  EXPECT_DOUBLE_EQ(run.stamps.back(), static_cast<double>(d.truth.size() - 1));
}

TEST(FastSlamRedraw, ParticlesAroundThePoseWithTheSpreadAndThePath)
{
  FastSlamConfig fc;
  fc.particles = 2000;
  FastSlam filter(fc);
  filter.initialize(Pose2());
  LandmarkMap map;
  Landmark l;
  l.id = 41;
  l.mean = Eigen::Vector2d(3.0, 1.0);
  map.add(l);
  const std::vector<Pose2> path{ Pose2(0, 0, 0), Pose2(1, 0, 0), Pose2(2, 0.5, 0.1) };
  Eigen::Matrix3d cov = Eigen::Vector3d(0.2 * 0.2, 0.1 * 0.1, 0.05 * 0.05).asDiagonal();
  filter.redraw(path.back(), cov, map, path);
  const Eigen::Matrix3d c = filter.poseCovariance();
  const Pose2 m = filter.meanPose();
  EXPECT_NEAR(m.x, 2.0, 0.02);
  EXPECT_NEAR(m.y, 0.5, 0.01);
  EXPECT_NEAR(std::sqrt(c(0, 0)), 0.2, 0.02);
  EXPECT_NEAR(std::sqrt(c(1, 1)), 0.1, 0.01);
  EXPECT_NEAR(std::sqrt(c(2, 2)), 0.05, 0.005);
  for (const auto& p : filter.particles())
  {
    ASSERT_EQ(p.map.size(), 1u);
    EXPECT_EQ(p.map[0].id, 41);
  }
  const std::vector<Pose2> h = filter.bestHistory();
  ASSERT_EQ(h.size(), 3u);
  EXPECT_DOUBLE_EQ(h[1].x, 1.0);
  EXPECT_DOUBLE_EQ(h[2].x, filter.best().pose.x);
}

namespace
{
/** The drive through the pipeline, as a robot would: 4 sweeps per metre at 1 m/s, odometry at 20 Hz; the trunks
 * seen within 1-12 m (the scope the sweeps leave to the filter). Returns the final estimate. */
Pose2 drivePipeline(const LoopDrive& d, bool loop_closure, int* closed, double* smoothed_error, int apply_after = -1,
                    const TrunkSlamConfig& base = TrunkSlamConfig(), std::vector<LoopEvent>* loops = nullptr)
{
  TrunkSlamConfig fc = base;
  fc.seed = 3;
  fc.loop_closure.enabled = loop_closure;
  if (apply_after >= 0)
    fc.loop_closure.apply_after = apply_after;
  TrunkSlamPipeline p(TrunkDetectorConfig(), fc);
  const double dt = 0.25;  // s per update (0.25 m at 1 m/s)
  for (std::size_t i = 0; i < d.truth.size(); ++i)
  {
    const double t = 10.0 + dt * static_cast<double>(i);
    for (int k = 0; k < 5; ++k)
    {
      // Odometry between the updates, interpolated.
      const Pose2& a = d.odometry[i == 0 ? 0 : i - 1];
      const Pose2 inc = between(a, d.odometry[i]);
      const double f = (k + 1) / 5.0;
      p.addOdometry(t - dt + f * dt, a * Pose2(f * inc.x, f * inc.y, f * inc.theta));
    }
    TrunkSweep sweep;
    sweep.stamp = t;
    for (std::size_t j = 0; j < d.stand.size(); ++j)
    {
      double x = 0.0, y = 0.0;
      d.truth[i].inverse().transformPoint(d.stand[j].x(), d.stand[j].y(), &x, &y);
      const double r = std::hypot(x, y);
      if (r < 1.0 || r > 12.0)
        continue;
      TrunkObservation o;
      o.center = Eigen::Vector2d(x, y);
      o.range = r;
      o.bearing = std::atan2(y, x);
      o.radius = d.radii[j];
      o.radius_variance = 0.01 * 0.01;
      o.covariance = 0.02 * 0.02 * Eigen::Matrix2d::Identity();
      sweep.trunks.push_back(o);
    }
    p.addTrunks(sweep);
    for (const auto& u : p.process())
    {
      *closed += u.loop.kind == rbpf_slam::core::LoopEvent::Kind::kClosed;
      if (loops && u.loop.kind != LoopEvent::Kind::kNone)
        loops->push_back(u.loop);
    }
  }
  for (const auto& u : p.process(NAN, true))
    *closed += u.loop.kind == rbpf_slam::core::LoopEvent::Kind::kClosed;
  const SmoothedRun s = p.smoothed();
  *smoothed_error = s.ok ? positionError(s.poses.back(), d.truth.back()) : NAN;
  return p.filter().estimate();
}
/** The same drive with loop closure off and on: the final position errors, loops closed, smoothed final errors. */
struct OffAndOn
{
  double off = 0.0, on = 0.0;
  int closed_off = 0, closed_on = 0;
  double smoothed_off = 0.0, smoothed_on = 0.0;
};

OffAndOn driveOffAndOn(const LoopDrive& d)
{
  OffAndOn r;
  r.off = positionError(drivePipeline(d, false, &r.closed_off, &r.smoothed_off), d.truth.back());
  r.on = positionError(drivePipeline(d, true, &r.closed_on, &r.smoothed_on), d.truth.back());
  return r;
}
}  // namespace

TEST(TrunkSlamPipelineLoops, ADriftOverOpenGroundIsClosedWhenTheStandComesBack)
{
  // A square of 40 m: the open side has 16 m with no tree in reach, where the heading drifts 0.32 rad: the filter
  // alone maps the stand again beside itself.
  const OffAndOn r = driveOffAndOn(makeLoopDrive(0.02, 40.0));
  EXPECT_EQ(r.closed_off, 0);
  EXPECT_GT(r.off, 1.0) << "the filter alone must be off for the test to mean anything";
  EXPECT_GE(r.closed_on, 1);
  EXPECT_LT(r.on, 0.3) << "without loop closure " << r.off;
  EXPECT_LT(r.smoothed_on, 0.3);
}

TEST(TrunkSlamPipelineLoops, TheRunSmoothedAtItsEndHoldsThePathAndTheMap)
{
  // A square of 40 m: the open side has 16 m with no tree in reach, where the heading drifts 0.16 rad; the filter
  // holds it (the trees come back within its gates), and the run smoothed at its end keeps to the truth.
  const OffAndOn r = driveOffAndOn(makeLoopDrive(0.01, 40.0));
  EXPECT_EQ(r.closed_off, 0);
  EXPECT_TRUE(std::isnan(r.smoothed_off)) << "no smoothing without loop closure";
  EXPECT_EQ(r.closed_on, 0) << "no loop to close: the filter kept its trees";
  EXPECT_LT(r.off, 0.3);
  EXPECT_LT(r.on, 0.3);
  EXPECT_LT(r.smoothed_on, 0.3);
}

TEST(TrunkSlamPipelineLoops, ALoopSolvedBesideTheFilterGivesOneAnswerHoweverBusyTheComputer)
{
  // The solve runs on a worker thread and is applied a fixed number of updates later: the same drive gives the same
  // estimate to the bit, alone and beside threads that keep every core busy, and closes its loop as well as a solve
  // applied within the update that found it.
  const LoopDrive d = makeLoopDrive(0.02, 40.0);
  int closed_alone = 0, closed_busy = 0, closed_at_once = 0;
  double smoothed_alone = 0.0, smoothed_busy = 0.0, smoothed_at_once = 0.0;
  const Pose2 alone = drivePipeline(d, true, &closed_alone, &smoothed_alone, 20);
  std::atomic<bool> stop(false);
  std::vector<std::thread> hogs;
  for (unsigned k = 0; k < std::max(2u, std::thread::hardware_concurrency()); ++k)
    hogs.emplace_back([&stop]() {
      volatile double x = 1.0;
      while (!stop.load())
        x = x * 1.0000001 + 1e-9;
    });
  const Pose2 busy = drivePipeline(d, true, &closed_busy, &smoothed_busy, 20);
  stop = true;
  for (std::thread& t : hogs)
    t.join();
  const Pose2 at_once = drivePipeline(d, true, &closed_at_once, &smoothed_at_once, 0);
  EXPECT_GE(closed_alone, 1);
  EXPECT_EQ(closed_alone, closed_busy);
  EXPECT_EQ(alone.x, busy.x);
  EXPECT_EQ(alone.y, busy.y);
  EXPECT_EQ(alone.theta, busy.theta);
  EXPECT_EQ(smoothed_alone, smoothed_busy);
  EXPECT_GE(closed_at_once, 1);
  EXPECT_LT(positionError(alone, d.truth.back()), 0.3);
  EXPECT_LT(positionError(at_once, d.truth.back()), 0.3);
}

TEST(TrunkSlamPipelineLoops, ALoopBeyondWhatTheOdometryCanDriftIsRefused)
{
  // The drive that closes its loop above, told that its odometry drifts a hundred times less than it does: the
  // loop's correction is then beyond the odometry's drift bound, and refused before any solve.
  const LoopDrive d = makeLoopDrive(0.02, 40.0);
  TrunkSlamConfig overconfident;
  overconfident.motion.alpha1 *= 1e-4;
  overconfident.motion.alpha2 *= 1e-4;
  overconfident.motion.alpha3 *= 1e-4;
  overconfident.motion.alpha4 *= 1e-4;
  TrunkSlamConfig honest;
  int closed = 0, closed_honest = 0;
  double smoothed = 0.0;
  std::vector<LoopEvent> loops, loops_honest;
  drivePipeline(d, true, &closed, &smoothed, -1, overconfident, &loops);
  drivePipeline(d, true, &closed_honest, &smoothed, -1, honest, &loops_honest);
  EXPECT_GE(closed_honest, 1);
  for (const LoopEvent& e : loops_honest)
    EXPECT_EQ(e.reason.find("drift"), std::string::npos) << e.reason;
  EXPECT_EQ(closed, 0);
  ASSERT_FALSE(loops.empty());
  EXPECT_NE(loops.front().reason.find("beyond what the odometry can drift"), std::string::npos)
      << loops.front().reason;
}

TEST(TrunkSmoother, TheOdometrysDriftGrowsWithTheDrive)
{
  const LoopDrive d = makeLoopDrive(0.01);
  const TrunkSmoother smoother = recorded(d, FastSlamConfig());
  Pose2 then;
  const Eigen::Matrix3d all = smoother.driftSince(-1.0, &then);
  EXPECT_EQ(then.x, d.odometry.front().x);
  const Eigen::Matrix3d half = smoother.driftSince(static_cast<double>(d.odometry.size() / 2), &then);
  const Eigen::Matrix3d none = smoother.driftSince(1e9, &then);
  EXPECT_GT(all(2, 2), 1.5 * half(2, 2));
  EXPECT_GT(all.trace(), half.trace());
  EXPECT_LT(none.trace(), 1e-4) << "no drive since the last update";
}

TEST(TrunkSmoother, LapsOfOnePlaceKeepOneLookPerKeyframe)
{
  // Five laps of the square; after the first, every update revisits a place kept from a lap earlier. The odometry
  // turns 0.003 rad per metre too much: a keyframe left without observations would follow it off the square.
  const LoopDrive d = makeLoopDrive(0.0);
  const std::size_t lap = 320;  // updates per lap (80 m in steps of 0.25 m)
  const SmootherConfig sc;
  const FastSlamConfig fc;
  TrunkSmoother laps(sc, fc), kept_all(sc, fc);
  std::vector<Pose2> path;
  Pose2 odometry;
  std::size_t with_observations = 0;
  for (std::size_t k = 0; k < 5; ++k)
    for (std::size_t i = 0; i < lap; ++i)
    {
      const double stamp = static_cast<double>(k * lap + i);
      if (!path.empty())
      {
        const Pose2 inc = between(path.back(), d.truth[i]);
        odometry = odometry * Pose2(inc.x, inc.y, inc.theta + 0.003 * std::hypot(inc.x, inc.y));
      }
      laps.add(stamp, odometry, Pose2(), d.observations[i], 1.0);
      kept_all.add(stamp, odometry, Pose2(), d.observations[i], 1.0);
      path.push_back(d.truth[i]);
      if (k == 0 && !d.observations[i].empty())
        ++with_observations;
    }
  // Nothing within the pass gap of itself is a revisit: a lap does not thin itself.
  EXPECT_EQ(laps.thin(path, static_cast<double>(lap), 100.0), 0u);
  // Before the last lap's start: laps 2 to 4 thinned to one look per metre (of four or five), the last kept (recent).
  const std::size_t n = laps.thin(path, static_cast<double>(4 * lap), 100.0);
  EXPECT_GT(n, 3 * with_observations * 6 / 10);
  EXPECT_LT(n, 3 * with_observations * 85 / 100);
  EXPECT_EQ(laps.thin(path, static_cast<double>(4 * lap), 100.0), 0u) << "thinning twice changes nothing";
  EXPECT_EQ(laps.thinned(), n);
  EXPECT_EQ(laps.size(), path.size()) << "the odometry of every update stays";
  EXPECT_EQ(laps.thin(std::vector<Pose2>(path.begin(), path.end() - 1), 1e9, 100.0), 0u) << "a path that does "
                                                                                            "not match: nothing";
  // The thinned graph is solved as the whole one, from a fraction of its observations: every keyframe still tied.
  const SmoothedRun thin_run = laps.solve(path, d.trees, {});
  const SmoothedRun full_run = kept_all.solve(path, d.trees, {});
  ASSERT_TRUE(thin_run.ok) << thin_run.reason;
  ASSERT_TRUE(full_run.ok) << full_run.reason;
  EXPECT_EQ(thin_run.keyframes, full_run.keyframes);
  EXPECT_LT(thin_run.observations, full_run.observations * 6 / 10);
  ASSERT_EQ(thin_run.poses.size(), path.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < path.size(); ++i)
    worst = std::max(worst, positionError(thin_run.poses[i], path[i]));
  EXPECT_LT(worst, 0.1);
}
