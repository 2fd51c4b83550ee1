// Particle-filter skeleton, FastSLAM and the evaluator on cases whose answer is known.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <vector>

#include <Eigen/Dense>

#include "rbpf_slam/eval/evaluation.h"
#include "core/fastslam/fastslam_test_util.h"
#include "rbpf_slam/core/fastslam/fastslam.h"
#include "rbpf_slam/core/fastslam/landmark_map.h"
#include "rbpf_slam/core/filter/particle_filter.h"
#include "rbpf_slam/core/trunk_slam/trunk_slam_pipeline.h"

using namespace rbpf_slam::core;
using namespace rbpf_slam::eval;
using rbpf_slam::test::observe;
using rbpf_slam::test::quietConfig;

TEST(ParticleFilter, OdometryMotionMomentsMatchTheModel)
{
  OdometryMotionNoise n;
  n.alpha1 = 0.1;
  n.alpha2 = 0.02;
  n.alpha3 = 0.05;
  n.alpha4 = 0.01;
  const OdometryIncrement u = decomposeOdometry(Pose2(0, 0, 0), Pose2(1.0, 0.0, 0.0));
  EXPECT_NEAR(u.trans, 1.0, 1e-12);
  EXPECT_NEAR(u.rot1, 0.0, 1e-12);
  Random r(1);
  const int n_samples = 20000;
  double sx = 0, sxx = 0, st = 0, stt = 0;
  for (int i = 0; i < n_samples; ++i)
  {
    const Pose2 p = sampleOdometryMotion(Pose2(), u, n, r);
    sx += p.x;
    sxx += p.x * p.x;
    st += p.theta;
    stt += p.theta * p.theta;
  }
  const double mx = sx / n_samples, vx = sxx / n_samples - mx * mx;
  const double mt = st / n_samples, vt = stt / n_samples - mt * mt;
  EXPECT_NEAR(mx, 1.0, 0.002);
  EXPECT_NEAR(std::sqrt(vx), 0.05, 0.002);  // alpha3 * trans (rot1 ~ 0 adds only second order)
  // Heading: rot1 and rot2 each alpha2 * trans -> sqrt(2) * 0.02.
  EXPECT_NEAR(mt, 0.0, 0.001);
  EXPECT_NEAR(std::sqrt(vt), std::sqrt(2.0) * 0.02, 0.001);
}

TEST(FastSlam, WithoutNoiseEveryParticleFollowsTheOdometry)
{
  FastSlam f(quietConfig(50));
  OdometryIncrement u;
  u.trans = 0.2;
  for (int i = 0; i < 100; ++i)
    f.predict(u);
  EXPECT_LT(std::sqrt(f.poseCovariance()(2, 2)), 1e-12);
  EXPECT_NEAR(f.meanPose().x, 20.0, 1e-9);
}

TEST(ParticleFilter, LowVarianceResamplingPreservesTheWeights)
{
  const std::vector<double> w{ 0.5, 0.25, 0.125, 0.125 };
  Random r(2);
  std::vector<int> counts(4, 0);
  for (int rep = 0; rep < 2000; ++rep)
  {
    std::vector<int> once(4, 0);
    for (int k : lowVarianceResample(w, r))
      ++once[static_cast<std::size_t>(k)];
    // Systematic resampling: particle i gets floor(N w_i) or ceil(N w_i) copies, never more or fewer.
    for (std::size_t i = 0; i < w.size(); ++i)
    {
      EXPECT_GE(once[i], static_cast<int>(std::floor(4 * w[i])));
      EXPECT_LE(once[i], static_cast<int>(std::ceil(4 * w[i])));
      counts[i] += once[i];
    }
  }
  for (std::size_t i = 0; i < w.size(); ++i)
    EXPECT_NEAR(counts[i] / (2000.0 * 4), w[i], 0.01);  // and N w_i on average
  EXPECT_NEAR(effectiveSampleSize({ 0.25, 0.25, 0.25, 0.25 }), 4.0, 1e-12);
  std::vector<double> lw{ -1000.0, -1001.0 }, out;
  normalizeLogWeights(&lw, &out);
  EXPECT_NEAR(out[0], 1.0 / (1.0 + std::exp(-1.0)), 1e-12);
}

