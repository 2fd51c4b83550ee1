// Circle fits on points whose circle is known.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/extraction/circle_fit.h"
#include "rbpf_slam/core/filter/random.h"

using rbpf_slam::core::circleCovariance;
using rbpf_slam::core::circleInliers;
using rbpf_slam::core::CircleRefineParams;
using rbpf_slam::core::countCircleInliers;
using rbpf_slam::core::fitCircleAlgebraic;
using rbpf_slam::core::fitCircleAlgebraicProjected;
using rbpf_slam::core::Random;
using rbpf_slam::core::ransacCircle;
using rbpf_slam::core::RansacCircleParams;
using rbpf_slam::core::refineCircle;
using rbpf_slam::core::subtendedAngle;

namespace
{
/** @p n points evenly over [a0, a1] on the circle, with Gaussian radial noise. */
std::vector<Eigen::Vector2d> arc(const Eigen::Vector2d& c, double r, double a0, double a1, int n, double sigma,
                                 Random& rnd)
{
  std::vector<Eigen::Vector2d> p;
  for (int i = 0; i < n; ++i)
  {
    const double a = a0 + (a1 - a0) * i / std::max(1, n - 1);
    const double rr = r + rnd.gaussian(sigma);
    p.emplace_back(c.x() + rr * std::cos(a), c.y() + rr * std::sin(a));
  }
  return p;
}
}  // namespace

TEST(CircleFit, AlgebraicFitIsExactWithoutNoise)
{
  Random rnd(1);
  const auto p = arc({ 7.0, -3.0 }, 0.25, 0.3, 1.5, 30, 0.0, rnd);
  Eigen::Vector2d c;
  double r = 0.0;
  ASSERT_TRUE(fitCircleAlgebraic(p, &c, &r));
  EXPECT_NEAR(c.x(), 7.0, 1e-9);
  EXPECT_NEAR(c.y(), -3.0, 1e-9);
  EXPECT_NEAR(r, 0.25, 1e-9);
}

TEST(CircleFit, AlgebraicFitOf3DPointsIsThatOfTheirProjection)
{
  Random rnd(9);
  const auto p2 = arc({ -5.0, 2.0 }, 0.3, -0.4, 0.9, 40, 0.01, rnd);
  std::vector<Eigen::Vector3d> p3;
  for (const auto& q : p2)
    p3.emplace_back(q.x(), q.y(), rnd.uniform(-1.5, 0.5));
  Eigen::Vector2d c2, c3;
  double r2 = 0.0, r3 = 0.0;
  ASSERT_TRUE(fitCircleAlgebraic(p2, &c2, &r2));
  ASSERT_TRUE(fitCircleAlgebraicProjected(p3, &c3, &r3));
  EXPECT_EQ(c2, c3);
  EXPECT_EQ(r2, r3);
}

TEST(CircleFit, AlgebraicFitRefusesTooFewPoints)
{
  Eigen::Vector2d c;
  double r = 0.0;
  EXPECT_FALSE(fitCircleAlgebraic({ { 1.0, 0.0 }, { 0.0, 1.0 } }, &c, &r));
  EXPECT_TRUE(fitCircleAlgebraic({ { 1.0, 0.0 }, { 0.0, 1.0 }, { -1.0, 0.0 } }, &c, &r));
  EXPECT_NEAR(c.norm(), 0.0, 1e-12);
  EXPECT_NEAR(r, 1.0, 1e-12);
}

TEST(CircleFit, InliersAreThePointsWithinTheThreshold)
{
  const Eigen::Vector2d c(2.0, 1.0);
  // Distances to the circle (r = 0.5): 0, 0.03, -0.039, 0.05, -0.2.
  const std::vector<Eigen::Vector2d> p{ { 2.5, 1.0 }, { 2.0, 1.53 }, { 1.539, 1.0 }, { 2.0, 0.45 }, { 2.3, 1.0 } };
  EXPECT_EQ(countCircleInliers(p, c, 0.5, 0.04), 3);
  const auto in = circleInliers(p, c, 0.5, 0.04);
  ASSERT_EQ(in.size(), 3u);
  EXPECT_EQ(in[0], p[0]);
  EXPECT_EQ(in[1], p[1]);
  EXPECT_EQ(in[2], p[2]);
  EXPECT_EQ(countCircleInliers(p, c, 0.5, 0.3), 5);
}

