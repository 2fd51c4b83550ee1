#include "rbpf_slam/core/grid/rbpf_grid_slam.h"

#include <algorithm>
#include <cmath>
#include <thread>

namespace rbpf_slam
{
namespace core
{
RbpfGridSlam::RbpfGridSlam(const GridSlamConfig& config) : GridSlam(config), matcher_(config.matcher)
{
  reset();
}

void RbpfGridSlam::resetMaps()
{
  const std::size_t n = static_cast<std::size_t>(config_.particles);
  maps_.assign(n, OccupancyGrid(config_.grid));
  histories_.assign(n, nullptr);
  best_index_ = 0;
}

int RbpfGridSlam::startMaps(const Pose2& odometry, const ScanData& scan, const Pose2& sensor)
{
  // One map for all: the others share its tiles until they write.
  const int beams = maps_[0].insertScan(odometry * sensor, scan, config_.limits);
  const auto root = config_.keep_trajectory ? std::make_shared<const TrajectoryNode>(odometry, nullptr) : nullptr;
  for (std::size_t i = 0; i < maps_.size(); ++i)
  {
    if (i > 0)
      maps_[i] = maps_[0];
    histories_[i] = root;
  }
  best_index_ = 0;
  return beams;
}

GridSlamStep RbpfGridSlam::step(const OdometryIncrement& u, const ScanData& scan, const Pose2& sensor)
{
  GridSlamStep step;
  scanEndPoints(scan, config_.limits, 1, &end_points_);
  const std::size_t n = particles_.size();
  const std::size_t used = (end_points_.size() + static_cast<std::size_t>(config_.matcher.beam_step) - 1) /
                           static_cast<std::size_t>(config_.matcher.beam_step);
  const double min_matched = config_.min_matched_ratio * static_cast<double>(used);
  log_weights_.resize(n);
  std::vector<int> matched(n, 0);
  // The odometry's spread for this increment (rot1 and rot2 noise both turn the heading; rot1 noise also moves
  // the end point sideways), floored: the motion factor of the weight.
  double sigma_xy = 0.0, sigma_theta = 0.0;
  {
    const OdometryNoiseSigmas s = odometryNoiseSigmas(u, config_.motion);
    sigma_xy = std::max(std::hypot(s.trans, u.trans * s.rot1), config_.matcher.prior_floor_xy);
    sigma_theta = std::max(std::hypot(s.rot1, s.rot2), config_.matcher.prior_floor_theta);
  }
  // The random draws first, in particle order: the odometry sample and the jitter around the match (drawn
  // whether or not the match is trusted), so the result does not depend on the threads.
  predicted_.resize(n);
  jitter_.resize(n);
  for (std::size_t i = 0; i < n; ++i)
  {
    predicted_[i] = sampleOdometryMotion(particles_[i].pose, u, config_.motion, random_);
    jitter_[i] = Pose2(random_.gaussian(config_.proposal_sigma_xy), random_.gaussian(config_.proposal_sigma_xy),
                       random_.gaussian(config_.proposal_sigma_theta));
  }
  // Proposal: each particle's odometry sample, scan-matched against its own map (independent per particle: read
  // only, so the matches may run on several threads).
  matches_.resize(n);
  trusted_.assign(n, 0);
  const auto match_range = [&](std::size_t first, std::size_t stride) {
    for (std::size_t i = first; i < n; i += stride)
    {
      matches_[i] = matcher_.match(maps_[i], predicted_[i], sensor, end_points_);
      trusted_[i] = used > 0 && static_cast<double>(matches_[i].matched) >= min_matched;
      if (!trusted_[i])  // weighed at the odometry sample, which the particle keeps
      {
        const int evaluations = matches_[i].evaluations;
        matches_[i] = matcher_.evaluate(maps_[i], predicted_[i], sensor, end_points_);
        matches_[i].evaluations += evaluations;
      }
    }
  };
  const std::size_t threads = std::min<std::size_t>(static_cast<std::size_t>(config_.threads), n);
  if (threads <= 1)
    match_range(0, 1);
  else
  {
    std::vector<std::thread> pool;
    for (std::size_t t = 1; t < threads; ++t)
      pool.emplace_back(match_range, t, threads);
    match_range(0, threads);
    for (auto& thread : pool)
      thread.join();
  }
  for (std::size_t i = 0; i < n; ++i)
  {
    GridParticle& p = particles_[i];
    const ScanMatch& m = matches_[i];
    step.matcher_evaluations += m.evaluations;
    // The pose: a small Gaussian around a trusted match (the weight is the likelihood at the match, GMapping's
    // "best score" normaliser), else the odometry sample itself.
    Pose2 pose = predicted_[i];
    if (trusted_[i])
    {
      pose = Pose2(m.pose.x + jitter_[i].x, m.pose.y + jitter_[i].y, wrapAngle(m.pose.theta + jitter_[i].theta));
      ++step.matches_trusted;
    }
    double motion_log = 0.0;
    if (config_.proposal_motion_weight > 0.0)
    {
      const Pose2 mean = applyOdometry(p.pose, u);
      const double dx = pose.x - mean.x, dy = pose.y - mean.y, dt = wrapAngle(pose.theta - mean.theta);
      motion_log = -config_.proposal_motion_weight *
                   ((dx * dx + dy * dy) / (2.0 * sigma_xy * sigma_xy) +
                    dt * dt / (2.0 * sigma_theta * sigma_theta));
    }
    p.pose = pose;
    matched[i] = m.matched;
    log_weights_[i] = p.log_weight + config_.likelihood_gain * m.log_likelihood + motion_log;
  }
  // Every particle maps with its own pose (copy-on-write clones the shared tiles it writes), before resampling:
  // once per particle, not once per copy.
  const WeightingStep w = weighParticles([&](const WeightingStep& weighed) {
    best_index_ = weighed.best;
    step.best = static_cast<int>(best_index_);
    step.best_correlation = matched[best_index_];
    mapping_pose_ = particles_[best_index_].pose;
    for (std::size_t i = 0; i < n; ++i)
    {
      const int b = maps_[i].insertScan(particles_[i].pose * sensor, scan, config_.limits);
      if (i == best_index_)
        step.beams_mapped = b;
      if (config_.keep_trajectory)
        histories_[i] = std::make_shared<const TrajectoryNode>(particles_[i].pose, std::move(histories_[i]));
    }
  });
  step.neff = w.neff;
  step.resampled = w.resampled;
  if (w.resampled)
  {
    // The estimate stays the particle that was best, if it survived (it nearly always does).
    const auto survivor = std::find(w.keep.begin(), w.keep.end(), static_cast<int>(best_index_));
    applyResampling(&maps_, w.keep);  // copies tile pointers only
    applyResampling(&histories_, w.keep);
    best_index_ = survivor != w.keep.end() ? static_cast<std::size_t>(survivor - w.keep.begin()) : 0;
    if (survivor == w.keep.end())
      mapping_pose_ = particles_[0].pose;
  }
  return step;
}

std::vector<Pose2> RbpfGridSlam::bestTrajectory() const
{
  std::vector<Pose2> poses;
  if (histories_.empty())
    return poses;
  for (const TrajectoryNode* node = histories_[best_index_].get(); node; node = node->parent.get())
    poses.push_back(node->value);
  std::reverse(poses.begin(), poses.end());
  return poses;
}

}  // namespace core
}  // namespace rbpf_slam
