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
