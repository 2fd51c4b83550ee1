#include <algorithm>
#include <cstdio>
#include <fstream>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "io/split_config.h"

#include "rbpf_slam/io/grid_slam_config.h"

using namespace rbpf_slam;

namespace
{
const std::string kConfigDir = std::string(RBPF_SLAM_SOURCE_DIR) + "/config/";
// The shipped configuration is two files, read in this order: the advanced keys (rbpf's tuning), then the keys a user
// sets on top; config/grid_single_map.yaml goes over both for the single-map filter.
const std::string kAdvancedFile = kConfigDir + "grid_slam_advanced.yaml";
const std::string kUserFile = kConfigDir + "grid_slam.yaml";

}  // namespace

TEST(GridSlamConfigFile, TheSingleMapOverlayOnTheShippedConfigGivesBackTheBuiltInDefaults)
{
  // config/grid_slam_advanced.yaml and config/grid_slam.yaml are rbpf's; config/grid_single_map.yaml laid over them
  // restores every built-in value (the single-map filter's), so the three files together document them.
  io::YamlParamSource advanced(kAdvancedFile);
  io::YamlParamSource params(kUserFile);
  io::YamlParamSource single(kConfigDir + "grid_single_map.yaml");
  core::GridSlamConfig read, defaults;
  read.particles = 1;  // so that the file's value is seen to arrive
  io::readGridSlamConfig(advanced, &read);
  io::readGridSlamConfig(params, &read);
  io::readGridSlamConfig(single, &read);
  EXPECT_TRUE(single.unusedKeys().empty());
  EXPECT_EQ(read.mode, defaults.mode);
  EXPECT_EQ(read.particles, defaults.particles);
  EXPECT_EQ(read.seed, defaults.seed);
  EXPECT_EQ(read.resampling.method, defaults.resampling.method);
  EXPECT_EQ(read.resampling.neff_ratio, defaults.resampling.neff_ratio);
  EXPECT_EQ(read.correlation_gain, defaults.correlation_gain);
  EXPECT_EQ(read.score_beam_step, defaults.score_beam_step);
  EXPECT_EQ(read.motion.alpha1, defaults.motion.alpha1);
  EXPECT_EQ(read.motion.alpha2, defaults.motion.alpha2);
  EXPECT_EQ(read.motion.alpha3, defaults.motion.alpha3);
  EXPECT_EQ(read.motion.alpha4, defaults.motion.alpha4);
  EXPECT_EQ(read.grid.resolution, defaults.grid.resolution);
  EXPECT_EQ(read.grid.log_odds_hit, defaults.grid.log_odds_hit);
  EXPECT_EQ(read.grid.log_odds_free, defaults.grid.log_odds_free);
  EXPECT_EQ(read.grid.log_odds_clamp, defaults.grid.log_odds_clamp);
  EXPECT_EQ(read.grid.occupied_log_odds, defaults.grid.occupied_log_odds);
  EXPECT_EQ(read.grid.free_log_odds, defaults.grid.free_log_odds);
  EXPECT_EQ(read.limits.range_min, defaults.limits.range_min);
  EXPECT_EQ(read.limits.range_max, defaults.limits.range_max);
  EXPECT_EQ(read.limits.no_return_free_range, defaults.limits.no_return_free_range);
  EXPECT_EQ(read.likelihood_gain, defaults.likelihood_gain);
  EXPECT_EQ(read.proposal_sigma_xy, defaults.proposal_sigma_xy);
  EXPECT_EQ(read.proposal_sigma_theta, defaults.proposal_sigma_theta);
  EXPECT_EQ(read.min_matched_ratio, defaults.min_matched_ratio);
  EXPECT_EQ(read.proposal_motion_weight, defaults.proposal_motion_weight);
  EXPECT_EQ(read.odometry_veto, defaults.odometry_veto);
  EXPECT_EQ(read.veto_consensus, defaults.veto_consensus);
  EXPECT_EQ(read.veto_information_gain, defaults.veto_information_gain);
  EXPECT_EQ(read.linear_update, defaults.linear_update);
  EXPECT_EQ(read.angular_update, defaults.angular_update);
  EXPECT_EQ(read.temporal_update, defaults.temporal_update);
  EXPECT_EQ(read.matcher.kernel, defaults.matcher.kernel);
  EXPECT_EQ(read.matcher.match_sigma, defaults.matcher.match_sigma);
  EXPECT_EQ(read.matcher.likelihood_sigma, defaults.matcher.likelihood_sigma);
  EXPECT_EQ(read.matcher.no_hit_distance, defaults.matcher.no_hit_distance);
  EXPECT_EQ(read.matcher.linear_step, defaults.matcher.linear_step);
  EXPECT_EQ(read.matcher.angular_step, defaults.matcher.angular_step);
  EXPECT_EQ(read.matcher.refinements, defaults.matcher.refinements);
  EXPECT_EQ(read.matcher.max_iterations, defaults.matcher.max_iterations);
  EXPECT_EQ(read.matcher.beam_step, defaults.matcher.beam_step);
  EXPECT_EQ(read.matcher.coarse_kernel, defaults.matcher.coarse_kernel);
  EXPECT_EQ(read.matcher.coarse_sigma, defaults.matcher.coarse_sigma);
  EXPECT_EQ(read.matcher.coarse_beam_step, defaults.matcher.coarse_beam_step);
  EXPECT_EQ(read.matcher.coarse_refinements, defaults.matcher.coarse_refinements);
  EXPECT_EQ(read.matcher.prior_floor_xy, defaults.matcher.prior_floor_xy);
  EXPECT_EQ(read.matcher.prior_floor_theta, defaults.matcher.prior_floor_theta);
  EXPECT_EQ(read.matcher.climb_beam_step, defaults.matcher.climb_beam_step);
  EXPECT_EQ(read.threads, defaults.threads);
  // The keys the nodelet reads itself (frames, timing, map file) are the only ones this reader leaves.
  for (const io::YamlParamSource* source : { &advanced, &params })
    for (const auto& k : source->unusedKeys())
      EXPECT_TRUE(k == "map_frame" || k == "odom_frame" || k == "base_frame" || k == "odom_timeout" ||
                  k == "transform_tolerance" || k == "map_update_interval" || k == "publish_tf" || k == "map_path" ||
                  k == "max_path_poses" || k == "time_jump_threshold")
          << "unexpected key " << k;
}

