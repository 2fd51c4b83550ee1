#include "rbpf_slam/io/fastslam_config.h"

#include <cstdint>
#include <stdexcept>
#include <string>

namespace rbpf_slam
{
namespace io
{
void readFastSlamConfig(const ParamSource& p, core::TrunkSlamConfig* c)
{
  p.get("particles", &c->particles);
  p.get("motion/alpha1", &c->motion.alpha1);
  p.get("motion/alpha2", &c->motion.alpha2);
  p.get("motion/alpha3", &c->motion.alpha3);
  p.get("motion/alpha4", &c->motion.alpha4);
  p.get("motion_step", &c->motion_step);
  p.get("motion_step_angle", &c->motion_step_angle);
  p.get("motion_noise_time", &c->motion_noise_time);
  p.get("range_sigma_floor", &c->range_sigma_floor);
  p.get("bearing_sigma_floor", &c->bearing_sigma_floor);
  p.get("min_range", &c->min_range);
  p.get("max_range", &c->max_range);
  p.get("field_of_view", &c->field_of_view);
  p.get("detection_probability", &c->detection_probability);
  p.get("association_gate", &c->association_gate);
  p.get("use_radius", &c->use_radius);
  p.get("use_known_ids", &c->use_known_ids);
  p.get("radius_sigma_floor", &c->radius_sigma_floor);
  p.get("min_trunk_gap", &c->min_trunk_gap);
  p.get("relocalize_when_lost", &c->relocalize_when_lost);
  p.get("max_trunks_per_sweep", &c->max_trunks_per_sweep);
  p.get("max_landmarks", &c->max_landmarks);
  p.get("gps/enabled", &c->gnss.enabled);
  p.get("gps/max_sigma", &c->gnss.max_sigma);
  p.get("gps/sigma_floor", &c->gnss.sigma_floor);
  p.get("gps/correlation_time", &c->gnss.correlation_time);
  p.get("gps/anchor_min_spread", &c->gnss.anchor_min_spread);
  p.get("gps/anchor_min_fixes", &c->gnss.anchor_min_fixes);
  p.get("gps/weigh_max_anchor_sigma", &c->gnss.weigh_max_anchor_sigma);
  p.get("evidence_hit", &c->evidence_hit);
  p.get("evidence_miss", &c->evidence_miss);
  p.get("evidence_max", &c->evidence_max);
  p.get("delete_evidence", &c->delete_evidence);
  p.get("evidence_view_change", &c->evidence_view_change);
  p.get("confirm_observations", &c->confirm_observations);
  p.get("provisional_weighs", &c->provisional_weighs);
  p.get("drop_unconfirmed_leaving_scope", &c->drop_unconfirmed_leaving_scope);
  readResamplingPolicy(p, &c->resampling);
  p.get("roughening", &c->roughening);
  p.get("roughening_sigma_xy", &c->roughening_sigma_xy);
  p.get("roughening_sigma_theta", &c->roughening_sigma_theta);
  std::string motion_model = core::toString(c->motion_model);
  p.get("motion_model", &motion_model);
  if (!core::parseMotionModel(motion_model, &c->motion_model))
    throw std::runtime_error("parameter 'motion_model' must be odometry or velocity, not '" + motion_model + "'");
  std::string proposal = core::toString(c->proposal);
  p.get("proposal", &proposal);
  if (!core::parsePoseProposal(proposal, &c->proposal))
    throw std::runtime_error("parameter 'proposal' must be fastslam1 or fastslam2, not '" + proposal + "'");
  std::string estimate = core::toString(c->estimate);
  p.get("estimate", &estimate);
  if (!core::parsePoseEstimate(estimate, &c->estimate))
    throw std::runtime_error("parameter 'estimate' must be mean or best, not '" + estimate + "'");
  p.get("mixture_fraction", &c->mixture_fraction);
  core::LoopClosureConfig& lc = c->loop_closure;
  p.get("loop_closure/enabled", &lc.enabled);
  p.get("loop_closure/search_interval", &lc.search_interval);
  p.get("loop_closure/retry_interval", &lc.retry_interval);
  p.get("loop_closure/recent_time", &lc.detection.recent_time);
  p.get("loop_closure/recent_radius", &lc.detection.recent_radius);
  p.get("loop_closure/old_time", &lc.detection.old_time);
  p.get("loop_closure/min_trees", &lc.detection.constellation.min_inliers);
  p.get("loop_closure/min_correction", &lc.detection.min_correction);
  p.get("loop_closure/confirmations", &lc.detection.confirmations);
  p.get("loop_closure/keyframe_distance", &lc.smoother.keyframe_distance);
  p.get("loop_closure/keyframe_angle", &lc.smoother.keyframe_angle);
  p.get("loop_closure/robust_scale", &lc.smoother.robust_scale);
  p.get("loop_closure/loop_sigma", &lc.smoother.loop_sigma);
  p.get("loop_closure/loop_radius_share", &lc.smoother.loop_radius_share);
  p.get("loop_closure/loop_quantile", &lc.smoother.loop_quantile);
  p.get("loop_closure/loop_rounds", &lc.smoother.loop_rounds);
  p.get("loop_closure/max_iterations", &lc.smoother.max_iterations);
  p.get("loop_closure/max_factors", &lc.smoother.max_factors);
  p.get("loop_closure/apply_after", &lc.apply_after);
  p.get("loop_closure/drift_quantile", &lc.drift_quantile);
  p.get("loop_closure/smooth_interval", &lc.smooth_interval);
  p.getSeed("seed", &c->seed);
  const std::string error = c->validate();
  if (!error.empty())
    throw std::runtime_error("invalid parameter: " + error);
}

}  // namespace io
}  // namespace rbpf_slam
