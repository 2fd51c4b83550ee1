// The search for the robot in a saved map (core::Relocalizer): the start found from the trunks of two sweeps, an
// unknown stand refused, and while tracking a wrong estimate replaced and a right one confirmed.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/forest_map/stand_test_util.h"

#include "rbpf_slam/core/forest_map/relocalization.h"

using rbpf_slam::core::Landmark;
using rbpf_slam::core::Pose2;
using rbpf_slam::core::RelocalizationConfig;
using rbpf_slam::core::RelocalizationStatus;
using rbpf_slam::core::Relocalizer;
using rbpf_slam::core::TrunkMethod;
using rbpf_slam::core::TrunkObservation;

using rbpf_slam::test::randomStand;

namespace
{

/** The trees within 12 m of the sensor at @p sensor (map frame), in the sensor's frame, with 3 cm of noise. */
std::vector<TrunkObservation> sweep(const std::vector<Landmark>& trees, const Pose2& sensor, unsigned seed)
{
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.03);
  std::vector<TrunkObservation> seen;
  const Pose2 inv = sensor.inverse();
  for (const Landmark& l : trees)
  {
    if ((l.mean - Eigen::Vector2d(sensor.x, sensor.y)).norm() > 12.0)
      continue;
    TrunkObservation t;
    inv.transformPoint(l.mean.x(), l.mean.y(), &t.center.x(), &t.center.y());
    t.center += Eigen::Vector2d(noise(rng), noise(rng));
    t.radius = l.radius;
    t.range = t.center.norm();
    t.bearing = std::atan2(t.center.y(), t.center.x());
    t.covariance = 0.03 * 0.03 * Eigen::Matrix2d::Identity();
    t.method = TrunkMethod::kCircle;
    seen.push_back(t);
  }
  return seen;
}

double distance(const Pose2& a, const Pose2& b)
{
  return std::hypot(a.x - b.x, a.y - b.y);
}

// The odometry frame lies in the saved map at this transform (map = kOdomInMap * odometry).
const Pose2 kOdomInMap(14.0, 9.0, 0.7);
const Pose2 kMount(0.4, 0.0, 0.0);
}  // namespace

TEST(Relocalizer, TheStartIsFoundFromTwoSweepsOfTheTrunksAround)
{
  const std::vector<Landmark> trees = randomStand(80, 40.0, 3);
  Relocalizer r(trees, RelocalizationConfig(), false);
  std::vector<Pose2> starts;
  RelocalizationStatus status;
  const Pose2 odom0(0.0, 0.0, 0.0), odom1(0.5, 0.0, 0.0);
  EXPECT_FALSE(r.search(sweep(trees, kOdomInMap * odom0 * kMount, 1), kMount, odom0, &status, &starts))
      << "one sweep: every trunk seen once";
  EXPECT_TRUE(status.active);
  EXPECT_EQ(status.trunks, 0);
  EXPECT_NE(status.reason.find("gathering trunks"), std::string::npos) << status.reason;
  ASSERT_TRUE(r.search(sweep(trees, kOdomInMap * odom1 * kMount, 2), kMount, odom1, &status, &starts))
      << status.reason;
  EXPECT_GE(status.trunks, 8);
  EXPECT_GE(status.best_inliers, 8);
  ASSERT_FALSE(starts.empty());
  EXPECT_EQ(status.hypotheses, static_cast<int>(starts.size()));
  const Pose2 truth = kOdomInMap * odom1;
  EXPECT_LT(distance(starts.front(), truth), 0.1);
  EXPECT_NEAR(starts.front().theta, truth.theta, 0.02);
  // One weight per start, the best hypothesis the heaviest.
  ASSERT_EQ(r.startLogWeights().size(), starts.size());
  for (double w : r.startLogWeights())
    EXPECT_LE(w, r.startLogWeights().front());
}

TEST(Relocalizer, AStandThatIsNotTheSavedOneIsRefused)
{
  const std::vector<Landmark> saved = randomStand(80, 40.0, 3), other = randomStand(80, 40.0, 11);
  Relocalizer r(saved, RelocalizationConfig(), false);
  std::vector<Pose2> starts;
  RelocalizationStatus status;
  for (int k = 0; k < 4; ++k)
  {
    const Pose2 odom(0.5 * k, 0.0, 0.0);
    EXPECT_FALSE(r.search(sweep(other, kOdomInMap * odom * kMount, 20 + k), kMount, odom, &status, &starts));
  }
  EXPECT_GE(status.trunks, 8);
  EXPECT_TRUE(starts.empty());
  EXPECT_FALSE(status.reason.empty());
}

TEST(Relocalizer, WhileTrackingAWrongEstimateIsReplacedAndARightOneConfirmed)
{
  const std::vector<Landmark> trees = randomStand(80, 40.0, 3);
  for (const bool wrong : { true, false })
  {
    SCOPED_TRACE(wrong ? "estimate 4 m off" : "estimate right");
    Relocalizer r(trees, RelocalizationConfig(), true);
    RelocalizationStatus status;
    std::vector<Pose2> starts;
    // The saved map's trees are re-observed: no search.
    EXPECT_EQ(r.whileTracking({}, kMount, Pose2(), [] { return kOdomInMap; }, false, 0.0, &status, &starts),
              Relocalizer::Tracking::kNoSearch);
    EXPECT_FALSE(status.active);
    Relocalizer::Tracking t = Relocalizer::Tracking::kNoSearch;
    for (int k = 0; k < 4 && (t == Relocalizer::Tracking::kNoSearch || !status.confirmed) &&
                    t != Relocalizer::Tracking::kRecovered;
         ++k)
    {
      const Pose2 odom(0.5 * k, 0.0, 0.0);
      const Pose2 truth = kOdomInMap * odom;
      const Pose2 estimate = wrong ? Pose2(truth.x + 4.0, truth.y, truth.theta) : truth;
      starts.clear();
      t = r.whileTracking(sweep(trees, truth * kMount, 30 + k), kMount, odom, [&] { return estimate; }, true,
                          0.5 * k, &status, &starts);
      EXPECT_NE(t, Relocalizer::Tracking::kNoSearch) << "the trees not re-observed start a search";
      EXPECT_TRUE(status.lost);
    }
    if (wrong)
    {
      ASSERT_EQ(t, Relocalizer::Tracking::kRecovered) << status.reason;
      EXPECT_TRUE(status.recovered);
      ASSERT_GE(starts.size(), 2u);
      const Pose2 truth = kOdomInMap * Pose2(0.5, 0.0, 0.0);
      EXPECT_LT(distance(starts.front(), truth), 0.1) << "the hypothesis first";
      EXPECT_NEAR(starts.back().x, truth.x + 4.0, 1e-9) << "the estimate last";
      ASSERT_EQ(r.startLogWeights().size(), starts.size());
      EXPECT_LT(r.startLogWeights().back(), r.startLogWeights().front() - 10.0)
          << "the estimate, 4 m off, explains the trunks far worse than the hypothesis";
    }
    else
    {
      EXPECT_EQ(t, Relocalizer::Tracking::kSearching);
      EXPECT_TRUE(status.confirmed) << status.reason;
      EXPECT_FALSE(status.recovered);
    }
  }
}
