// One cluster's trunk fit, acceptance and verticality, on clusters whose trunk is known.
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/filter/random.h"
#include "rbpf_slam/core/extraction/trunk_fit.h"

using rbpf_slam::core::checkTrunkFit;
using rbpf_slam::core::fitTrunk;
using rbpf_slam::core::fitTrunkCentroid;
using rbpf_slam::core::fitPartialArc;
using rbpf_slam::core::fitTrunkCircle;
using rbpf_slam::core::fitTrunkPair;
using rbpf_slam::core::isUpright;
using rbpf_slam::core::Random;
using rbpf_slam::core::SilhouetteEdge;
using rbpf_slam::core::toTrunkObservation;
using rbpf_slam::core::TrunkCandidate;
using rbpf_slam::core::TrunkDetectorConfig;
using rbpf_slam::core::TrunkFit;
using rbpf_slam::core::TrunkMethod;
using rbpf_slam::core::TrunkPairFit;
using rbpf_slam::core::TrunkRejection;

namespace
{
/** @p n points of the side facing the sensor (origin) of a trunk, over @p arc [rad], with radial noise. */
std::vector<Eigen::Vector2d> visibleSide(const Eigen::Vector2d& c, double r, double arc, int n, double sigma,
                                         Random& rnd)
{
  const double facing = std::atan2(-c.y(), -c.x());
  std::vector<Eigen::Vector2d> p;
  for (int i = 0; i < n; ++i)
  {
    const double a = facing - 0.5 * arc + arc * i / std::max(1, n - 1);
    const double rr = r + rnd.gaussian(sigma);
    p.emplace_back(c.x() + rr * std::cos(a), c.y() + rr * std::sin(a));
  }
  return p;
}
}  // namespace

TEST(TrunkFit, CleanSideGivesCentreRadiusAndArc)
{
  Random rnd(1);
  const auto p = visibleSide({ 6.0, 2.0 }, 0.2, 100.0 * M_PI / 180.0, 400, 0.01, rnd);  // 8 rings of 50 points
  const TrunkFit fit = fitTrunkCircle(p, TrunkDetectorConfig());
  ASSERT_TRUE(fit.ok);
  EXPECT_EQ(fit.method, TrunkMethod::kCircle);
  EXPECT_NEAR(fit.center.x(), 6.0, 0.02);
  EXPECT_NEAR(fit.center.y(), 2.0, 0.02);
  EXPECT_NEAR(fit.radius, 0.2, 0.015);
  EXPECT_NEAR(fit.arc_angle, 100.0 * M_PI / 180.0, 0.15);
  EXPECT_GE(fit.inliers, 390);
  EXPECT_GT(fit.covariance(0, 0), 0.0);
}

TEST(TrunkFit, ClutterIsLeftOutOfTheCircle)
{
  Random rnd(2);
  auto p = visibleSide({ 7.0, 0.0 }, 0.25, 1.6, 80, 0.008, rnd);
  for (int i = 0; i < 30; ++i)  // twigs in front of the trunk
    p.emplace_back(rnd.uniform(6.2, 6.6), rnd.uniform(-0.3, 0.3));
  const TrunkFit fit = fitTrunkCircle(p, TrunkDetectorConfig());
  ASSERT_TRUE(fit.ok);
  EXPECT_NEAR(fit.center.x(), 7.0, 0.03);
  EXPECT_NEAR(fit.center.y(), 0.0, 0.03);
  EXPECT_NEAR(fit.radius, 0.25, 0.03);
  EXPECT_GE(fit.inliers, 78);
  EXPECT_LT(fit.inliers, 100);
}