TEST(FastSlam, EkfUpdateMatchesAHandComputedCase)
{
  FastSlam f(quietConfig());
  f.initialize(Pose2());
  // First sighting at (2, 0): covariance G R G^T with G = diag(1, 2) at bearing 0.
  f.update({ observe(Pose2(), 2.0, 0.0, 0.1, 0.05) }, Pose2());
  ASSERT_EQ(f.best().map.size(), 1u);
  const Landmark& l0 = f.best().map[0];
  const double r_var = 0.1 * 0.1 + 0.03 * 0.03;        // with the floors
  const double b_var = 0.05 * 0.05 + 0.005 * 0.005;
  EXPECT_NEAR(l0.covariance(0, 0), r_var, 1e-12);
  EXPECT_NEAR(l0.covariance(1, 1), 4.0 * b_var, 1e-12);
  // A second observation at range 2.1: the range is a scalar Kalman update, K = P / (P + R) = 1/2.
  LandmarkObservation o = observe(Pose2(), 2.1, 0.0, 0.1, 0.05);
  f.update({ o }, Pose2());
  const Landmark& l1 = f.best().map[0];
  EXPECT_NEAR(l1.mean.x(), 2.05, 1e-9);
  EXPECT_NEAR(l1.mean.y(), 0.0, 1e-9);
  EXPECT_NEAR(l1.covariance(0, 0), r_var / 2.0, 1e-12);
  EXPECT_EQ(l1.observations, 2);
}

TEST(FastSlam, StableMatchingKeepsTwoNearbyTreesApartWhereGreedyFuses)
{
  // Two landmarks 0.4 m apart; observation A lies between them but nearer L1, B next to L1 too, but B is
  // the best for L1 and A is then still acceptable for L0. Greedy (A first, its best) would take L1 for A
  // and leave B to start a duplicate of L1.
  std::vector<std::vector<double>> ll{ { -2.0, -1.0 },   // A: prefers L1
                                       { -9.0, -0.5 } };  // B: only fits L1, and fits it better than A
  const std::vector<int> m = FastSlam::stableMatching(ll);
  EXPECT_EQ(m[0], 0);
  EXPECT_EQ(m[1], 1);
  // A greedy pass in observation order would give A -> L1 and B -> nothing.
  // Rows with nothing allowed stay unmatched.
  const double ninf = -std::numeric_limits<double>::infinity();
  const std::vector<int> m2 = FastSlam::stableMatching({ { ninf, ninf }, { -1.0, ninf } });
  EXPECT_EQ(m2[0], -1);
  EXPECT_EQ(m2[1], 0);
}

TEST(FastSlam, TwoObservationsNeverClaimOneLandmarkInTheFilter)
{
  FastSlamConfig c = quietConfig();
  FastSlam f(c);
  f.update({ observe(Pose2(), 5.0, 0.0), observe(Pose2(), 5.0, 0.6) }, Pose2());
  ASSERT_EQ(f.best().map.size(), 2u);
  // Both seen again, slightly moved towards each other: both landmarks are updated, none is created.
  const FastSlamUpdateStats st = f.update({ observe(Pose2(), 5.0, 0.05), observe(Pose2(), 5.0, 0.55) }, Pose2());
  EXPECT_EQ(st.matched, 2);
  EXPECT_EQ(st.created, 0);
  EXPECT_EQ(f.best().map.size(), 2u);
}

TEST(FastSlam, LandmarkThatDisappearsIsDeletedOneBehindAnotherIsNot)
{
  FastSlamConfig c = quietConfig();
  FastSlam f(c);
  // A at 4 m; B at 8 m straight behind A (hidden); C at 6 m to the side.
  f.update({ observe(Pose2(), 4.0, 0.0), observe(Pose2(), 6.0, 3.0) }, Pose2());
  f.update({ observe(Pose2(), 4.0, 0.0), observe(Pose2(), 6.0, 3.0) }, Pose2());
  // Now B appears from another pose where it is visible.
  ASSERT_EQ(f.best().map.size(), 2u);
  // C vanishes (the clutter that was no tree): repeated misses remove it; A stays.
  for (int i = 0; i < 6; ++i)
    f.update({ observe(Pose2(), 4.0, 0.0) }, Pose2());
  ASSERT_EQ(f.best().map.size(), 1u);
  EXPECT_NEAR(f.best().map[0].mean.x(), 4.0, 1e-6);
  // A landmark hidden behind A is not missed.
  FastSlam g(c);
  g.update({ observe(Pose2(), 4.0, 0.0), observe(Pose2(), 8.0, 0.0, 0.02, 0.003) }, Pose2(0, 0, 0));
  for (int i = 0; i < 6; ++i)
    g.update({ observe(Pose2(), 4.0, 0.0) }, Pose2());
  EXPECT_EQ(g.best().map.size(), 2u);
}

TEST(FastSlam, NoDuplicateAcrossPlusMinusPi)
{
  FastSlam f(quietConfig());
  const Pose2 s(0, 0, 0);
  f.update({ observe(s, -5.0, 0.001) }, Pose2());   // bearing just below +pi
  f.update({ observe(s, -5.0, -0.001) }, Pose2());  // just above -pi
  EXPECT_EQ(f.best().map.size(), 1u);
}

