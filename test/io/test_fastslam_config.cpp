#include <algorithm>
#include <cstdio>
#include <fstream>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "io/split_config.h"

#include "rbpf_slam/io/fastslam_config.h"

using namespace rbpf_slam;

namespace
{
const std::string kConfigDir = std::string(RBPF_SLAM_SOURCE_DIR) + "/config/";
// The shipped configuration is two files, read in this order: the advanced keys, then the keys a user sets on top.
const std::string kAdvancedFile = kConfigDir + "fastslam_advanced.yaml";
const std::string kUserFile = kConfigDir + "fastslam.yaml";

/** @brief The shipped configuration as the launch files and slam_bag load it: the advanced file, then the user's. */
void readShippedConfig(core::TrunkSlamConfig* c)
{
  io::readFastSlamConfig(io::YamlParamSource(kAdvancedFile), c);
  io::readFastSlamConfig(io::YamlParamSource(kUserFile), c);
}

}  // namespace

TEST(FastSlamConfigFile, ShippedConfigMatchesTheBuiltInDefaults)
{
  // config/fastslam_advanced.yaml and config/fastslam.yaml document the defaults; reading them must change nothing.
  io::YamlParamSource advanced(kAdvancedFile);
  io::YamlParamSource params(kUserFile);
  core::TrunkSlamConfig read, defaults;
  io::readFastSlamConfig(advanced, &read);
  io::readFastSlamConfig(params, &read);
  EXPECT_EQ(read.particles, defaults.particles);
  EXPECT_EQ(read.max_trunks_per_sweep, defaults.max_trunks_per_sweep);
  EXPECT_EQ(read.max_landmarks, defaults.max_landmarks);
  EXPECT_EQ(read.gnss.max_sigma, defaults.gnss.max_sigma);
  EXPECT_EQ(read.motion.alpha1, defaults.motion.alpha1);
  EXPECT_EQ(read.motion.alpha2, defaults.motion.alpha2);
  EXPECT_EQ(read.motion.alpha3, defaults.motion.alpha3);
  EXPECT_EQ(read.motion.alpha4, defaults.motion.alpha4);
  EXPECT_EQ(read.range_sigma_floor, defaults.range_sigma_floor);
  EXPECT_EQ(read.bearing_sigma_floor, defaults.bearing_sigma_floor);
  EXPECT_EQ(read.min_range, defaults.min_range);
  EXPECT_EQ(read.max_range, defaults.max_range);
  EXPECT_NEAR(read.field_of_view, defaults.field_of_view, 1e-12);
  EXPECT_EQ(read.detection_probability, defaults.detection_probability);
  EXPECT_EQ(read.motion_step, defaults.motion_step);
  EXPECT_EQ(read.motion_step_angle, defaults.motion_step_angle);
  EXPECT_EQ(read.motion_model, defaults.motion_model);
  EXPECT_EQ(read.motion_noise_time, defaults.motion_noise_time);
  EXPECT_EQ(read.provisional_weighs, defaults.provisional_weighs);
  EXPECT_EQ(read.estimate, defaults.estimate);
  EXPECT_EQ(read.use_known_ids, defaults.use_known_ids);
  EXPECT_EQ(read.association_gate, defaults.association_gate);
  EXPECT_EQ(read.use_radius, defaults.use_radius);
  EXPECT_EQ(read.radius_sigma_floor, defaults.radius_sigma_floor);
  EXPECT_EQ(read.min_trunk_gap, defaults.min_trunk_gap);
  EXPECT_EQ(read.evidence_hit, defaults.evidence_hit);
  EXPECT_EQ(read.evidence_miss, defaults.evidence_miss);
  EXPECT_EQ(read.evidence_max, defaults.evidence_max);
  EXPECT_EQ(read.delete_evidence, defaults.delete_evidence);
  EXPECT_EQ(read.confirm_observations, defaults.confirm_observations);
  EXPECT_EQ(read.drop_unconfirmed_leaving_scope, defaults.drop_unconfirmed_leaving_scope);
  EXPECT_EQ(read.resampling.method, defaults.resampling.method);
  EXPECT_EQ(read.resampling.neff_ratio, defaults.resampling.neff_ratio);
  EXPECT_EQ(read.roughening, defaults.roughening);
  EXPECT_EQ(read.roughening_sigma_xy, defaults.roughening_sigma_xy);
  EXPECT_EQ(read.roughening_sigma_theta, defaults.roughening_sigma_theta);
  EXPECT_EQ(read.seed, defaults.seed);
  EXPECT_EQ(read.proposal, defaults.proposal);
  EXPECT_EQ(read.mixture_fraction, defaults.mixture_fraction);
  EXPECT_EQ(read.relocalize_when_lost, defaults.relocalize_when_lost);
  EXPECT_EQ(read.gnss.enabled, defaults.gnss.enabled);
  EXPECT_EQ(read.loop_closure.enabled, defaults.loop_closure.enabled);
  EXPECT_EQ(read.loop_closure.search_interval, defaults.loop_closure.search_interval);
  EXPECT_EQ(read.loop_closure.smoother.max_factors, defaults.loop_closure.smoother.max_factors);
  EXPECT_EQ(read.loop_closure.apply_after, defaults.loop_closure.apply_after);
  // The keys the nodelet reads itself (frames, timing, inventory) are the only ones this reader leaves.
  for (const io::YamlParamSource* source : { &advanced, &params })
    for (const auto& k : source->unusedKeys())
      EXPECT_TRUE(k == "map_frame" || k == "odom_frame" || k == "base_frame" || k == "odom_timeout" ||
                  k == "transform_tolerance" || k == "publish_tf" || k == "inventory_path" || k == "max_path_poses" ||
                  k == "time_jump_threshold" || k == "run_folder" || k == "map_file" || k == "initial_x" ||
                  k == "initial_y" || k == "initial_yaw" || k == "map_path" || k == "relocalize")
          << "unexpected key " << k;
}