TEST(CircleFit, SubtendedAngleIsTheArcWithoutItsWidestGap)
{
  Random rnd(2);
  const Eigen::Vector2d c(-4.0, 5.0);
  EXPECT_NEAR(subtendedAngle(arc(c, 0.3, 0.2, 0.2 + M_PI / 2, 50, 0.0, rnd), c), M_PI / 2, 1e-9);
  // Across the ±π cut of atan2.
  EXPECT_NEAR(subtendedAngle(arc(c, 0.3, 2.8, 3.8, 50, 0.0, rnd), c), 1.0, 1e-9);
  EXPECT_EQ(subtendedAngle({ { 1.0, 0.0 } }, Eigen::Vector2d::Zero()), 0.0);
}

TEST(CircleFit, RansacFindsTheCircleAmongClutter)
{
  Random rnd(3);
  const Eigen::Vector2d c(6.0, 2.0);
  auto p = arc(c, 0.2, M_PI - 0.9, M_PI + 0.9, 60, 0.005, rnd);
  // 40 % clutter: a bush's points scattered in front of the trunk.
  for (int i = 0; i < 40; ++i)
    p.emplace_back(rnd.uniform(5.0, 5.7), rnd.uniform(1.5, 2.5));
  RansacCircleParams params;
  Eigen::Vector2d rc;
  double rr = 0.0;
  ASSERT_TRUE(ransacCircle(p, params, &rc, &rr));
  EXPECT_NEAR(rc.x(), 6.0, 0.03);
  EXPECT_NEAR(rc.y(), 2.0, 0.03);
  EXPECT_NEAR(rr, 0.2, 0.03);
  EXPECT_GE(countCircleInliers(p, rc, rr, params.threshold), 58);
  // The algebraic fit on all points is pulled away by the clutter.
  Eigen::Vector2d kc;
  double kr = 0.0;
  ASSERT_TRUE(fitCircleAlgebraic(p, &kc, &kr));
  EXPECT_GT((kc - c).norm(), 0.1);
  // Repeatable.
  Eigen::Vector2d rc2;
  double rr2 = 0.0;
  ASSERT_TRUE(ransacCircle(p, params, &rc2, &rr2));
  EXPECT_EQ(rc, rc2);
  EXPECT_EQ(rr, rr2);
}

TEST(CircleFit, RansacKeepsToTheRadiusLimits)
{
  Random rnd(4);
  const auto p = arc({ 3.0, 0.0 }, 1.5, 2.5, 3.8, 40, 0.002, rnd);  // a wall-like arc of radius 1.5
  RansacCircleParams params;
  params.max_radius = 0.6;
  Eigen::Vector2d c;
  double r = 0.0;
  if (ransacCircle(p, params, &c, &r))
  {
    EXPECT_LE(r, 0.6 + 1e-6);
  }
  params.max_radius = 2.0;
  ASSERT_TRUE(ransacCircle(p, params, &c, &r));
  EXPECT_NEAR(r, 1.5, 0.05);
}