TEST(FastSlam, SameSeedSameResultOtherSeedOther)
{
  FastSlamConfig c;
  c.particles = 30;
  const auto run = [&](std::uint64_t seed) {
    c.seed = seed;
    FastSlam f(c);
    Pose2 odom_prev;
    for (int k = 1; k <= 20; ++k)
    {
      const Pose2 odom(0.1 * k, 0.0, 0.0);
      f.predict(decomposeOdometry(odom_prev, odom));
      odom_prev = odom;
      f.update({ observe(odom, 5.0, 2.0), observe(odom, 6.0, -3.0) }, Pose2());
    }
    return f.best().pose;
  };
  const Pose2 a = run(3), b = run(3), d = run(4);
  EXPECT_EQ(a.x, b.x);
  EXPECT_EQ(a.theta, b.theta);
  EXPECT_NE(a.x, d.x);
}

TEST(FastSlam, ResamplingSharesMapsInsteadOfCopyingThem)
{
  LandmarkMap a;
  for (int i = 0; i < 40; ++i)
  {
    Landmark l;
    l.id = i;
    a.add(l);
  }
  LandmarkMap b = a;
  EXPECT_EQ(b.sharedChunks(), 3u);
  b.modify(5, [](Landmark& l) { l.radius = 1.0; });  // copies one chunk only
  EXPECT_EQ(b.sharedChunks(), 2u);
  EXPECT_EQ(a[5].radius, 0.0);
  b.remove(0);  // the last moves into slot 0
  EXPECT_EQ(b.size(), 39u);
  EXPECT_EQ(b[0].id, 39);
  EXPECT_EQ(a[0].id, 0);
}

TEST(Evaluation, OptimalAssignmentBeatsGreedy)
{
  // Greedy would take (0,0) = 1 and then (1,1) = 10; the optimum is (0,1) + (1,0) = 2 + 2.
  const std::vector<int> a = optimalAssignment({ { 1.0, 2.0 }, { 2.0, 10.0 } }, 1e6);
  EXPECT_EQ(a[0], 1);
  EXPECT_EQ(a[1], 0);
  const std::vector<int> b = optimalAssignment({ { 1e6, 0.3 } }, 1e6);
  EXPECT_EQ(b[0], 1);
}

TEST(Evaluation, MapScoreCountsRecallDuplicatesAndSpurious)
{
  std::vector<MapPoint> trees{ { Eigen::Vector2d(0, 0), 0.2 }, { Eigen::Vector2d(5, 0), 0.2 },
                               { Eigen::Vector2d(10, 0), 0.2 } };
  std::vector<bool> seen{ true, true, false };
  std::vector<MapPoint> features{ { Eigen::Vector2d(0.1, 0), 0.21 }, { Eigen::Vector2d(0.7, 0), 0.2 },
                                  { Eigen::Vector2d(5.0, 0.2), 0.19 }, { Eigen::Vector2d(20, 0), 0.2 } };
  const MapScore s = scoreMap(trees, seen, features);
  EXPECT_EQ(s.matched, 2);
  EXPECT_EQ(s.trees_seen, 2);
  EXPECT_NEAR(s.recall, 1.0, 1e-12);
  EXPECT_EQ(s.duplicates, 1);
  EXPECT_EQ(s.spurious, 1);
  EXPECT_NEAR(s.mean_distance, 0.15, 1e-12);
  EXPECT_NEAR(s.radius_rms, 0.01, 1e-12);
}

TEST(FastSlam2, ProposalMeanAndCovarianceMatchAHandComputedCase)
{
  // Robot at the origin, landmark 2 m ahead: Hm = [1 0; 0 1/2], Hx = [-1 0 0; 0 -1/2 -1].
  // Q = R + Hm Sm Hm^T = diag(0.02, 0.005) + diag(0.02, 0.005) = diag(0.04, 0.01); prior diag(0.04, 0.04, 0.01).
  // Information: x: 1/0.04 + 1/0.04 = 50 -> 0.02; (y, theta): [25 + 25, 50; 50, 100 + 100] = [50 50; 50 200],
  // inverse [200 -50; -50 50] / 7500. Innovation (0.1, 0.05): Q^-1 v = (2.5, 5), Hx^T Q^-1 v = (-2.5, -2.5, -5),
  // mean = (0.02 * -2.5, (200 * -2.5 + 50 * 5) / 7500, (125 - 250) / 7500) = (-0.05, -1/30, -1/60).
  Landmark l;
  l.mean = Eigen::Vector2d(2.0, 0.0);
  l.covariance = 0.02 * Eigen::Matrix2d::Identity();
  Eigen::Matrix2d R = Eigen::Vector2d(0.02, 0.005).asDiagonal();
  Pose2 mean;
  Eigen::Matrix3d cov = Eigen::Vector3d(0.04, 0.04, 0.01).asDiagonal();
  conditionPoseOnLandmark(&mean, &cov, l, Eigen::Vector2d(2.1, 0.05), R, Pose2());
  EXPECT_NEAR(mean.x, -0.05, 1e-12);
  EXPECT_NEAR(mean.y, -1.0 / 30.0, 1e-12);
  EXPECT_NEAR(mean.theta, -1.0 / 60.0, 1e-12);
  Eigen::Matrix3d expected;
  expected << 0.02, 0, 0, 0, 200.0 / 7500, -50.0 / 7500, 0, -50.0 / 7500, 50.0 / 7500;
  EXPECT_LT((cov - expected).cwiseAbs().maxCoeff(), 1e-12) << cov;

  // A zero prior covariance stays zero and the mean stays (the motion was certain).
  Pose2 still;
  Eigen::Matrix3d zero = Eigen::Matrix3d::Zero();
  conditionPoseOnLandmark(&still, &zero, l, Eigen::Vector2d(2.1, 0.05), R, Pose2());
  EXPECT_EQ(still.x, 0.0);
  EXPECT_EQ(zero.cwiseAbs().maxCoeff(), 0.0);
}

