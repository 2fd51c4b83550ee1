// Satellite fixes on the FastSLAM filter (core::GnssAnchoring): which fixes are refused, the anchor fitted to
// fixes of the antenna, a receiver's jump rejected by the gate, the particles weighed, a restart forgetting.
#include <cmath>

#include <gtest/gtest.h>

#include "rbpf_slam/core/forest_map/gnss_anchoring.h"
#include "core/forest_map/gnss_test_util.h"

using rbpf_slam::core::FastSlam;
using rbpf_slam::core::FastSlamConfig;
using rbpf_slam::core::GeoAnchor;
using rbpf_slam::core::GeoPoint;
using rbpf_slam::core::GnssAnchoring;
using rbpf_slam::core::GnssFix;
using rbpf_slam::core::GnssFusionConfig;
using rbpf_slam::core::OdometryBuffer;
using rbpf_slam::core::Pose2;

namespace
{
GeoAnchor trueAnchor()
{
  GeoAnchor a;
  a.valid = true;
  a.latitude = 61.5;
  a.longitude = 24.3;
  a.altitude = 300.0;
  a.yaw = 0.4;
  return a;
}

/** @brief [m] between two WGS84 points, in the tangent plane at the first. */
double metresBetween(const GeoAnchor& a, double lat, double lon)
{
  const rbpf_slam::core::LocalTangentPlane p(GeoPoint{ a.latitude, a.longitude, a.altitude });
  return p.toEastNorth(lat, lon).norm();
}

GnssFix fixAt(double stamp, const Eigen::Vector2d& map_position, double offset_east = 0.0, double offset_north_deg = 0.0)
{
  GeoPoint g = rbpf_slam::core::anchoredToGeo(trueAnchor(), map_position.x(), map_position.y());
  g.latitude += offset_north_deg;
  // a receiver's jump: metres east (the longitude's metres at this latitude)
  g.longitude += offset_east / (111320.0 * std::cos(61.5 * M_PI / 180.0));
  return rbpf_slam::test::validFix(g, stamp);
}

/**
 * The robot drives a circle of @p radius at 1 m/s for @p steps seconds with @p filter on the truth at every update;
 * each second a fix @p fix(k, t, antenna position) of the antenna 0.2 m ahead goes to @p g, and @p before_use(k) runs
 * before @p g uses the fixes due.
 */
template <typename Fix, typename Hook>
void driveCircle(double radius, int steps, GnssAnchoring* g, FastSlam* filter, const Fix& fix, const Hook& before_use)
{
  OdometryBuffer odometry;
  const Eigen::Vector2d antenna(0.2, 0.0);
  for (int k = 0; k <= steps; ++k)
  {
    const double t = k, w = 1.0 / radius;
    const Pose2 pose(radius * std::sin(w * t), radius * (1.0 - std::cos(w * t)), w * t);
    odometry.add(t, pose);
    filter->initialize(pose);
    Eigen::Vector2d at;
    pose.transformPoint(antenna.x(), antenna.y(), &at.x(), &at.y());
    ASSERT_EQ(g->add(fix(k, t, at), antenna, k > 0 ? t - 1.0 : NAN), "");
    before_use(k);
    g->use(t, pose, odometry, filter);
  }
}
}  // namespace

TEST(GnssAnchoring, RefusedFixesAreNamed)
{
  GnssFusionConfig off;
  off.enabled = false;
  GnssAnchoring disabled(off);
  EXPECT_NE(disabled.add(fixAt(1.0, Eigen::Vector2d::Zero()), Eigen::Vector2d::Zero(), NAN).find("not used"),
            std::string::npos);
  GnssAnchoring g{ GnssFusionConfig() };
  GnssFix outage = fixAt(1.0, Eigen::Vector2d::Zero());
  outage.valid = false;
  EXPECT_FALSE(g.add(outage, Eigen::Vector2d::Zero(), NAN).empty());
  EXPECT_NE(g.add(fixAt(1.0, Eigen::Vector2d::Zero()), Eigen::Vector2d(NAN, 0.0), NAN).find("antenna"),
            std::string::npos);
  EXPECT_EQ(g.add(fixAt(5.0, Eigen::Vector2d::Zero()), Eigen::Vector2d::Zero(), 4.5), "");
  EXPECT_NE(g.add(fixAt(3.0, Eigen::Vector2d::Zero()), Eigen::Vector2d::Zero(), 4.5).find("older than the last"),
            std::string::npos);
  EXPECT_NE(g.add(fixAt(5.0, Eigen::Vector2d::Zero()), Eigen::Vector2d::Zero(), 4.5).find("not after the previous"),
            std::string::npos);
}

