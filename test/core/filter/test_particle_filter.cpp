#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/filter/particle_filter.h"

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

TEST(WeighAndResample, KeepsAllWhileNeffIsHighAndResamplesBelowTheRatio)
{
  Random random(3);
  ResamplingPolicy policy;
  policy.neff_ratio = 0.5;
  // Nearly uniform: Neff close to N, nothing resampled, weights normalised, best is the largest.
  std::vector<double> log_w = { 0.0, 0.1, 0.0, -0.1 }, w;
  WeightingStep step = weighAndResample(&log_w, &w, policy, random);
  EXPECT_FALSE(step.resampled);
  EXPECT_TRUE(step.keep.empty());
  EXPECT_GT(step.neff, 3.9);
  EXPECT_EQ(step.best, 1u);
  double sum = 0.0;
  for (double x : w)
    sum += x;
  EXPECT_NEAR(sum, 1.0, 1e-12);
  // One particle holds almost all the mass: Neff ~ 1 < 2, every survivor is that particle, weights uniform again.
  log_w = { 0.0, 20.0, 0.0, 0.0 };
  bool called_before = false;
  step = weighAndResample(&log_w, &w, policy, random, [&](const WeightingStep& s) {
    called_before = true;
    EXPECT_FALSE(s.resampled);
    EXPECT_EQ(s.best, 1u);
    EXPECT_GT(w[1], 0.999);  // the callback sees the weights as weighed
  });
  EXPECT_TRUE(called_before);
  EXPECT_TRUE(step.resampled);
  EXPECT_LT(step.neff, 1.01);
  ASSERT_EQ(step.keep.size(), 4u);
  for (int k : step.keep)
    EXPECT_EQ(k, 1);
  for (std::size_t i = 0; i < 4; ++i)
  {
    EXPECT_DOUBLE_EQ(w[i], 0.25);
    EXPECT_DOUBLE_EQ(log_w[i], -std::log(4.0));
  }
  // Ratio 0 never resamples; ratio 1 resamples whenever the weights are not exactly uniform.
  policy.neff_ratio = 0.0;
  log_w = { 0.0, 20.0, 0.0, 0.0 };
  EXPECT_FALSE(weighAndResample(&log_w, &w, policy, random).resampled);
  policy.neff_ratio = 1.0;
  log_w = { 0.0, 0.01, 0.0, 0.0 };
  EXPECT_TRUE(weighAndResample(&log_w, &w, policy, random).resampled);
  ResamplingPolicy invalid;
  invalid.neff_ratio = 1.5;
  EXPECT_NE(invalid.validate(), "");
  EXPECT_EQ(ResamplingPolicy().validate(), "");
}

TEST(WeighAndResample, TheMethodDecidesWhichSurvive)
{
  // Two particles share the mass; low-variance resampling keeps each exactly N/2 times, multinomial draws.
  const std::vector<double> start = { 0.0, 0.0, -50.0, -50.0, -50.0, -50.0, -50.0, -50.0 };
  ResamplingPolicy policy;
  policy.neff_ratio = 0.5;
  Random random(11);
  std::vector<double> log_w = start, w;
  const WeightingStep low = weighAndResample(&log_w, &w, policy, random);
  ASSERT_TRUE(low.resampled);
  EXPECT_EQ(std::count(low.keep.begin(), low.keep.end(), 0), 4);
  EXPECT_EQ(std::count(low.keep.begin(), low.keep.end(), 1), 4);
  policy.method = ResamplingMethod::kMultinomial;
  int uneven = 0;
  for (int trial = 0; trial < 20; ++trial)
  {
    log_w = start;
    const WeightingStep multi = weighAndResample(&log_w, &w, policy, random);
    ASSERT_TRUE(multi.resampled);
    for (int k : multi.keep)
      EXPECT_TRUE(k == 0 || k == 1);
    uneven += std::count(multi.keep.begin(), multi.keep.end(), 0) != 4 ? 1 : 0;
  }
  EXPECT_GT(uneven, 5);  // independent draws rarely split 4 / 4
}

TEST(ApplyResampling, CopiesByIndexAndMovesTheLastCopy)
{
  std::vector<std::vector<int>> items = { { 0 }, { 1, 1 }, { 2, 2, 2 } };
  applyResampling(&items, { 2, 2, 0 });
  ASSERT_EQ(items.size(), 3u);
  EXPECT_EQ(items[0], (std::vector<int>{ 2, 2, 2 }));
  EXPECT_EQ(items[1], (std::vector<int>{ 2, 2, 2 }));
  EXPECT_EQ(items[2], (std::vector<int>{ 0 }));
}
