#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "rbpf_slam/sim/velocity_noise.h"

using rbpf_slam::sim::VelocityCommand;
using rbpf_slam::sim::VelocityNoiseConfig;
using rbpf_slam::sim::VelocityNoiseModel;

namespace
{
struct Moments
{
  double mean_linear = 0.0;
  double std_linear = 0.0;
  double mean_angular = 0.0;
  double std_angular = 0.0;
};

Moments sample(VelocityNoiseModel& model, const VelocityCommand& cmd, int n)
{
  double s_l = 0.0, ss_l = 0.0, s_a = 0.0, ss_a = 0.0;
  for (int i = 0; i < n; ++i)
  {
    const VelocityCommand out = model.apply(cmd);
    s_l += out.linear;
    ss_l += out.linear * out.linear;
    s_a += out.angular;
    ss_a += out.angular * out.angular;
  }
  Moments m;
  m.mean_linear = s_l / n;
  m.mean_angular = s_a / n;
  m.std_linear = std::sqrt(ss_l / n - m.mean_linear * m.mean_linear);
  m.std_angular = std::sqrt(ss_a / n - m.mean_angular * m.mean_angular);
  return m;
}
}  // namespace

TEST(VelocityNoise, MomentsMatchTheConfiguredSigmas)
{
  VelocityNoiseConfig config;
  config.linear_sigma_abs = 0.03;
  config.linear_sigma_rel = 0.04;
  config.angular_sigma_abs = 0.02;
  config.angular_sigma_rel = 0.10;
  VelocityNoiseModel model(config, 123);
  const VelocityCommand cmd{ 1.5, -0.4 };
  const int n = 100000;
  const Moments m = sample(model, cmd, n);

  const double sigma_l = std::sqrt(0.03 * 0.03 + (0.04 * 1.5) * (0.04 * 1.5));  // 0.0671
  const double sigma_a = std::sqrt(0.02 * 0.02 + (0.10 * 0.4) * (0.10 * 0.4));  // 0.0447
  EXPECT_NEAR(model.linearSigma(1.5), sigma_l, 1e-12);
  EXPECT_NEAR(model.angularSigma(-0.4), sigma_a, 1e-12);
  // 5 standard errors: the mean's is sigma / sqrt(n), the std's is sigma / sqrt(2 n).
  EXPECT_NEAR(m.mean_linear, 1.5, 5.0 * sigma_l / std::sqrt(n));
  EXPECT_NEAR(m.mean_angular, -0.4, 5.0 * sigma_a / std::sqrt(n));
  EXPECT_NEAR(m.std_linear, sigma_l, 5.0 * sigma_l / std::sqrt(2.0 * n));
  EXPECT_NEAR(m.std_angular, sigma_a, 5.0 * sigma_a / std::sqrt(2.0 * n));
}

TEST(VelocityNoise, ProportionalPartScalesWithTheCommand)
{
  VelocityNoiseConfig config;
  config.linear_sigma_abs = 0.0;
  config.linear_sigma_rel = 0.1;
  config.angular_sigma_abs = 0.0;
  config.angular_sigma_rel = 0.0;
  VelocityNoiseModel model(config, 1);
  // A standing robot gets no linear noise at all when the absolute part is zero.
  for (int i = 0; i < 100; ++i)
    EXPECT_EQ(model.apply({ 0.0, 0.0 }).linear, 0.0);
  const Moments fast = sample(model, { 2.0, 0.0 }, 50000);
  EXPECT_NEAR(fast.std_linear, 0.2, 0.01);
}

TEST(VelocityNoise, ZeroSigmaIsTheIdentity)
{
  VelocityNoiseConfig config;
  config.linear_sigma_abs = config.linear_sigma_rel = 0.0;
  config.angular_sigma_abs = config.angular_sigma_rel = 0.0;
  VelocityNoiseModel model(config, 99);
  for (double v : { -1.0, 0.0, 0.3, 7.25 })
  {
    const VelocityCommand out = model.apply({ v, -v / 2 });
    EXPECT_EQ(out.linear, v);
    EXPECT_EQ(out.angular, -v / 2);
  }
}

TEST(VelocityNoise, SameSeedSameSequenceOtherSeedOtherSequence)
{
  VelocityNoiseConfig config;
  VelocityNoiseModel a(config, 2024);
  VelocityNoiseModel b(config, 2024);
  VelocityNoiseModel c(config, 2025);
  int differ = 0;
  for (int i = 0; i < 500; ++i)
  {
    const VelocityCommand cmd{ 0.01 * i, 0.3 };
    const VelocityCommand oa = a.apply(cmd);
    const VelocityCommand ob = b.apply(cmd);
    const VelocityCommand oc = c.apply(cmd);
    ASSERT_EQ(oa.linear, ob.linear);
    ASSERT_EQ(oa.angular, ob.angular);
    differ += oa.linear != oc.linear;
  }
  EXPECT_GT(differ, 490);
}

TEST(VelocityNoise, ClampsToTheMaximumVelocities)
{
  VelocityNoiseConfig config;
  config.linear_sigma_abs = 0.5;
  config.angular_sigma_abs = 0.5;
  config.max_linear = 1.0;
  config.max_angular = 0.5;
  VelocityNoiseModel model(config, 3);
  bool hit_limit = false;
  for (int i = 0; i < 1000; ++i)
  {
    const VelocityCommand out = model.apply({ 0.9, -0.4 });
    ASSERT_LE(std::abs(out.linear), 1.0);
    ASSERT_LE(std::abs(out.angular), 0.5);
    hit_limit = hit_limit || out.linear == 1.0;
  }
  EXPECT_TRUE(hit_limit);
}

TEST(VelocityNoise, ValidationNamesTheBadParameter)
{
  VelocityNoiseConfig config;
  std::string error;
  EXPECT_TRUE(config.validate(&error));
  config.angular_sigma_rel = -0.1;
  EXPECT_FALSE(config.validate(&error));
  EXPECT_NE(error.find("angular_sigma_rel"), std::string::npos);
  config = VelocityNoiseConfig();
  config.linear_sigma_abs = std::nan("");
  EXPECT_FALSE(config.validate(&error));
  EXPECT_NE(error.find("linear_sigma_abs"), std::string::npos);
}
