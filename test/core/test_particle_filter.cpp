#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/particle_filter.h"

using namespace rbpf_slam::core;

TEST(PoseMoments, HeadingsAcrossPiAverageOnTheCircle)
{
  // Two particles just either side of +-pi: the mean heading is pi (not 0), the spread small.
  const std::vector<Pose2> poses{ Pose2(1.0, 2.0, M_PI - 0.1), Pose2(3.0, 2.0, -M_PI + 0.1) };
  const PoseMoments m = poseMoments(poses, { 1.0, 1.0 });
  EXPECT_NEAR(std::abs(m.mean.theta), M_PI, 1e-9);
  EXPECT_NEAR(m.mean.x, 2.0, 1e-12);
  EXPECT_NEAR(m.mean.y, 2.0, 1e-12);
  EXPECT_NEAR(m.covariance(0, 0), 1.0, 1e-12);     // x: +-1 about the mean
  EXPECT_NEAR(m.covariance(1, 1), 0.0, 1e-12);
  EXPECT_NEAR(m.covariance(2, 2), 0.01, 1e-9);     // heading: +-0.1, wrapped
}

TEST(PoseMoments, WeightsNeedNotBeNormalisedAndZeroTotalMeansUniform)
{
  const std::vector<Pose2> poses{ Pose2(0.0, 0.0, 0.0), Pose2(4.0, 0.0, 0.0) };
  EXPECT_NEAR(poseMoments(poses, { 3.0, 1.0 }).mean.x, 1.0, 1e-12);  // weights 0.75 / 0.25
  EXPECT_NEAR(poseMoments(poses, { 0.0, 0.0 }).mean.x, 2.0, 1e-12);  // no weight: uniform
  EXPECT_NEAR(poseMoments(poses, { 0.0, 0.0 }).covariance(0, 0), 4.0, 1e-12);
}
