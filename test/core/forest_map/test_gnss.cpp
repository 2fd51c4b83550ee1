#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/fastslam/fastslam.h"
#include "rbpf_slam/sim/forest_simulator.h"
#include "rbpf_slam/core/forest_map/geodesy.h"
#include "rbpf_slam/core/forest_map/gnss.h"
#include "rbpf_slam/core/filter/random.h"
#include "core/forest_map/gnss_test_util.h"

namespace rbpf_slam
{
namespace core
{
namespace
{
GeoAnchor anchorAt(double lat, double lon, double yaw, double sigma)
{
  GeoAnchor a;
  a.valid = true;
  a.latitude = lat;
  a.longitude = lon;
  a.altitude = 300.0;
  a.yaw = yaw;
  a.sigma = sigma;
  return a;
}

/** @brief [m] between two WGS84 points, in the tangent plane at the first. */
double metresBetween(const GeoAnchor& a, double lat, double lon)
{
  const LocalTangentPlane p(GeoPoint{ a.latitude, a.longitude, a.altitude });
  return p.toEastNorth(lat, lon).norm();
}
}  // namespace

TEST(Geodesy, TangentPlaneScaleAndRoundTrip)
{
  const LocalTangentPlane plane(GeoPoint{ 47.0, 8.0, 0.0 });
  // A thousandth of a degree of latitude at 47 deg is 111.18 m, one of longitude 76.06 m (WGS84).
  const Eigen::Vector2d north = plane.toEastNorth(47.001, 8.0), east = plane.toEastNorth(47.0, 8.001);
  EXPECT_NEAR(north.y(), 111.18, 0.05);
  EXPECT_NEAR(north.x(), 0.0, 1e-9);
  EXPECT_NEAR(east.x(), 76.06, 0.05);
  const GeoPoint back = plane.toGeo(Eigen::Vector2d(-321.5, 812.25));
  const Eigen::Vector2d again = plane.toEastNorth(back.latitude, back.longitude);
  EXPECT_NEAR(again.x(), -321.5, 1e-6);
  EXPECT_NEAR(again.y(), 812.25, 1e-6);
}

TEST(Geodesy, AnchoredFrameTurnsByTheAnchorsHeading)
{
  // The frame's x axis points north-east (45 deg from east): its point (10, 0) lies 7.07 m east and north.
  const GeoAnchor a = anchorAt(-33.5, 151.0, M_PI / 4.0, 0.0);
  const GeoPoint g = anchoredToGeo(a, 10.0, 0.0);
  const LocalTangentPlane plane(GeoPoint{ a.latitude, a.longitude, a.altitude });
  const Eigen::Vector2d en = plane.toEastNorth(g.latitude, g.longitude);
  EXPECT_NEAR(en.x(), 10.0 / std::sqrt(2.0), 1e-6);
  EXPECT_NEAR(en.y(), 10.0 / std::sqrt(2.0), 1e-6);
  const Eigen::Vector2d p = geoToAnchored(a, g.latitude, g.longitude);
  EXPECT_NEAR(p.x(), 10.0, 1e-6);
  EXPECT_NEAR(p.y(), 0.0, 1e-6);
}

TEST(Gnss, FixProblemsAreNamed)
{
  GnssFix f;
  EXPECT_EQ(gnssFixProblem(f, 50.0), "no fix");
  f.valid = true;
  f.latitude = 47.0;
  f.longitude = 8.0;
  EXPECT_EQ(gnssFixProblem(f, 50.0), "");
  f.latitude = NAN;
  EXPECT_NE(gnssFixProblem(f, 50.0).find("latitude"), std::string::npos);
  f.latitude = 47.0;
  f.covariance << 1.0, 0.0, 0.0, -1.0;
  EXPECT_NE(gnssFixProblem(f, 50.0).find("positive definite"), std::string::npos);
  f.covariance = 10000.0 * Eigen::Matrix2d::Identity();
  EXPECT_NE(gnssFixProblem(f, 50.0).find("beyond"), std::string::npos);
  f.covariance(0, 1) = NAN;
  EXPECT_NE(gnssFixProblem(f, 50.0).find("not finite"), std::string::npos);
}

TEST(Gnss, ReceiverErrorsMatchWhatItReports)
{
  GnssConfig c;
  c.enabled = true;
  c.outage_interval = 0.0;
  GnssReceiver rx(c, 7);
  const LocalTangentPlane plane(c.origin);
  for (double canopy : { 0.0, 1.0 })
  {
    double sum2 = 0.0, reported = 0.0;
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    const int n = 20000;
    for (int i = 0; i < n; ++i)
    {
      const GnssSample s = rx.sample(canopy * 1e6 + i, Eigen::Vector3d(5.0, -3.0, 1.5), canopy);
      ASSERT_TRUE(s.fix.valid);
      const Eigen::Vector2d t = plane.toEastNorth(s.truth.latitude, s.truth.longitude);
      EXPECT_NEAR(t.x(), 5.0, 1e-6);
      EXPECT_NEAR(t.y(), -3.0, 1e-6);
      const Eigen::Vector2d e = plane.toEastNorth(s.fix.latitude, s.fix.longitude) - t;
      mean += e / n;
      sum2 += e.squaredNorm() / (2.0 * n);
      reported += 0.5 * s.fix.covariance.trace() / n;
    }
    // 20000 s at a bias time of 30 s: about 670 independent bias values.
    const double sigma = std::sqrt(reported);
    EXPECT_NEAR(std::sqrt(sum2), sigma, 0.1 * sigma) << "canopy " << canopy;
    EXPECT_LT(mean.norm(), 0.25 * sigma) << "canopy " << canopy;
    EXPECT_NEAR(sigma, canopy > 0.5 ? std::hypot(c.canopy_sigma, c.canopy_bias_sigma) :
                                      std::hypot(c.open_sigma, c.open_bias_sigma), 1e-9);
  }
}

TEST(Gnss, OutagesComeUnderCanopyOnly)
{
  GnssConfig c;
  c.enabled = true;
  c.outage_interval = 60.0;
  c.outage_duration = 10.0;
  for (double canopy : { 0.0, 1.0 })
  {
    GnssReceiver rx(c, 3);
    int lost = 0;
    const int n = 36000;
    for (int i = 0; i < n; ++i)
      lost += rx.sample(i, Eigen::Vector3d::Zero(), canopy).fix.valid ? 0 : 1;
    if (canopy == 0.0)
      EXPECT_EQ(lost, 0);
    else  // about 10 s lost per 70 s
      EXPECT_NEAR(static_cast<double>(lost) / n, 10.0 / 70.0, 0.04);
  }
}

TEST(Gnss, SimulatorGivesFixesAtItsRateWithTheirTruth)
{
  sim::ForestWorld world;
  world.trunks.push_back(sim::TrunkSpec());
  world.trunks.back().x = 3.0;
  world.trunks.back().y = 15.0;
  sim::SimulatorConfig c;
  c.lidar3d.enabled = false;
  c.gnss.enabled = true;
  c.gnss.rate = 2.0;
  c.gnss.antenna = Eigen::Vector3d::Zero();  // at base_link: the body's tilt on the slope moves it not
  sim::ForestSimulator sim(world, c);
  EXPECT_GT(sim.canopyAt(3.0, 15.0), 0.0);
  EXPECT_EQ(sim.canopyAt(100.0, 100.0), 0.0);
  sim::SimulatorOutput out;
  int fixes = 0;
  for (int i = 0; i < 2000; ++i)  // 10 s
  {
    out.clear();
    sim.step(&out);
    for (const GnssSample& s : out.gnss)
    {
      ++fixes;
      // The robot stands at the start (0, 15) of the world, whose origin is the receiver's.
      const LocalTangentPlane plane(c.gnss.origin);
      const Eigen::Vector2d t = plane.toEastNorth(s.truth.latitude, s.truth.longitude);
      EXPECT_NEAR(t.x(), 0.0, 0.01);
      EXPECT_NEAR(t.y(), 15.0, 0.01);
    }
  }
  EXPECT_EQ(fixes, 20);
}

TEST(GeoAnchor, FitFindsTheAnchorOfAFrameFromNoisyFixes)
{
  const GeoAnchor truth = anchorAt(61.5, 24.3, 1.1, 0.0);
  GnssFusionConfig fc;
  GeoAnchorEstimator est(fc);
  Random rng(5);
  for (int i = 0; i < 300; ++i)  // a 20 m circle in the frame, a fix a second, 1 m white noise
  {
    const double a = i * 0.05;
    const Eigen::Vector2d p(20.0 + 20.0 * std::cos(a), 20.0 * std::sin(a));
    const GeoPoint g = anchoredToGeo(truth, p.x() + rng.gaussian(1.0), p.y() + rng.gaussian(1.0));
    est.add(test::validFix(g, i), p);
    if (i == 10)
    {
      EXPECT_FALSE(est.anchor().valid) << "too few fixes";
    }
  }
  const GeoAnchor a = est.anchor();
  ASSERT_TRUE(a.valid);
  EXPECT_LT(metresBetween(truth, a.latitude, a.longitude), 0.3);
  EXPECT_NEAR(a.yaw, truth.yaw, 0.02);
  EXPECT_GT(a.sigma, 0.05);
  EXPECT_LT(a.sigma, 1.0);
}

TEST(GeoAnchor, FixesAtOneSpotGiveNoAnchor)
{
  GeoAnchorEstimator est;
  const GeoAnchor truth = anchorAt(47.0, 8.0, 0.0, 0.0);
  for (int i = 0; i < 100; ++i)
  {
    est.add(test::validFix(anchoredToGeo(truth, 1.0, 2.0), i), Eigen::Vector2d(1.0, 2.0));
  }
  EXPECT_EQ(est.fixes(), 100);
  EXPECT_FALSE(est.anchor().valid);
}

TEST(GeoAnchor, CombinedAnchorsWeighByTheirSigmas)
{
  const GeoAnchor a = anchorAt(47.0, 8.0, 0.10, 2.0);
  const GeoPoint east = anchoredToGeo(anchorAt(47.0, 8.0, 0.0, 0.0), 4.0, 0.0);
  const GeoAnchor b = anchorAt(east.latitude, east.longitude, 0.20, 2.0);
  const GeoAnchor c = combineAnchors(a, b);
  ASSERT_TRUE(c.valid);
  const LocalTangentPlane plane(GeoPoint{ a.latitude, a.longitude, a.altitude });
  const Eigen::Vector2d en = plane.toEastNorth(c.latitude, c.longitude);
  EXPECT_NEAR(en.x(), 2.0, 1e-3);
  EXPECT_NEAR(en.y(), 0.0, 1e-3);
  EXPECT_NEAR(c.yaw, 0.15, 1e-3);
  EXPECT_NEAR(c.sigma, 2.0 / std::sqrt(2.0), 1e-9);
  // An exact anchor (sigma 0, e.g. surveyed) stays as it is; a missing one is ignored.
  GeoAnchor exact = a;
  exact.sigma = 0.0;
  EXPECT_EQ(combineAnchors(exact, b).latitude, exact.latitude);
  EXPECT_EQ(combineAnchors(GeoAnchor(), b).longitude, b.longitude);
}

TEST(GeoAnchor, FixInFrameCarriesTheAnchorsUncertainty)
{
  const GeoAnchor a = anchorAt(47.0, 8.0, 0.3, 1.5);
  const GeoPoint g = anchoredToGeo(a, 12.0, -4.0);
  GnssFix f;
  f.valid = true;
  f.latitude = g.latitude;
  f.longitude = g.longitude;
  f.covariance = 0.25 * Eigen::Matrix2d::Identity();
  Eigen::Vector2d z;
  Eigen::Matrix2d cov;
  gnssInFrame(f, a, 1.0, &z, &cov);
  EXPECT_NEAR(z.x(), 12.0, 1e-6);
  EXPECT_NEAR(z.y(), -4.0, 1e-6);
  EXPECT_NEAR(cov(0, 0), 1.0 + 2.25, 1e-9);  // floored at 1 m, plus the anchor's 1.5 m
}

TEST(FastSlamPosition, WeighingFavoursTheParticlesNearTheFix)
{
  FastSlamConfig c;
  c.particles = 200;
  FastSlam f(c);
  LandmarkMap empty;
  f.initialize({ Pose2(0.0, 0.0, 0.0), Pose2(10.0, 0.0, 0.0) }, empty, 0.5, 0.01);
  const Eigen::Vector2d antenna(0.5, 0.0);
  const double neff = f.weighPosition(Eigen::Vector2d(10.5, 0.0), 4.0 * Eigen::Matrix2d::Identity(), antenna);
  EXPECT_GT(neff, 0.0);
  EXPECT_LT(neff, 0.7);  // half the particles are 10 m (5 sigma) off
  EXPECT_NEAR(f.best().pose.x, 10.0, 2.0);
  EXPECT_NEAR(f.meanPose().x, 10.0, 0.5);
  double total = 0.0;
  for (const Particle& p : f.particles())
    total += std::exp(p.log_weight);
  EXPECT_NEAR(total, 1.0, 1e-9);
  EXPECT_EQ(f.weighPosition(Eigen::Vector2d(NAN, 0.0), Eigen::Matrix2d::Identity()), -1.0);
}

}  // namespace core
}  // namespace rbpf_slam