TEST(TrunkFit, FewPointsFallBackToTheArc)
{
  // Five points (fewer than min_fit_points) of a far trunk: the centre is put behind the arc, the method says so.
  Random rnd(3);
  const auto p = visibleSide({ 15.0, 0.0 }, 0.2, 0.4, 5, 0.0, rnd);
  TrunkDetectorConfig cfg;
  const TrunkFit fit = fitTrunkCircle(p, cfg);
  ASSERT_TRUE(fit.ok);
  EXPECT_EQ(fit.method, TrunkMethod::kArc);
  EXPECT_NEAR(fit.center.y(), 0.0, 0.01);
  EXPECT_NEAR(fit.center.x(), 15.0, 0.15);
  EXPECT_GT(fit.covariance(0, 0), 1e-3);  // along the ray: the radius is hardly known
}

TEST(TrunkFit, CentroidSitsTowardsTheSensor)
{
  Random rnd(4);
  const auto p = visibleSide({ 8.0, 0.0 }, 0.25, 2.0 * M_PI / 3.0, 100, 0.0, rnd);
  TrunkDetectorConfig cfg;
  cfg.method = TrunkMethod::kCentroid;
  const TrunkFit fit = fitTrunk(p, cfg);
  ASSERT_TRUE(fit.ok);
  EXPECT_EQ(fit.method, TrunkMethod::kCentroid);
  // The centroid of a 120 degree arc lies r sin(60 deg) / (60 deg in rad) = 0.83 r from the centre.
  EXPECT_NEAR(fit.center.x(), 8.0 - 0.827 * 0.25, 0.01);
  EXPECT_NEAR(fit.radius, 0.25 * std::sin(M_PI / 3.0), 0.01);  // half the chord
  EXPECT_EQ(fit.inliers, 100);
  // Its covariance carries the method's own error of about half a radius.
  EXPECT_GT(fit.covariance(0, 0), 0.25 * fit.radius * fit.radius);
}

TEST(TrunkFit, AcceptanceChecksRadiusInliersAndRange)
{
  TrunkDetectorConfig cfg;
  TrunkFit fit;
  fit.ok = true;
  fit.center = Eigen::Vector2d(5.0, 0.0);
  fit.radius = 0.2;
  fit.inliers = 90;
  EXPECT_EQ(checkTrunkFit(fit, 100, cfg), TrunkRejection::kNone);
  EXPECT_EQ(checkTrunkFit(fit, 200, cfg), TrunkRejection::kInliers);
  fit.radius = 0.8;
  EXPECT_EQ(checkTrunkFit(fit, 100, cfg), TrunkRejection::kRadius);
  fit.radius = 0.2;
  fit.center = Eigen::Vector2d(0.3, 0.0);
  EXPECT_EQ(checkTrunkFit(fit, 100, cfg), TrunkRejection::kShape);
  fit.center = Eigen::Vector2d(5.0, 0.0);
  fit.ok = false;
  EXPECT_EQ(checkTrunkFit(fit, 100, cfg), TrunkRejection::kShape);
}

TEST(TrunkFit, UprightTrunksPassLyingBranchesDoNot)
{
  TrunkDetectorConfig cfg;  // max_tilt 0.35 rad
  TrunkCandidate trunk, branch;
  for (int i = 0; i < 20; ++i)
  {
    const double z = -1.3 + 0.07 * i;
    trunk.points.emplace_back(5.0 + 0.05 * (i % 3), 0.02 * (i % 2), z);
    branch.points.emplace_back(5.0 + 0.3 * i, 0.0, -1.3 + 0.04 * i);  // 6 m long, 0.8 m high: about 8 degrees
  }
  for (TrunkCandidate* c : { &trunk, &branch })
  {
    c->z_lo = c->points.front().z();
    c->z_hi = c->points.back().z();
  }
  const auto flat = [](const TrunkCandidate& c) {
    std::vector<Eigen::Vector2d> p;
    for (const auto& q : c.points)
      p.emplace_back(q.x(), q.y());
    return p;
  };
  EXPECT_TRUE(isUpright(trunk, flat(trunk), cfg));
  EXPECT_FALSE(isUpright(branch, flat(branch), cfg));
}