TEST(GridSlamConfigFile, TheUsersFileIsShortAndTheTwoFilesSplitTheKeys)
{
  const std::vector<std::string> users_keys{ "map_frame", "odom_frame", "base_frame", "mode", "particles", "seed" };
  split_config::expectSplitKeys(kUserFile, kAdvancedFile, users_keys, 40u,
                                [](const io::ParamSource& p) {
                                  core::GridSlamConfig c;
                                  io::readGridSlamConfig(p, &c);
                                });
}

TEST(GridSlamConfigFile, TheUsersFileAloneIsNotTheShippedFilter)
{
  // The advanced file holds values that differ from the built-in ones (rbpf's matcher, its weights): the user's file
  // read without it leaves them at the built-in values, so every loader must read both (slam_bag: two --config).
  core::GridSlamConfig alone, both;
  io::readGridSlamConfig(io::YamlParamSource(kUserFile), &alone);
  io::readGridSlamConfig(io::YamlParamSource(kAdvancedFile), &both);
  io::readGridSlamConfig(io::YamlParamSource(kUserFile), &both);
  EXPECT_EQ(alone.mode, both.mode);
  EXPECT_EQ(alone.particles, both.particles);
  EXPECT_EQ(both.matcher.coarse_kernel, 1);
  EXPECT_EQ(alone.matcher.coarse_kernel, core::GridSlamConfig().matcher.coarse_kernel);
  EXPECT_NE(alone.matcher.coarse_kernel, both.matcher.coarse_kernel);
  EXPECT_NE(alone.proposal_motion_weight, both.proposal_motion_weight);
}

TEST(GridSlamConfigFile, AMisspeltKeyOverTheAdvancedFileIsStillReported)
{
  // The tools warn of each file's unused keys: the advanced file leaves only the node's keys, and a user's file laid
  // over it still shows its misspelt key (and only that one).
  core::GridSlamConfig c;
  split_config::expectMisspeltKeyReported(kAdvancedFile, "particles: 12\nrbpf:\n  kernel: 2\nlinear_updte: 0.2\n",
                                          "linear_updte",
                                          [&](const io::ParamSource& p) { io::readGridSlamConfig(p, &c); });
  EXPECT_EQ(c.particles, 12);
  EXPECT_EQ(c.matcher.kernel, 2);
  EXPECT_EQ(c.matcher.coarse_kernel, 1);  // the rest of rbpf/ stays the advanced file's
}

TEST(GridSlamConfigFile, WrongTypeUnknownNameAndInvalidValueNameTheKey)
{
  const std::string path = std::string(::testing::TempDir()) + "grid_slam_bad.yaml";
  const auto expectError = [&](const std::string& content, const std::string& key) {
    std::ofstream(path) << content;
    core::GridSlamConfig c;
    try
    {
      io::readGridSlamConfig(io::YamlParamSource(path), &c);
      ADD_FAILURE() << "no error for: " << content;
    }
    catch (const std::runtime_error& e)
    {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  };
  expectError("grid:\n  resolution: fine\n", "grid/resolution");
  expectError("resampling: stratified\n", "resampling");
  expectError("mode: gmapping\n", "mode");
  expectError("rbpf:\n  kernel: -1\n", "rbpf/kernel");
  expectError("rbpf:\n  coarse_kernel: 9\n", "rbpf/coarse_kernel");
  expectError("rbpf:\n  climb_beam_step: 0\n", "rbpf/climb_beam_step");
  expectError("threads: 0\n", "threads");
  expectError("rbpf:\n  prior_floor_xy: 0\n", "rbpf/prior_floor_xy");
  expectError("proposal_motion_weight: -2\n", "proposal_motion_weight");
  expectError("likelihood_gain: -1\n", "likelihood_gain");
  expectError("grid:\n  log_odds_free: 0.1\n", "log_odds_free");
  expectError("range_min: 5.0\nrange_max: 2.0\n", "range_max");
}

TEST(GridSlamConfigFile, ShippedConfigRunsRbpfWithTheCoarseLevelTheVetoItsConsensusAndEveryScan)
{
  core::GridSlamConfig c;
  io::readGridSlamConfig(io::YamlParamSource(kAdvancedFile), &c);
  io::readGridSlamConfig(io::YamlParamSource(kUserFile), &c);
  EXPECT_EQ(c.validate(), "");
  EXPECT_EQ(c.mode, core::GridSlamMode::kRbpf);
  EXPECT_EQ(c.particles, 30);
  EXPECT_GT(c.matcher.coarse_kernel, 0);
  EXPECT_EQ(c.proposal_motion_weight, 1.0);
  EXPECT_EQ(c.odometry_veto, 100.0);
  EXPECT_EQ(c.resampling.method, core::ResamplingMethod::kLowVariance);
  EXPECT_TRUE(c.veto_consensus);
  EXPECT_EQ(c.veto_information_gain, 0.0);
  EXPECT_EQ(c.linear_update, 0.0);
  EXPECT_EQ(c.angular_update, 0.0);
  EXPECT_EQ(c.temporal_update, 0.0);
}