TEST(FastSlamConfigFile, TheUsersFileIsShortAndTheTwoFilesSplitTheKeys)
{
  const std::vector<std::string> users_keys{ "map_frame", "odom_frame", "base_frame", "particles", "seed" };
  split_config::expectSplitKeys(kUserFile, kAdvancedFile, users_keys, 50u,
                                [](const io::ParamSource& p) {
                                  core::TrunkSlamConfig c;
                                  io::readFastSlamConfig(p, &c);
                                });
}

TEST(FastSlamConfigFile, AMisspeltKeyOverTheAdvancedFileIsStillReported)
{
  // The tools warn of each file's unused keys: the advanced file leaves only the node's keys, and a user's file laid
  // over it still shows its misspelt key (and only that one).
  core::TrunkSlamConfig c;
  split_config::expectMisspeltKeyReported(kAdvancedFile, "particles: 50\nmotion:\n  alpha1: 0.1\nparticels: 60\n",
                                          "particels",
                                          [&](const io::ParamSource& p) { io::readFastSlamConfig(p, &c); });
  EXPECT_EQ(c.particles, 50);
  EXPECT_EQ(c.motion.alpha1, 0.1);
  EXPECT_EQ(c.motion.alpha2, core::TrunkSlamConfig().motion.alpha2);  // the rest of motion/ stays
}

TEST(FastSlamConfigFile, ResamplingKeys)
{
  const std::string path = std::string(::testing::TempDir()) + "fastslam_resampling.yaml";
  {
    std::ofstream(path) << "resampling: multinomial\nresample_neff_ratio: 0.25\n";
    io::YamlParamSource params(path);
    core::TrunkSlamConfig c;
    io::readFastSlamConfig(params, &c);
    EXPECT_EQ(c.resampling.method, core::ResamplingMethod::kMultinomial);
    EXPECT_EQ(c.resampling.neff_ratio, 0.25);
    EXPECT_TRUE(params.unusedKeys().empty());
  }
  {
    // The former name is no longer read: an unknown key, which the tools warn of as misspelt.
    std::ofstream(path) << "resample_threshold: 0.25\n";
    io::YamlParamSource params(path);
    core::TrunkSlamConfig c;
    io::readFastSlamConfig(params, &c);
    EXPECT_EQ(c.resampling.neff_ratio, core::TrunkSlamConfig().resampling.neff_ratio);
    EXPECT_EQ(params.unusedKeys(), std::vector<std::string>{ "resample_threshold" });
  }
  std::ofstream(path) << "resampling: stratified\n";
  io::YamlParamSource bad(path);
  core::TrunkSlamConfig c;
  EXPECT_THROW(io::readFastSlamConfig(bad, &c), std::runtime_error);
  std::remove(path.c_str());
}