TEST(TrunkFit, ObservationCarriesTheFit)
{
  TrunkFit fit;
  fit.ok = true;
  fit.center = Eigen::Vector2d(3.0, 4.0);
  fit.radius = 0.2;
  fit.covariance = Eigen::Vector3d(1e-4, 2e-4, 3e-4).asDiagonal();
  fit.inliers = 40;
  fit.arc_angle = M_PI / 4.0;
  fit.method = TrunkMethod::kCircle;
  const auto o = toTrunkObservation(fit, 50, -0.5);
  EXPECT_DOUBLE_EQ(o.range, 5.0);
  EXPECT_DOUBLE_EQ(o.bearing, std::atan2(4.0, 3.0));
  EXPECT_DOUBLE_EQ(o.radius_variance, 3e-4);
  EXPECT_DOUBLE_EQ(o.covariance(1, 1), 2e-4);
  // Inlier ratio 0.8, half the full coverage of 90 degrees: 0.8 * (0.5 + 0.25).
  EXPECT_DOUBLE_EQ(o.score, 0.8 * 0.75);
  EXPECT_EQ(o.num_points, 50);
  EXPECT_EQ(o.height, -0.5);
}

TEST(TrunkFit, PartialArcWithOneSilhouetteEdgeGivesTheCentre)
{
  // A trunk of radius 55 mm at 0.8 m seen by beams 0.0061 rad apart, hidden beyond its middle: the beams from its
  // middle to its silhouette edge hit it (range noise 5 mm), the next one passes beside it. Within 20 mm, and the
  // error inside the covariance's 3-sigma ellipse in at least 97 % of 200 trials.
  const double step = 0.0061, r = 0.055;
  const Eigen::Vector2d c(0.78, 0.18);
  const double bearing = std::atan2(c.y(), c.x()), half = std::asin(r / c.norm());
  TrunkDetectorConfig cfg;
  cfg.arc_radius_prior = r;
  cfg.arc_radius_sigma = 0.01;
  cfg.range_sigma = 0.005;
  cfg.min_radius = 0.02;
  cfg.max_radius = 0.15;
  Random rnd(21);
  const int trials = 200;
  int covered = 0;
  for (int trial = 0; trial < trials; ++trial)
  {
    std::vector<Eigen::Vector2d> points;
    double a = bearing + rnd.uniform(-0.5, 0.5) * step;
    for (; a < bearing + half; a += step)
    {
      const Eigen::Vector2d d(std::cos(a), std::sin(a));
      const double b = d.dot(c), disc = b * b - (c.squaredNorm() - r * r);
      points.push_back(d * (b - std::sqrt(disc) + rnd.gaussian(cfg.range_sigma)));
    }
    SilhouetteEdge edge;
    edge.spacing = step;
    const double mid = a - 0.5 * step;
    edge.direction = Eigen::Vector2d(std::cos(mid), std::sin(mid));
    const TrunkFit fit = fitPartialArc(points, { edge }, cfg);
    ASSERT_TRUE(fit.ok) << trial;
    EXPECT_LT((fit.center - c).norm(), 0.02) << trial;
    EXPECT_NEAR(fit.radius, r, 0.02) << trial;
    const Eigen::Vector2d e = fit.center - c;
    covered += e.dot(fit.covariance.topLeftCorner<2, 2>().inverse() * e) <= 11.83;  // 99.7 %
  }
  EXPECT_GE(covered, 0.97 * trials);
}

TEST(TrunkFit, FlatPieceIsNoPartialArc)
{
  // A straight face 0.12 m wide across the line of sight at 1 m, 3 mm noise, ending at a free edge: no circle of
  // about the prior radius fits it tangent to the edge.
  TrunkDetectorConfig cfg;
  cfg.arc_radius_prior = 0.055;
  cfg.arc_radius_sigma = 0.01;
  cfg.range_sigma = 0.003;
  Random rnd(22);
  std::vector<Eigen::Vector2d> points;
  for (double y = -0.06; y <= 0.06; y += 0.006)
    points.emplace_back(1.0 + rnd.gaussian(0.003), y);
  SilhouetteEdge edge;
  edge.spacing = 0.006;
  edge.direction = Eigen::Vector2d(1.0, 0.063).normalized();
  EXPECT_FALSE(fitPartialArc(points, { edge }, cfg).ok);
}