TEST(GnssAnchoring, TheAnchorIsFittedAJumpIsRejectedAndTheParticlesAreWeighed)
{
  FastSlamConfig fc;
  fc.particles = 100;
  fc.seed = 4;
  FastSlam filter(fc);
  // The robot drives a circle of 10 m radius at 1 m/s, a fix a second; the filter sits on the truth.
  GnssFusionConfig gc;
  gc.correlation_time = 5.0;
  GnssAnchoring g(gc);
  int weighed_before = 0;
  driveCircle(
      10.0, 60, &g, &filter, [](int k, double t, const Eigen::Vector2d& at) { return fixAt(t, at, k == 50 ? 60.0 : 0.0); },
      [&](int k) {
        if (k == 49)
          weighed_before = g.weighed();
      });
  EXPECT_EQ(g.used() + g.rejected(), 61);
  EXPECT_EQ(g.rejected(), 1) << "the 60 m jump is outside the gate once an anchor is known";
  const GeoAnchor a = g.anchor();
  ASSERT_TRUE(a.valid);
  EXPECT_LT(metresBetween(trueAnchor(), a.latitude, a.longitude), 0.3);
  EXPECT_NEAR(a.yaw, 0.4, 0.02);
  EXPECT_GT(g.weighed(), 0);
  EXPECT_LE(g.weighed(), 61 / 5 + 1) << "at most one fix per correlation time weighs the particles";
  EXPECT_GE(g.weighed(), weighed_before);

  // A restart forgets this timeline's fit; the counts stay.
  const int used = g.used();
  g.restart();
  EXPECT_FALSE(g.anchor().valid);
  EXPECT_EQ(g.used(), used);
  // With the saved map's anchor set, it is the anchor at once.
  g.setMapAnchor(trueAnchor());
  EXPECT_TRUE(g.anchor().valid);
  EXPECT_NEAR(g.anchor().latitude, 61.5, 1e-12);
}

TEST(GnssAnchoring, WildFirstFixesDoNotLockTheAnchor)
{
  // The receiver's first 20 fixes lie 1000 km north (9 degrees of latitude, where a degree of longitude is 30 %
  // shorter), before any anchor exists, so the first anchor is theirs and its gate refuses the good fixes after
  // them. The robust fit still sees the refused fixes: once they are the many, the anchor is theirs, within a metre
  // of the truth, the 20 are counted as left out, and the good fixes weigh the particles again.
  FastSlamConfig fc;
  fc.particles = 50;
  fc.seed = 2;
  FastSlam filter(fc);
  GnssFusionConfig gc;
  gc.correlation_time = 5.0;
  GnssAnchoring g(gc);
  int weighed_at_40 = 0;
  driveCircle(
      20.0, 120, &g, &filter,
      [](int k, double t, const Eigen::Vector2d& at) { return fixAt(t, at, 0.0, k < 20 ? 9.0 : 0.0); },
      [&](int k) {
        if (k == 41)
          weighed_at_40 = g.weighed();  // after the fixes of second 40 were used
      });
  const GeoAnchor a = g.anchor();
  ASSERT_TRUE(a.valid);
  EXPECT_LT(metresBetween(trueAnchor(), a.latitude, a.longitude), 1.0);
  EXPECT_NEAR(a.yaw, 0.4, 0.02);
  EXPECT_EQ(g.anchorOutliers(), 20);
  EXPECT_GT(g.weighed(), weighed_at_40) << "good fixes weigh the particles once the anchor is theirs";
}