TEST(FastSlamConfigFile, WrongTypeAndInvalidValueNameTheKey)
{
  const std::string path = std::string(::testing::TempDir()) + "fastslam_bad.yaml";
  std::ofstream(path) << "motion:\n  alpha3: lots\n";
  core::TrunkSlamConfig c;
  try
  {
    io::readFastSlamConfig(io::YamlParamSource(path), &c);
    FAIL() << "no error for a non-number alpha3";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("motion/alpha3"), std::string::npos) << e.what();
  }
  std::ofstream(path) << "particles: 0\n";
  try
  {
    io::readFastSlamConfig(io::YamlParamSource(path), &c);
    FAIL() << "no error for zero particles";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("particles"), std::string::npos) << e.what();
  }
  std::ofstream(path) << "proposal: fastslam3\n";
  try
  {
    io::readFastSlamConfig(io::YamlParamSource(path), &c);
    FAIL() << "no error for an unknown proposal";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("proposal"), std::string::npos) << e.what();
  }
  std::ofstream(path) << "motion_model: wheels\n";
  try
  {
    io::readFastSlamConfig(io::YamlParamSource(path), &c);
    FAIL() << "no error for an unknown motion model";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("motion_model"), std::string::npos) << e.what();
  }
  std::ofstream(path) << "proposal: fastslam2\nmixture_fraction: 0.1\n";
  core::TrunkSlamConfig ok;
  io::readFastSlamConfig(io::YamlParamSource(path), &ok);
  EXPECT_EQ(ok.proposal, core::PoseProposal::kFastSlam2);
  EXPECT_EQ(ok.mixture_fraction, 0.1);
  std::remove(path.c_str());
}

TEST(FastSlamConfigFile, OdometryClassesOverrideTheMotionModelOnly)
{
  // Each accuracy class of config/odometry/ read after the shipped files sets the motion model and its step,
  // nothing else, and every class differs from the defaults somewhere or is the defaults' own statement.
  for (const char* name : { "forest_atv", "skid_steer_indoor", "car", "indoor_commanded" })
  {
    const std::string path = std::string(RBPF_SLAM_SOURCE_DIR) + "/config/odometry/" + name + ".yaml";
    core::TrunkSlamConfig c;
    readShippedConfig(&c);
    io::YamlParamSource cls(path);
    io::readFastSlamConfig(cls, &c);
    EXPECT_TRUE(cls.unusedKeys().empty()) << name;
    EXPECT_GT(c.motion.alpha1, 0.0) << name;
    EXPECT_GT(c.motion_step, 0.0) << name;
    // The commanded-velocity class takes the velocity model, the measured ones the odometry model.
    EXPECT_EQ(c.motion_model == core::MotionModel::kVelocity, std::string(name) == "indoor_commanded") << name;
    const core::TrunkSlamConfig d;
    EXPECT_EQ(c.particles, d.particles) << name;
    EXPECT_EQ(c.association_gate, d.association_gate) << name;
  }
}

TEST(FastSlamConfigFile, TheScannerOverlaySetsOnlyTheProvisionalRule)
{
  core::TrunkSlamConfig c;
  readShippedConfig(&c);
  EXPECT_TRUE(c.provisional_weighs);
  io::YamlParamSource overlay(kConfigDir + "scanner_2d.yaml");
  io::readFastSlamConfig(overlay, &c);
  EXPECT_TRUE(overlay.unusedKeys().empty());
  EXPECT_FALSE(c.provisional_weighs);
}

TEST(FastSlamConfigFile, TheShippedFilesLeaveOnlyTheNodesKeysUnread)
{
  io::YamlParamSource advanced(kAdvancedFile), params(kUserFile);
  core::TrunkSlamConfig c;
  io::readFastSlamConfig(advanced, &c);
  io::readFastSlamConfig(params, &c);
  const std::vector<std::string>& node = io::nodeOnlyKeys();
  for (const io::YamlParamSource* source : { &advanced, &params })
    for (const auto& k : source->unusedKeys())
      EXPECT_NE(std::find(node.begin(), node.end(), k), node.end()) << "key " << k << " is read by no one";
  EXPECT_NE(std::find(node.begin(), node.end(), "map_frame"), node.end());
  EXPECT_EQ(std::find(node.begin(), node.end(), "particles"), node.end());
}