TEST(FastSlam2, ProposalWithALeverArmAgreesWithNumericalDerivatives)
{
  // With the sensor 0.5 m ahead and 0.2 m left of base_link, one observation of small innovation must move
  // the mean by Sigma Hx^T (Hx Sigma Hx^T + Q)^-1 v; check Hx by finite differences through the same call.
  Landmark l;
  l.mean = Eigen::Vector2d(4.0, 3.0);
  l.covariance = 1e-4 * Eigen::Matrix2d::Identity();
  const Eigen::Matrix2d R = Eigen::Vector2d(1e-4, 1e-5).asDiagonal();
  const Pose2 sensor(0.5, 0.2, 0.3), prior(1.0, -0.5, 0.4);
  const Eigen::Matrix3d P = Eigen::Vector3d(0.01, 0.02, 0.003).asDiagonal();
  const auto predict = [&](const Pose2& base) {
    const Pose2 s = base * sensor;
    const double dx = l.mean.x() - s.x, dy = l.mean.y() - s.y;
    return Eigen::Vector2d(std::hypot(dx, dy), wrapAngle(std::atan2(dy, dx) - s.theta));
  };
  Eigen::Matrix<double, 2, 3> Hx;
  const double h = 1e-6;
  for (int j = 0; j < 3; ++j)
  {
    Pose2 a = prior, b = prior;
    (j == 0 ? a.x : j == 1 ? a.y : a.theta) += h;
    (j == 0 ? b.x : j == 1 ? b.y : b.theta) -= h;
    Hx.col(j) = (predict(a) - predict(b)) / (2 * h);
  }
  const Eigen::Vector2d v(0.01, -0.002);
  const Eigen::Vector2d z = predict(prior) + v;
  Eigen::Matrix2d Hm;  // wrt the landmark: minus the position part of Hx rotated... take it numerically too
  for (int j = 0; j < 2; ++j)
  {
    Landmark a = l, b = l;
    a.mean[j] += h;
    b.mean[j] -= h;
    const Pose2 s = prior * sensor;
    const auto rb = [&](const Landmark& m) {
      const double dx = m.mean.x() - s.x, dy = m.mean.y() - s.y;
      return Eigen::Vector2d(std::hypot(dx, dy), std::atan2(dy, dx) - s.theta);
    };
    Hm.col(j) = (rb(a) - rb(b)) / (2 * h);
  }
  const Eigen::Matrix2d Q = R + Hm * l.covariance * Hm.transpose();
  const Eigen::Matrix<double, 3, 2> K = P * Hx.transpose() * (Hx * P * Hx.transpose() + Q).inverse();
  const Eigen::Vector3d expected = K * v;
  Pose2 mean = prior;
  Eigen::Matrix3d cov = P;
  conditionPoseOnLandmark(&mean, &cov, l, z, R, sensor);
  EXPECT_NEAR(mean.x - prior.x, expected.x(), 1e-6);
  EXPECT_NEAR(mean.y - prior.y, expected.y(), 1e-6);
  EXPECT_NEAR(mean.theta - prior.theta, expected.z(), 1e-6);
  const Eigen::Matrix3d expected_cov = (Eigen::Matrix3d::Identity() - K * Hx) * P;
  EXPECT_LT((cov - expected_cov).cwiseAbs().maxCoeff(), 1e-8);
}

