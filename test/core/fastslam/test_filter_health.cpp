// The filter's health over its last updates.
#include <gtest/gtest.h>

#include "rbpf_slam/core/fastslam/fastslam.h"
#include "rbpf_slam/core/fastslam/filter_health.h"

using rbpf_slam::core::FastSlamUpdateStats;
using rbpf_slam::core::FilterHealth;
using rbpf_slam::core::HealthLevel;

TEST(FilterHealth, ANewMapIsHealthyARebuiltOneWarns)
{
  FilterHealth h;
  FastSlamUpdateStats s;
  // Exploring: every observation first makes a landmark, then matches it once confirmed.
  for (int i = 0; i < 100; ++i)
  {
    s = FastSlamUpdateStats();
    s.observations = 3;
    s.created = i % 20 == 0 ? 3 : 0;
    s.matched = 3 - s.created;
    s.matched_confirmed = i % 20 < 3 ? 0 : s.matched;
    s.neff = 80;
    EXPECT_EQ(h.add(s, 100).level, HealthLevel::kOk) << "update " << i << ": " << h.status().message;
  }
  // Lost: observations keep making landmarks where confirmed ones were deleted.
  for (int i = 0; i < 3; ++i)
  {
    s = FastSlamUpdateStats();
    s.observations = 2;
    s.created = 2;
    s.recreated = 1;
    h.add(s, 100);
  }
  EXPECT_EQ(h.status().level, HealthLevel::kWarn);
  EXPECT_NE(h.status().message.find("rebuilt"), std::string::npos);
  EXPECT_GT(h.warnings(), 0);
}

TEST(FilterHealth, FewMatchesToConfirmedLandmarksWithManyNewOnesWarn)
{
  FilterHealth h;
  FastSlamUpdateStats s;
  s.observations = 2;
  s.created = 2;  // nothing ever matches: every look makes new landmarks
  for (int i = 0; i < 99; ++i)
    EXPECT_EQ(h.add(s, 100).level, HealthLevel::kOk);  // a new map: no verdict before the window is full
  h.add(s, 100);
  EXPECT_EQ(h.status().level, HealthLevel::kWarn);
  EXPECT_DOUBLE_EQ(h.status().matched_confirmed_share, 0.0);
}

TEST(FilterHealth, InASavedMapFewMatchesToItsTreesWarnAfterAShortWindow)
{
  rbpf_slam::core::HealthConfig c;
  c.matched_prior_warn = 0.3;
  FilterHealth h(c);
  FastSlamUpdateStats s;
  s.neff = 80;
  s.observations = 10;
  s.matched = s.matched_confirmed = 7;
  s.matched_prior = 6;  // a second visit: two thirds matched to the saved trees, the rest new, clutter
  for (int i = 0; i < 200; ++i)
    EXPECT_EQ(h.add(s, 100).level, HealthLevel::kOk) << h.status().message;
  // Lost: the observations match the filter's own new landmarks (consistently), none of the saved map's.
  s.matched_prior = 0;
  int updates = 0;
  while (h.add(s, 100).level == HealthLevel::kOk && updates < 100)
    ++updates;
  EXPECT_EQ(h.status().level, HealthLevel::kWarn);
  EXPECT_NE(h.status().message.find("saved map not re-observed"), std::string::npos) << h.status().message;
  EXPECT_LE(updates, c.prior_window) << "warned after a short window, not the long one";
  EXPECT_GE(updates, 15) << "not on a few sweeps' dip";
  // Without a saved map the same figures are a healthy new map.
  FilterHealth fresh;
  for (int i = 0; i < 200; ++i)
    EXPECT_EQ(fresh.add(s, 100).level, HealthLevel::kOk);
}

TEST(FilterHealth, InnovationsBeyondTheClaimedUncertaintyWarn)
{
  FilterHealth h;
  FastSlamUpdateStats s;
  s.observations = 3;
  s.matched = 3;
  s.matched_confirmed = 3;
  s.neff = 80;
  s.claimed_matches = 3;
  s.claimed_nis = 3 * 2.1;  // chi-square, 2 dof: about 2 per match when the spread covers the error
  for (int i = 0; i < 100; ++i)
    EXPECT_EQ(h.add(s, 100).level, HealthLevel::kOk) << h.status().message;
  EXPECT_NEAR(h.status().claimed_nis, 2.1, 1e-12);
  s.claimed_nis = 3 * 30.0;  // errors about four times what the cloud claims
  for (int i = 0; i < 30; ++i)
    h.add(s, 100);
  EXPECT_EQ(h.status().level, HealthLevel::kWarn);
  EXPECT_TRUE(h.status().overconfident);
  EXPECT_NE(h.status().message.find("overconfident"), std::string::npos) << h.status().message;
}

TEST(FilterHealth, ARevisitTheSmootherRefusedWarnsUntilALoopCloses)
{
  rbpf_slam::core::HealthConfig config;
  config.recreated_warn = 0;  // with loop closure: the loop search judges a map made again beside itself
  FilterHealth h(config);
  FastSlamUpdateStats s;
  s.observations = 4;
  s.matched = s.matched_confirmed = 3;
  s.created = 1;
  s.recreated = 1;  // every update: the rule would warn at the third
  s.neff = 80;
  for (int i = 0; i < 10; ++i)
    EXPECT_EQ(h.add(s, 100).level, HealthLevel::kOk) << h.status().message;
  EXPECT_EQ(h.status().cause, rbpf_slam::core::HealthCause::kNone);
  h.revisit(false, "its trees' residuals 795.6 exceed the chi-square bound 65.2");
  EXPECT_EQ(h.add(s, 100).level, HealthLevel::kWarn);
  EXPECT_EQ(h.status().cause, rbpf_slam::core::HealthCause::kInconsistent);
  EXPECT_TRUE(h.status().map_inconsistent);
  EXPECT_NE(h.status().message.find("795.6"), std::string::npos) << h.status().message;
  EXPECT_STREQ(rbpf_slam::core::toString(h.status().cause), "inconsistent");
  for (int i = 0; i < 50; ++i)
    EXPECT_EQ(h.add(s, 100).level, HealthLevel::kWarn) << "it stays until a loop closes";
  h.revisit(true, std::string());
  EXPECT_EQ(h.add(s, 100).level, HealthLevel::kOk) << h.status().message;
  EXPECT_EQ(h.warnings(), 51);

  // With the rule on (no loop closure), the same updates warn for the landmarks made again.
  FilterHealth rule;
  for (int i = 0; i < 3; ++i)
    rule.add(s, 100);
  EXPECT_EQ(rule.status().cause, rbpf_slam::core::HealthCause::kRecreated);
}
