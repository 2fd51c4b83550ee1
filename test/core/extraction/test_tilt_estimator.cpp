// Tilt from the trunks' verticality, on candidates sheared by a known tilt.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/filter/random.h"
#include "rbpf_slam/core/extraction/tilt_estimator.h"

using rbpf_slam::core::estimateTiltFromTrunks;
using rbpf_slam::core::Random;
using rbpf_slam::core::TiltEstimatorParams;
using rbpf_slam::core::TrunkCandidate;

namespace
{
/**
 * The side facing the sensor of a vertical trunk (centre c, radius r at the band's middle z_mid = -0.55), seen by a
 * sensor tilted so that a levelled point is (x + a z, y + b z): the candidate holds the unlevelled points.
 */
TrunkCandidate shearedTrunk(const Eigen::Vector2d& c, double r, double a, double b, Random& rnd, double sigma = 0.01)
{
  TrunkCandidate t;
  const double facing = std::atan2(-c.y(), -c.x());
  for (int ring = 0; ring < 8; ++ring)
  {
    const double z = -1.3 + 0.2 * ring;
    for (int k = -15; k <= 15; ++k)
    {
      const double ang = facing + 0.05 * k;
      const double rr = r + rnd.gaussian(sigma);
      const double x = c.x() + rr * std::cos(ang), y = c.y() + rr * std::sin(ang);
      t.points.emplace_back(x - a * z, y - b * z, z);
    }
  }
  t.z_lo = -1.3;
  t.z_hi = -1.3 + 0.2 * 7;
  return t;
}
}  // namespace

TEST(TiltEstimator, RecoversAKnownTilt)
{
  const double a = 0.08, b = -0.03;  // about 4.6 and 1.7 degrees
  Random rnd(1);
  std::vector<TrunkCandidate> c;
  c.push_back(shearedTrunk({ 6.0, 3.0 }, 0.2, a, b, rnd));
  c.push_back(shearedTrunk({ 8.0, -2.0 }, 0.15, a, b, rnd));
  c.push_back(shearedTrunk({ -4.0, -4.0 }, 0.25, a, b, rnd));
  const Eigen::Vector2d tilt = estimateTiltFromTrunks(c, TiltEstimatorParams());
  EXPECT_NEAR(tilt.x(), a, 0.005);
  EXPECT_NEAR(tilt.y(), b, 0.005);
}

TEST(TiltEstimator, UprightTrunksGiveNoTilt)
{
  Random rnd(2);
  std::vector<TrunkCandidate> c;
  c.push_back(shearedTrunk({ 5.0, 1.0 }, 0.2, 0.0, 0.0, rnd));
  c.push_back(shearedTrunk({ -3.0, 6.0 }, 0.2, 0.0, 0.0, rnd));
  const Eigen::Vector2d tilt = estimateTiltFromTrunks(c, TiltEstimatorParams());
  EXPECT_LT(tilt.norm(), 0.005);
}

TEST(TiltEstimator, OneUsableTrunkIsNotEnough)
{
  Random rnd(3);
  std::vector<TrunkCandidate> c;
  c.push_back(shearedTrunk({ 6.0, 3.0 }, 0.2, 0.1, 0.0, rnd));
  // A second candidate with too few points and a third whose circle is far too large for a trunk.
  TrunkCandidate few = shearedTrunk({ 4.0, -3.0 }, 0.2, 0.1, 0.0, rnd);
  few.points.resize(10);
  c.push_back(few);
  c.push_back(shearedTrunk({ 9.0, 0.0 }, 1.5, 0.1, 0.0, rnd));
  EXPECT_EQ(estimateTiltFromTrunks(c, TiltEstimatorParams()), Eigen::Vector2d::Zero());
}

TEST(TiltEstimator, ImplausibleTiltGivesNone)
{
  Random rnd(4);
  std::vector<TrunkCandidate> c;
  c.push_back(shearedTrunk({ 6.0, 3.0 }, 0.2, 0.15, 0.0, rnd));
  c.push_back(shearedTrunk({ 8.0, -2.0 }, 0.2, 0.15, 0.0, rnd));
  TiltEstimatorParams params;
  EXPECT_NEAR(estimateTiltFromTrunks(c, params).x(), 0.15, 0.01);
  params.max_tilt = 0.05;  // [rad] the sensor cannot lean that much
  EXPECT_EQ(estimateTiltFromTrunks(c, params), Eigen::Vector2d::Zero());
}