TEST(FastSlam2, MotionGaussianMatchesTheSampledMotionModel)
{
  // The linearised propagation and the sampled rot1-trans-rot2 model agree on mean and covariance.
  OdometryMotionNoise n;
  n.alpha1 = 0.1;
  n.alpha2 = 0.05;
  n.alpha3 = 0.05;
  n.alpha4 = 0.02;
  const Pose2 start(1.0, 2.0, 0.3);
  const OdometryIncrement u = decomposeOdometry(Pose2(), Pose2(0.3, 0.05, 0.1));
  Pose2 mean = start;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  propagatePoseGaussian(&mean, &cov, u, n);
  Random random(5);
  const int samples = 200000;
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
  for (int k = 0; k < samples; ++k)
  {
    const Pose2 s = sampleOdometryMotion(start, u, n, random);
    const Eigen::Vector3d d(s.x - mean.x, s.y - mean.y, wrapAngle(s.theta - mean.theta));
    m += d / samples;
    c += d * d.transpose() / samples;
  }
  EXPECT_LT(m.cwiseAbs().maxCoeff(), 1e-3) << m.transpose();
  EXPECT_LT((c - cov).cwiseAbs().maxCoeff(), 0.05 * cov.cwiseAbs().maxCoeff()) << c << "\n" << cov;
}

namespace
{
/** @brief Mean and covariance (x, y, theta about @p mean) of particle poses. */
Eigen::Matrix3d poseCovariance(const std::vector<Pose2>& poses, const Pose2& mean, Eigen::Vector3d* offset)
{
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
  const double n = static_cast<double>(poses.size());
  for (const Pose2& s : poses)
  {
    const Eigen::Vector3d d(s.x - mean.x, s.y - mean.y, wrapAngle(s.theta - mean.theta));
    m += d / n;
    c += d * d.transpose() / n;
  }
  *offset = m;
  return c - m * m.transpose();
}
}  // namespace

TEST(MotionModel, PartialStepsAddUpToTheNoiseOfAFullStep)
{
  // A full step of motion_step taken at once, or in four parts each scaled by partialStepNoiseScale(1/4): the
  // spread is the same (a random walk), not half of it (four independent steps of a quarter).
  OdometryMotionNoise n;
  n.alpha1 = 0.1;
  n.alpha2 = 0.05;
  n.alpha3 = 0.05;
  n.alpha4 = 0.02;
  const OdometryIncrement full = decomposeOdometry(Pose2(), Pose2(0.2, 0.0, 0.0));
  const OdometryIncrement part = decomposeOdometry(Pose2(), Pose2(0.05, 0.0, 0.0));
  EXPECT_DOUBLE_EQ(partialStepNoiseScale(0.25), 2.0);
  EXPECT_DOUBLE_EQ(partialStepNoiseScale(1.0), 1.0);
  EXPECT_DOUBLE_EQ(partialStepNoiseScale(0.0), 1.0);
  OdometryMotionNoise scaled = n;
  scaled.alpha1 *= 2.0;
  scaled.alpha2 *= 2.0;
  scaled.alpha3 *= 2.0;
  scaled.alpha4 *= 2.0;
  Random random(3);
  std::vector<Pose2> once, parts, unscaled;
  for (int k = 0; k < 40000; ++k)
  {
    once.push_back(sampleOdometryMotion(Pose2(), full, n, random));
    Pose2 a, b;
    for (int j = 0; j < 4; ++j)
    {
      a = sampleOdometryMotion(a, part, scaled, random);
      b = sampleOdometryMotion(b, part, n, random);
    }
    parts.push_back(a);
    unscaled.push_back(b);
  }
  Eigen::Vector3d m;
  const Eigen::Matrix3d c_once = poseCovariance(once, Pose2(0.2, 0, 0), &m);
  const Eigen::Matrix3d c_parts = poseCovariance(parts, Pose2(0.2, 0, 0), &m);
  const Eigen::Matrix3d c_unscaled = poseCovariance(unscaled, Pose2(0.2, 0, 0), &m);
  EXPECT_NEAR(c_parts(0, 0), c_once(0, 0), 0.05 * c_once(0, 0));
  EXPECT_NEAR(c_parts(2, 2), c_once(2, 2), 0.05 * c_once(2, 2));
  EXPECT_LT(c_unscaled(0, 0), 0.3 * c_once(0, 0));  // what unscaled parts would claim
}

TEST(MotionModel, ArcStepsRecoverTheArcAndItsDirection)
{
  for (const double d : { 0.5, -0.5 })
    for (const double t : { 0.0, 0.3, -1.2 })
    {
      const Pose2 a(1.0, -2.0, 0.7);
      const Pose2 b = a * arcIncrement(d, t);
      const ArcStep s = arcStep(a, b);
      EXPECT_NEAR(s.distance, d, 1e-9) << d << " " << t;
      EXPECT_NEAR(s.turn, t, 1e-12);
    }
  const ArcStep spin = arcStep(Pose2(), Pose2(0, 0, 0.4));
  EXPECT_EQ(spin.distance, 0.0);
  EXPECT_NEAR(spin.turn, 0.4, 1e-12);
}