TEST(CircleFit, RefinementRemovesTheAlgebraicBiasOfShortNoisyArcs)
{
  // A 60 degree arc with 1 cm noise: the algebraic fit shrinks the circle; the geometric one does not, on average.
  CircleRefineParams params;
  params.range_sigma = 0.01;
  params.radius_sigma = 10.0;  // [m] no prior to speak of: the data alone
  double kasa_err = 0.0, refined_err = 0.0;
  const int runs = 40;
  for (int k = 0; k < runs; ++k)
  {
    Random rnd(100 + k);
    const Eigen::Vector2d c0(8.0, 0.0);
    const auto p = arc(c0, 0.25, M_PI - 0.52, M_PI + 0.52, 80, 0.01, rnd);
    Eigen::Vector2d c;
    double r = 0.0;
    ASSERT_TRUE(fitCircleAlgebraic(p, &c, &r));
    kasa_err += (r - 0.25) / runs;
    Eigen::Matrix3d cov;
    ASSERT_TRUE(refineCircle(p, params, &c, &r, &cov));
    refined_err += (r - 0.25) / runs;
    // Each estimate within four standard deviations of its own covariance.
    ASSERT_GT(cov(0, 0), 0.0);
    ASSERT_GT(cov(2, 2), 0.0);
    EXPECT_LT(std::abs(c.x() - 8.0), 4.0 * std::sqrt(cov(0, 0)));
    EXPECT_LT(std::abs(r - 0.25), 4.0 * std::sqrt(cov(2, 2)));
  }
  EXPECT_LT(kasa_err, -0.01);
  EXPECT_LT(std::abs(refined_err), 0.005);
}

TEST(CircleFit, RadiusPriorHoldsAnArcTooShortToFit)
{
  // Five points over 6 degrees of a 0.3 m trunk: the arc cannot tell its radius, the prior does.
  Random rnd(5);
  const auto p = arc({ 10.0, 0.0 }, 0.3, M_PI - 0.05, M_PI + 0.05, 5, 0.0, rnd);
  CircleRefineParams params;
  params.radius_prior = 0.15;
  params.radius_sigma = 0.08;
  Eigen::Vector2d c(9.85, 0.0);
  double r = 0.15;
  Eigen::Matrix3d cov;
  ASSERT_TRUE(refineCircle(p, params, &c, &r, &cov));
  EXPECT_GT(r, 0.05);
  EXPECT_LT(r, 0.45);
  EXPECT_NEAR(c.y(), 0.0, 0.01);
  // The radius is known about as well as the prior says, and the centre along the ray no better.
  EXPECT_GT(std::sqrt(cov(2, 2)), 0.05);
  EXPECT_GT(std::sqrt(cov(0, 0)), 0.05);
}

TEST(CircleFit, CovarianceShrinksWithPointsAndGrowsWithTheResiduals)
{
  CircleRefineParams params;
  params.range_sigma = 0.01;
  Random rnd(6);
  const Eigen::Vector2d c0(5.0, 0.0);
  const auto few = arc(c0, 0.2, 2.4, 3.9, 40, 0.0, rnd);
  const auto many = arc(c0, 0.2, 2.4, 3.9, 160, 0.0, rnd);
  const auto noisy = arc(c0, 0.2, 2.4, 3.9, 160, 0.05, rnd);  // five times the sensor noise
  Eigen::Matrix3d cov_few, cov_many, cov_noisy;
  Eigen::Vector2d c = c0;
  double r = 0.2;
  ASSERT_TRUE(refineCircle(few, params, &c, &r, &cov_few));
  c = c0;
  r = 0.2;
  ASSERT_TRUE(refineCircle(many, params, &c, &r, &cov_many));
  // Four times the points: about a quarter of the variance of the centre.
  EXPECT_NEAR(cov_many(0, 0) / cov_few(0, 0), 0.25, 0.05);
  c = c0;
  r = 0.2;
  ASSERT_TRUE(refineCircle(noisy, params, &c, &r, &cov_noisy));
  EXPECT_GT(cov_noisy(1, 1), 10.0 * cov_many(1, 1));
  // circleCovariance on its own: residuals at the sensor noise leave the information as it is.
  Eigen::Matrix3d info = Eigen::Matrix3d::Identity() * 1e4;
  info(2, 2) += 1.0 / (params.radius_sigma * params.radius_sigma);
  Eigen::Matrix3d cov;
  ASSERT_TRUE(circleCovariance(many, c0, 0.2, info, params, &cov));
  EXPECT_NEAR(cov(0, 0), 1e-4, 1e-9);
}
