#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/filter/random.h"

using rbpf_slam::core::Random;

TEST(Random, SameSeedSameSequence)
{
  Random a(42);
  Random b(42);
  for (int i = 0; i < 1000; ++i)
  {
    ASSERT_EQ(a.uniform(), b.uniform());
    ASSERT_EQ(a.gaussian(), b.gaussian());
  }
}

TEST(Random, DifferentSeedsDiffer)
{
  Random a(1);
  Random b(2);
  int equal = 0;
  for (int i = 0; i < 100; ++i)
    equal += a.uniform() == b.uniform();
  EXPECT_LT(equal, 3);
}

TEST(Random, ReseedRestartsTheSequence)
{
  Random a(7);
  const double first = a.gaussian();
  a.gaussian();  // leaves a spare value cached
  a.seed(7);
  EXPECT_EQ(first, a.gaussian());
}

TEST(Random, UniformMomentsAndRange)
{
  Random r(3);
  const int n = 200000;
  double sum = 0.0;
  double sum_sq = 0.0;
  for (int i = 0; i < n; ++i)
  {
    const double u = r.uniform();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    sum += u;
    sum_sq += u * u;
  }
  const double mean = sum / n;
  const double var = sum_sq / n - mean * mean;
  // Standard error of the mean: sqrt(1/12 / n) = 6.5e-4; 5 sigma.
  EXPECT_NEAR(mean, 0.5, 3.3e-3);
  EXPECT_NEAR(var, 1.0 / 12.0, 1.5e-3);
}

TEST(Random, GaussianMoments)
{
  Random r(11);
  const int n = 200000;
  double sum = 0.0;
  double sum_sq = 0.0;
  double sum_4 = 0.0;
  for (int i = 0; i < n; ++i)
  {
    const double g = r.gaussian();
    sum += g;
    sum_sq += g * g;
    sum_4 += g * g * g * g;
  }
  const double mean = sum / n;
  const double var = sum_sq / n - mean * mean;
  EXPECT_NEAR(mean, 0.0, 5.0 / std::sqrt(n));
  EXPECT_NEAR(var, 1.0, 5.0 * std::sqrt(2.0 / n));
  EXPECT_NEAR(sum_4 / n, 3.0, 0.1);  // kurtosis of a normal distribution
}

TEST(Random, ZeroSigmaDrawsNothing)
{
  Random a(5);
  Random b(5);
  EXPECT_EQ(a.gaussian(0.0), 0.0);
  EXPECT_EQ(a.uniform(), b.uniform());
}

TEST(Random, UniformIndexCoversRange)
{
  Random r(9);
  std::vector<int> counts(7, 0);
  for (int i = 0; i < 70000; ++i)
  {
    const auto k = r.uniformIndex(7);
    ASSERT_LT(k, 7u);
    ++counts[k];
  }
  for (int c : counts)
    EXPECT_NEAR(c, 10000, 500);
}