TEST(MotionModel, VelocityBlockKeepsTheOdometryAsItsMeanAndHoldsItsErrorOverTheBlock)
{
  OdometryMotionNoise n;
  n.alpha1 = 0.1;
  n.alpha2 = 0.04;
  n.alpha3 = 0.05;
  n.alpha4 = 0.02;
  // Ten arcs of 0.1 m (one second at 0.1 m/s), the last one not quite an arc (a sideways centimetre).
  std::vector<ArcStep> block;
  Pose2 o;
  for (int k = 0; k < 10; ++k)
  {
    const Pose2 next = o * (k == 9 ? Pose2(0.1, 0.01, 0.0) : arcIncrement(0.1, 0.0));
    block.push_back(arcStep(o, next));
    o = next;
  }
  const Pose2 mean = applyVelocityBlock(Pose2(), block, n, 1.0, 0.0, 0.0);
  EXPECT_NEAR(mean.x, o.x, 1e-12);
  EXPECT_NEAR(mean.y, o.y, 1e-12);
  // The distance error is one draw for the whole block: alpha3 * 1 m (not alpha3 * 0.1 m * sqrt(10)); the heading
  // error alpha2 * 1 m.
  Random random(4);
  std::vector<Pose2> poses;
  for (int k = 0; k < 40000; ++k)
    poses.push_back(sampleVelocityBlock(Pose2(), block, n, 1.0, random));
  Eigen::Vector3d m;
  const Eigen::Matrix3d c = poseCovariance(poses, mean, &m);
  double distance = 0.0;
  for (const ArcStep& a : block)
    distance += a.distance;
  EXPECT_NEAR(distance, 1.0, 1e-3);
  EXPECT_NEAR(std::sqrt(c(0, 0)), n.alpha3 * distance, 0.03 * n.alpha3 * distance);
  EXPECT_NEAR(std::sqrt(c(2, 2)), n.alpha2 * distance, 0.03 * n.alpha2 * distance);
  EXPECT_LT(m.cwiseAbs().maxCoeff(), 2e-3);
}

TEST(MotionModel, VelocityBlockGaussianMatchesTheSamples)
{
  // FastSLAM 2.0 carries the block's pose as a Gaussian (linearised); it agrees with the sampled velocity model.
  FastSlamConfig c;
  c.particles = 1;
  c.proposal = PoseProposal::kFastSlam2;
  c.motion_model = MotionModel::kVelocity;
  c.motion.alpha1 = 0.1;
  c.motion.alpha2 = 0.05;
  c.motion.alpha3 = 0.05;
  c.motion.alpha4 = 0.02;
  std::vector<ArcStep> block;
  Pose2 o;
  for (int k = 0; k < 8; ++k)
  {
    const Pose2 next = o * arcIncrement(0.12, 0.08);
    block.push_back(arcStep(o, next));
    o = next;
  }
  FastSlam filter(c);
  const Pose2 start(1.0, 2.0, 0.3);
  filter.initialize(start);
  filter.predictArcs(block);
  const Particle& p = filter.particles().front();
  Random random(6);
  std::vector<Pose2> poses;
  for (int k = 0; k < 100000; ++k)
    poses.push_back(sampleVelocityBlock(start, block, c.motion, 1.0, random));
  Eigen::Vector3d m;
  const Eigen::Matrix3d cov = poseCovariance(poses, p.pose, &m);
  EXPECT_LT(m.cwiseAbs().maxCoeff(), 2e-3) << m.transpose();
  EXPECT_LT((cov - p.motion_covariance).cwiseAbs().maxCoeff(), 0.05 * cov.cwiseAbs().maxCoeff())
      << cov << "\n" << p.motion_covariance;
}

TEST(FastSlam, ProvisionalLandmarksWeighNoParticleWhenSoConfigured)
{
  // Twenty particles spread by motion noise see two trunks again that are still provisional (5 sightings to
  // confirm): with provisional_weighs they are weighed apart, without it every observation weighs as a new
  // landmark's and the weights stay equal (Neff = N).
  for (const bool weighs : { true, false })
  {
    FastSlamConfig c = quietConfig(20);
    c.motion.alpha2 = 0.02;
    c.motion.alpha3 = 0.05;
    c.confirm_observations = 5;
    c.provisional_weighs = weighs;
    FastSlam f(c);
    f.initialize(Pose2());
    f.update({ observe(Pose2(), 5.0, 1.0), observe(Pose2(), 6.0, -2.0) }, Pose2());
    f.predict(decomposeOdometry(Pose2(), Pose2(0.5, 0.0, 0.0)));
    const Pose2 truth(0.5, 0.0, 0.0);
    const FastSlamUpdateStats st = f.update({ observe(truth, 5.0, 1.0), observe(truth, 6.0, -2.0) }, Pose2());
    EXPECT_EQ(st.matched, 2) << weighs;
    EXPECT_EQ(st.matched_confirmed, 0) << weighs;
    if (weighs)
      EXPECT_LT(st.neff, 19.0);
    else
      EXPECT_NEAR(st.neff, 20.0, 1e-9);
  }
}

