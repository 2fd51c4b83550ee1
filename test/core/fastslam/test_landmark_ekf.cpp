// The EKF update of one landmark, its radius fusion and a new landmark's initialisation, against hand-computed
// cases.
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Dense>

#include "rbpf_slam/core/fastslam/landmark_ekf.h"

using namespace rbpf_slam::core;

TEST(LandmarkEkf, UpdateMatchesAHandComputedCase)
{
  // Landmark at (2, 0) seen from the origin: H = diag(1, 1/2). P = diag(0.01, 0.04), R = diag(0.01, 0.0025):
  // S = diag(0.02, 0.0125), K = P H^T S^-1 = diag(0.5, 1.6), (I - K H) P = diag(0.005, 0.008).
  Landmark l;
  l.mean = Eigen::Vector2d(2.0, 0.0);
  l.covariance << 0.01, 0, 0, 0.04;
  Eigen::Matrix2d H;
  const Eigen::Vector2d z = predictRangeBearing(l.mean, Pose2(), &H);
  EXPECT_NEAR(z.x(), 2.0, 1e-15);
  EXPECT_NEAR(H(0, 0), 1.0, 1e-15);
  EXPECT_NEAR(H(1, 1), 0.5, 1e-15);
  Eigen::Matrix2d R;
  R << 0.01, 0, 0, 0.0025;
  const Eigen::Matrix2d S = H * l.covariance * H.transpose() + R;
  const Eigen::Vector2d v(0.1, 0.01);  // observed 0.1 m further, 0.01 rad to the left
  updateLandmarkPosition(&l, H, S.inverse(), v, R);
  EXPECT_NEAR(l.mean.x(), 2.0 + 0.5 * 0.1, 1e-12);
  EXPECT_NEAR(l.mean.y(), 1.6 * 0.01, 1e-12);
  EXPECT_NEAR(l.covariance(0, 0), 0.005, 1e-12);
  EXPECT_NEAR(l.covariance(1, 1), 0.008, 1e-12);
  EXPECT_NEAR(l.covariance(0, 1), 0.0, 1e-15);
  EXPECT_EQ(l.covariance(0, 1), l.covariance(1, 0));  // Joseph form: symmetric
}

TEST(LandmarkEkf, NewLandmarkCarriesTheObservationNoiseThroughTheJacobian)
{
  // Sensor at (1, 2) facing +y sees a trunk 3 m straight ahead: landmark at (1, 5). G = [0 -3; 1 0], so the
  // range noise lies along y and the bearing noise, times the range squared, along x.
  LandmarkObservation o;
  o.range = 3.0;
  o.bearing = 0.0;
  o.radius = 0.15;
  o.radius_variance = -1.0;  // nonsense from upstream is taken as unknown
  Eigen::Matrix2d R;
  R << 0.04, 0, 0, 0.0001;
  const Landmark l = landmarkFromObservation(o, Pose2(1.0, 2.0, M_PI / 2), R);
  EXPECT_NEAR(l.mean.x(), 1.0, 1e-12);
  EXPECT_NEAR(l.mean.y(), 5.0, 1e-12);
  EXPECT_NEAR(l.covariance(0, 0), 9.0 * 0.0001, 1e-12);
  EXPECT_NEAR(l.covariance(1, 1), 0.04, 1e-12);
  EXPECT_NEAR(l.covariance(0, 1), 0.0, 1e-12);
  EXPECT_EQ(l.radius, 0.15);
  EXPECT_EQ(l.radius_variance, 0.0);
}

TEST(LandmarkEkf, RadiusFusionIsInverseVarianceWeighted)
{
  Landmark l;
  l.radius = 0.20;
  l.radius_variance = 1e-4;
  l.observations = 1;
  LandmarkObservation o;
  o.radius = 0.30;
  o.radius_variance = 3e-4;  // a third of the landmark's weight: the fused radius moves a quarter of the way
  fuseLandmarkRadius(&l, o);
  EXPECT_NEAR(l.radius, 0.225, 1e-12);
  EXPECT_NEAR(l.radius_variance, 0.75e-4, 1e-15);
  // Without a variance the observation's radius is not used.
  o.radius_variance = 0.0;
  fuseLandmarkRadius(&l, o);
  EXPECT_NEAR(l.radius, 0.225, 1e-12);
  // A landmark whose radius is not known yet takes the first one given.
  Landmark unknown;
  unknown.radius_variance = 0.0;
  unknown.observations = 2;
  o.radius_variance = 3e-4;
  fuseLandmarkRadius(&unknown, o);
  EXPECT_EQ(unknown.radius, 0.30);
  EXPECT_EQ(unknown.radius_variance, 3e-4);
}