namespace
{
/** What a sensor at the origin sees of two circles, beams @p step [rad] apart: the nearer one hides the other. */
std::vector<Eigen::Vector2d> visiblePair(const Eigen::Vector2d& c0, double r0, const Eigen::Vector2d& c1, double r1,
                                         double step, double sigma, Random& rnd)
{
  std::vector<Eigen::Vector2d> p;
  for (double a = -M_PI; a < M_PI; a += step)
  {
    const Eigen::Vector2d d(std::cos(a), std::sin(a));
    double best = INFINITY;
    for (const auto& cr : { std::make_pair(c0, r0), std::make_pair(c1, r1) })
    {
      const double b = d.dot(cr.first), disc = b * b - (cr.first.squaredNorm() - cr.second * cr.second);
      if (disc >= 0.0 && b - std::sqrt(disc) > 0.0)  // in front of the sensor
        best = std::min(best, b - std::sqrt(disc));
    }
    if (std::isfinite(best))
      p.push_back(d * (best + rnd.gaussian(sigma)));
  }
  return p;
}
}  // namespace

TEST(TrunkFit, PairSeenOnBothSidesOfTheNearTrunkIsSplitInTwo)
{
  // A thin trunk (r 0.1) 5 cm in front of a thick one (r 0.3), both on the line of sight at 5 m: the thick one shows
  // on both sides of the thin one. The single circle is poor; the pair is both trunks, each within 2 cm.
  Random rnd(21);
  const Eigen::Vector2d near(5.0, 0.0), far(5.0 + 0.1 + 0.05 + 0.3, 0.0);
  const std::vector<Eigen::Vector2d> pts = visiblePair(near, 0.1, far, 0.3, 0.001, 0.005, rnd);
  TrunkDetectorConfig cfg;
  const TrunkFit single = fitTrunkCircle(pts, cfg);
  const TrunkPairFit pair = fitTrunkPair(pts, single, cfg);
  ASSERT_TRUE(pair.ok);
  const int k = (pair.fits[0].center - near).norm() < (pair.fits[1].center - near).norm() ? 0 : 1;
  EXPECT_LT((pair.fits[k].center - near).norm(), 0.02);
  EXPECT_LT((pair.fits[1 - k].center - far).norm(), 0.02);
  EXPECT_NEAR(pair.fits[k].radius, 0.1, 0.02);
  EXPECT_NEAR(pair.fits[1 - k].radius, 0.3, 0.02);
  EXPECT_EQ(pair.members[0].size() + pair.members[1].size(), pts.size());
}

TEST(TrunkFit, OneTrunkIsNoPair)
{
  // The visible side of one trunk, clean or noisy, with a tenth of its points scattered around it: no pair.
  for (double sigma : { 0.005, 0.02 })
    for (double r : { 0.08, 0.25, 0.5 })
    {
      Random rnd(static_cast<std::uint64_t>(1000 * r + 100000 * sigma));
      std::vector<Eigen::Vector2d> pts = visibleSide(Eigen::Vector2d(6.0, 1.0), r, 2.6, 120, sigma, rnd);
      for (int i = 0; i < 12; ++i)
        pts.emplace_back(6.0 + rnd.uniform(-2.0 * r, 0.0), 1.0 + rnd.uniform(-1.5 * r, 1.5 * r));
      TrunkDetectorConfig cfg;
      const TrunkFit single = fitTrunkCircle(pts, cfg);
      EXPECT_FALSE(fitTrunkPair(pts, single, cfg).ok) << "r " << r << " sigma " << sigma;
    }
}