TEST(FastSlam2, ProposalsFollowTheTruthInASurveyedMapWhereOdometryDrifts)
{
  // A surveyed map of four trunks (1 mm); odometry reads 5 % short and turns 0.01 rad too far per step (twice the
  // filter's noise class). FastSLAM 1.0 with one particle can only follow odometry; FastSLAM 2.0 draws its pose
  // from the observations; so does the mixture's dual proposal for some of FastSLAM 1.0's particles.
  LandmarkMap map;
  const std::vector<Eigen::Vector2d> trees{ { 3, 4 }, { 6, -4 }, { 9, 4 }, { 12, -4 } };
  for (std::size_t i = 0; i < trees.size(); ++i)
  {
    Landmark l;
    l.mean = trees[i];
    l.covariance = 1e-6 * Eigen::Matrix2d::Identity();
    l.radius = 0.2;
    l.radius_variance = 1e-4;
    l.evidence = 5;
    l.observations = 10;
    l.provisional = false;
    l.id = static_cast<int>(i);
    map.add(l);
  }
  const auto run = [&](PoseProposal proposal, double mixture = 0.0, int particles = 1) {
    FastSlamConfig c;
    c.particles = particles;
    c.proposal = proposal;
    c.mixture_fraction = mixture;
    c.motion.alpha1 = c.motion.alpha2 = c.motion.alpha3 = 0.05;
    c.motion.alpha4 = 0.01;
    FastSlam f(c);
    f.initialize(Pose2(), map);
    Pose2 truth, odometry;
    for (int k = 0; k < 100; ++k)
    {
      const Pose2 next_odometry = odometry * Pose2(0.095, 0.0, 0.01);
      f.predict(decomposeOdometry(odometry, next_odometry));
      odometry = next_odometry;
      truth = truth * Pose2(0.1, 0.0, 0.0);
      std::vector<LandmarkObservation> obs;
      for (const auto& t : trees)
        if ((t - Eigen::Vector2d(truth.x, truth.y)).norm() < 12.0)
          obs.push_back(observe(truth, t.x(), t.y(), 0.01, 0.002));
      f.update(obs, Pose2());
    }
    const Pose2 est = f.best().pose;
    return std::hypot(est.x - truth.x, est.y - truth.y);
  };
  const double e1 = run(PoseProposal::kFastSlam1), e2 = run(PoseProposal::kFastSlam2);
  EXPECT_GT(e1, 0.5);   // about the odometry's drift
  EXPECT_LT(e2, 0.1);
  // Mixture MCL: FastSLAM 1.0 whose particles are sometimes drawn from the observations of the map.
  const double e1_mixture = run(PoseProposal::kFastSlam1, 0.2, 10), e1_many = run(PoseProposal::kFastSlam1, 0.0, 10);
  EXPECT_GT(e1_many, 0.3);
  EXPECT_LT(e1_mixture, 0.1) << "without the mixture " << e1_many;
}

TEST(FastSlam, ProvisionalLandmarkLeavingTheScopeUnconfirmedIsDropped)
{
  // Two landmarks just beyond the 12 m scope (inside the half-metre candidate ring): one provisional (seen
  // once), one confirmed. The provisional one leaves the scope unconfirmed and is dropped; the confirmed one
  // stays; with the rule off both stay.
  LandmarkMap map;
  for (int i = 0; i < 2; ++i)
  {
    Landmark l;
    l.mean = Eigen::Vector2d(i == 0 ? 12.2 : -12.2, 0.0);
    l.covariance = Eigen::Matrix2d::Identity() * 1e-3;
    l.radius = 0.2;
    l.evidence = 1.0;
    l.observations = i == 0 ? 1 : 10;
    l.provisional = i == 0;
    l.id = i;
    map.add(l);
  }
  for (bool rule : { true, false })
  {
    FastSlamConfig c;
    c.particles = 1;
    c.drop_unconfirmed_leaving_scope = rule;
    FastSlam f(c);
    f.initialize(Pose2(), map);
    f.update({}, Pose2());
    const LandmarkMap& m = f.best().map;
    ASSERT_EQ(m.size(), rule ? 1u : 2u);
    std::map<int, bool> provisional_by_id;
    for (std::size_t k = 0; k < m.size(); ++k)
      provisional_by_id[m[k].id] = m[k].provisional;
    if (rule)
    {
      EXPECT_EQ(provisional_by_id, (std::map<int, bool>{ { 1, false } }));
    }
    else
    {
      EXPECT_EQ(provisional_by_id, (std::map<int, bool>{ { 0, true }, { 1, false } }));
    }
  }
}

