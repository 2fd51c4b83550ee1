#include "rbpf_slam/io/grid_slam_config.h"

#include <cstdint>
#include <stdexcept>
#include <string>

namespace rbpf_slam
{
namespace io
{
namespace
{
void getFloat(const ParamSource& p, const std::string& key, float* v)
{
  double d = *v;
  if (p.get(key, &d))
    *v = static_cast<float>(d);
}
}  // namespace

void readGridSlamConfig(const ParamSource& p, core::GridSlamConfig* c)
{
  std::string name;
  if (p.get("mode", &name) && !core::parseGridSlamMode(name, &c->mode))
    throw std::runtime_error("invalid parameter: mode must be 'single_map' or 'rbpf' (got '" + name + "')");
  p.get("particles", &c->particles);
  p.get("threads", &c->threads);
  p.getSeed("seed", &c->seed);
  readResamplingPolicy(p, &c->resampling);
  p.get("correlation_gain", &c->correlation_gain);
  p.get("score_beam_step", &c->score_beam_step);
  p.get("motion/alpha1", &c->motion.alpha1);
  p.get("motion/alpha2", &c->motion.alpha2);
  p.get("motion/alpha3", &c->motion.alpha3);
  p.get("motion/alpha4", &c->motion.alpha4);
  p.get("grid/resolution", &c->grid.resolution);
  getFloat(p, "grid/log_odds_hit", &c->grid.log_odds_hit);
  getFloat(p, "grid/log_odds_free", &c->grid.log_odds_free);
  getFloat(p, "grid/log_odds_clamp", &c->grid.log_odds_clamp);
  getFloat(p, "grid/occupied_log_odds", &c->grid.occupied_log_odds);
  getFloat(p, "grid/free_log_odds", &c->grid.free_log_odds);
  p.get("likelihood_gain", &c->likelihood_gain);
  p.get("proposal_sigma_xy", &c->proposal_sigma_xy);
  p.get("proposal_sigma_theta", &c->proposal_sigma_theta);
  p.get("min_matched_ratio", &c->min_matched_ratio);
  p.get("proposal_motion_weight", &c->proposal_motion_weight);
  p.get("veto_information_gain", &c->veto_information_gain);
  p.get("odometry_veto", &c->odometry_veto);
  p.get("veto_consensus", &c->veto_consensus);
  p.get("rbpf/kernel", &c->matcher.kernel);
  p.get("rbpf/match_sigma", &c->matcher.match_sigma);
  p.get("rbpf/likelihood_sigma", &c->matcher.likelihood_sigma);
  p.get("rbpf/no_hit_distance", &c->matcher.no_hit_distance);
  p.get("rbpf/linear_step", &c->matcher.linear_step);
  p.get("rbpf/angular_step", &c->matcher.angular_step);
  p.get("rbpf/refinements", &c->matcher.refinements);
  p.get("rbpf/max_iterations", &c->matcher.max_iterations);
  p.get("rbpf/beam_step", &c->matcher.beam_step);
  p.get("rbpf/climb_beam_step", &c->matcher.climb_beam_step);
  p.get("rbpf/coarse_kernel", &c->matcher.coarse_kernel);
  p.get("rbpf/coarse_sigma", &c->matcher.coarse_sigma);
  p.get("rbpf/coarse_beam_step", &c->matcher.coarse_beam_step);
  p.get("rbpf/coarse_refinements", &c->matcher.coarse_refinements);
  p.get("rbpf/prior_floor_xy", &c->matcher.prior_floor_xy);
  p.get("rbpf/prior_floor_theta", &c->matcher.prior_floor_theta);
  p.get("linear_update", &c->linear_update);
  p.get("angular_update", &c->angular_update);
  p.get("temporal_update", &c->temporal_update);
  p.get("range_min", &c->limits.range_min);
  p.get("range_max", &c->limits.range_max);
  p.get("no_return_free_range", &c->limits.no_return_free_range);
  const std::string error = c->validate();
  if (!error.empty())
    throw std::runtime_error("invalid parameter: " + error);
}

}  // namespace io
}  // namespace rbpf_slam