TEST(SweepObservations, EachTrunkIsCarriedFromItsOwnBeamTime)
{
  // The robot drives +x at 1 m/s. A trunk 5 m to the left (bearing +pi/2) is the last beam of a 2D scan that
  // covers -pi/2 .. +pi/2 in 0.1 s, so it was seen 0.1 s after the stamp: taken back to the stamp it sits
  // 0.1 m further ahead. Under the spinning-lidar default (starting behind, 2 pi per period) the same bearing
  // is three quarters through the sweep: 0.075 m.
  OdometryBuffer odometry;
  for (int k = 0; k <= 20; ++k)
    odometry.add(0.01 * k, Pose2(0.01 * k, 0.0, 0.0));
  TrunkObservation t;
  t.center = Eigen::Vector2d(0.0, 5.0);
  t.range = 5.0;
  t.bearing = M_PI / 2;
  t.covariance = Eigen::Matrix2d::Identity() * 1e-4;
  t.radius = 0.2;
  const auto along = [&](const SweepGeometry& g) {
    const auto obs = sweepObservations({ t }, 0.0, 0.1, 0.0, 0.0, SensorMount(), odometry, 0.0, g);
    return obs.at(0).range * std::cos(obs.at(0).bearing);
  };
  SweepGeometry scan;
  scan.start_angle = -M_PI / 2;
  scan.span = M_PI;
  EXPECT_NEAR(along(scan), 0.1, 1e-9);
  EXPECT_NEAR(along(SweepGeometry()), 0.075, 1e-9);
}

TEST(FastSlamConsistency, TheTruthIsInsideTheRegionWhenTheSpreadCoversTheError)
{
  const Eigen::Matrix2d cov = Eigen::Vector2d(0.04, 0.01).asDiagonal();  // 0.2 m along x, 0.1 m along y
  EXPECT_TRUE(insideRegion95(Eigen::Vector2d(0.4, 0.0), Eigen::Vector2d::Zero(), cov));   // 2 sigma
  EXPECT_FALSE(insideRegion95(Eigen::Vector2d(0.0, 0.3), Eigen::Vector2d::Zero(), cov));  // 3 sigma
  EXPECT_FALSE(insideRegion95(Eigen::Vector2d(0.01, 0.0), Eigen::Vector2d::Zero(), Eigen::Matrix2d::Zero()));
  EXPECT_TRUE(insideRegion95(Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), Eigen::Matrix2d::Zero()));
}

TEST(FastSlam, ParticlesStartedOverSeveralPosesWeighAsTheirStartsSay)
{
  FastSlamConfig c = quietConfig(60);
  FastSlam f(c);
  LandmarkMap map;
  const std::vector<Pose2> starts = { Pose2(1.0, 2.0, 0.3), Pose2(-5.0, 4.0, 2.9), Pose2(9.0, -1.0, -1.0) };
  // The second start explains the trunks seen 3 times as likely as the first, the third not at all.
  const std::vector<double> log_weights = { -40.0, -40.0 + std::log(3.0),
                                        -std::numeric_limits<double>::infinity() };
  for (const bool weighed : { false, true })
  {
    SCOPED_TRACE(weighed ? "weighed" : "unweighed");
    if (weighed)
      f.initialize({ starts[0], starts[1] }, map, 0.1, 0.02, { log_weights[0], log_weights[1] });
    else
      f.initialize(starts, map, 0.1, 0.02);
    const std::size_t n = weighed ? 2 : 3;
    std::vector<double> mass(n, 0.0);
    double total = 0.0;
    for (const Particle& p : f.particles())
    {
      std::size_t nearest = 0;
      for (std::size_t k = 1; k < n; ++k)
        if (std::hypot(p.pose.x - starts[k].x, p.pose.y - starts[k].y) <
            std::hypot(p.pose.x - starts[nearest].x, p.pose.y - starts[nearest].y))
          nearest = k;
      mass[nearest] += std::exp(p.log_weight);
      total += std::exp(p.log_weight);
    }
    EXPECT_NEAR(total, 1.0, 1e-9);
    if (weighed)
    {
      EXPECT_NEAR(mass[1], 0.75, 1e-9);
      EXPECT_NEAR(mass[0], 0.25, 1e-9);
      EXPECT_LT(std::hypot(f.best().pose.x - starts[1].x, f.best().pose.y - starts[1].y), 1.0)
          << "the best particle is one of the heavier start's";
    }
    else
      for (std::size_t k = 0; k < n; ++k)
        EXPECT_NEAR(mass[k], 1.0 / 3.0, 1e-9);
  }
  // Weights that do not fit the starts (a count that differs, or not finite) are not taken: equal weights.
  f.initialize(starts, map, 0.1, 0.02, log_weights);
  for (const Particle& p : f.particles())
    EXPECT_NEAR(std::exp(p.log_weight), 1.0 / 60.0, 1e-12);
  f.initialize(starts, map, 0.1, 0.02, { 0.0, 1.0 });
  for (const Particle& p : f.particles())
    EXPECT_NEAR(std::exp(p.log_weight), 1.0 / 60.0, 1e-12);
}
