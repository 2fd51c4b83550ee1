#include "rbpf_slam/core/grid/rbpf_grid_slam.h"

#include <algorithm>
#include <initializer_list>
#include <cmath>
#include <thread>

#include <Eigen/LU>

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
  carried_ = Carried();
}

RbpfGridSlam::Spread RbpfGridSlam::spreadOf(const OdometryIncrement& u) const
{
  const OdometryNoiseSigmas s = odometryNoiseSigmas(u, config_.motion);
  Spread v;
  v.along = s.trans * s.trans;
  // rot1's noise moves the end point sideways; the translation a turn causes (alpha4) has no direction of its own:
  // a turn on the spot moves the robot across as much as along.
  const double turn_trans = config_.motion.alpha4 * (std::abs(u.rot1) + std::abs(u.rot2));
  v.across = u.trans * s.rot1 * u.trans * s.rot1 + turn_trans * turn_trans;
  v.theta = s.rot1 * s.rot1 + s.rot2 * s.rot2;     // both rotations turn the heading
  return v;
}

void RbpfGridSlam::carry(const OdometryIncrement& u)
{
  // The noise of the scans' increments adds up as a random walk (as when GMapping draws every particle's motion
  // at every scan): the spread of the travel folded into the next processed scan is the sum of their variances,
  // not that of one increment as long as all of them. Nothing else changes here.
  const Spread v = spreadOf(u);
  carried_.sum.add(v);
  carried_.max_theta = std::max(carried_.max_theta, std::sqrt(v.theta));
  carried_.max_xy = std::max(carried_.max_xy, std::sqrt(v.along + v.across));
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
  carried_ = Carried();
  return beams;
}

// The odometry's spread over one step and what follows from it: the motion factor of the weight, the odometry's
// veto, the widening of the matcher's first steps.
struct RbpfGridSlam::StepSpread
{
  Spread spread;                               // the variances since the last processed scan, this one's included
  double sigma_xy, sigma_theta;                // their standard deviations, floored: the motion factor
  double veto_along, veto_across, veto_theta;  // the veto's: the motion model's and the match's own precision
  int widen;                                   // doublings of the matcher's first steps

  // The veto's covariance in the map's axes (x, y, heading) about @p mean: along and across its heading.
  Eigen::Matrix3d covariance(const Pose2& mean) const
  {
    const double c = std::cos(mean.theta), sn = std::sin(mean.theta);
    Eigen::Matrix2d r;
    r << c, -sn, sn, c;
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    cov.topLeftCorner<2, 2>() =
        r * Eigen::Vector2d(veto_along * veto_along, veto_across * veto_across).asDiagonal() * r.transpose();
    cov(2, 2) = veto_theta * veto_theta;
    return cov;
  }

  // The squared Mahalanobis distance of pose @p x from the odometry's mean @p mean.
  double odometryDistance(const Pose2& x, const Pose2& mean) const
  {
    const double dx = x.x - mean.x, dy = x.y - mean.y;
    const double c = std::cos(mean.theta), sn = std::sin(mean.theta);
    const double along = (c * dx + sn * dy) / veto_along, across = (-sn * dx + c * dy) / veto_across;
    const double turn = wrapAngle(x.theta - mean.theta) / veto_theta;
    return along * along + across * across + turn * turn;
  }
};

RbpfGridSlam::StepSpread RbpfGridSlam::stepSpread() const
{
  // The odometry's spread since the last processed scan: the skipped scans' increments and this one's (equal to
  // the whole increment's when every scan is processed). Floored, it is the motion factor of the weight and the
  // odometry's veto; its growth over one scan's widens the matcher's first steps.
  Spread spread = carried_.sum;
  const Spread v_last = spreadOf(lastScanIncrement());
  spread.add(v_last);
  const double floor_xy = config_.matcher.prior_floor_xy, floor_theta = config_.matcher.prior_floor_theta;
  const double sigma_xy = std::max(std::sqrt(spread.along + spread.across), floor_xy);
  const double sigma_theta = std::max(std::sqrt(spread.theta), floor_theta);
  // The veto's spread: the motion model's and the match's own precision (half a cell; the last climbing step).
  const double match_xy = 0.5 * config_.grid.resolution, match_theta = matcher_.lastAngularStep();
  const double veto_along = std::sqrt(spread.along + match_xy * match_xy);
  const double veto_across = std::sqrt(spread.across + match_xy * match_xy);
  const double veto_theta = std::sqrt(spread.theta + match_theta * match_theta);
  // One doubling of the first steps per doubling of the spread against one scan's largest (rounded).
  const double one_theta = std::max({ carried_.max_theta, std::sqrt(v_last.theta), floor_theta });
  const double one_xy = std::max({ carried_.max_xy, std::sqrt(v_last.along + v_last.across), floor_xy });
  const double ratio = std::max(sigma_theta / one_theta, sigma_xy / one_xy);
  const int widen =
      ratio > 1.0 ? std::min(ScanMatcher::kMaxWiden, static_cast<int>(std::floor(std::log2(ratio) + 0.5))) : 0;
  return { spread, sigma_xy, sigma_theta, veto_along, veto_across, veto_theta, widen };
}

OdometryMotionNoise RbpfGridSlam::scaledNoise(const OdometryIncrement& u, const Spread& spread) const
{
  // The odometry sample of the whole increment with the motion noise scaled to that spread: the rotation
  // alphas by the ratio of the headings' standard deviations, the translation ones by the positions' (1 when every
  // scan is processed).
  OdometryMotionNoise noise = config_.motion;
  if (carried_.sum.theta > 0.0 || carried_.sum.along > 0.0)
  {
    const Spread whole = spreadOf(u);
    const double f_theta = whole.theta > 1e-12 ? std::sqrt(spread.theta / whole.theta) : 1.0;
    const double f_trans = whole.along > 1e-12 ? std::sqrt(spread.along / whole.along) : 1.0;
    noise.alpha1 *= f_theta;
    noise.alpha2 *= f_theta;
    noise.alpha3 *= f_trans;
    noise.alpha4 *= f_trans;
  }
  return noise;
}

void RbpfGridSlam::drawSamples(const OdometryIncrement& u, const OdometryMotionNoise& noise)
{
  // The random draws first, in particle order: the odometry sample and the jitter around the match (drawn
  // whether or not the match is trusted), so the result does not depend on the threads.
  const std::size_t n = particles_.size();
  predicted_.resize(n);
  jitter_.resize(n);
  means_.resize(n);
  for (std::size_t i = 0; i < n; ++i)
  {
    predicted_[i] = sampleOdometryMotion(particles_[i].pose, u, noise, random_);
    jitter_[i] = Pose2(random_.gaussian(config_.proposal_sigma_xy), random_.gaussian(config_.proposal_sigma_xy),
                       random_.gaussian(config_.proposal_sigma_theta));
    means_[i] = applyOdometry(particles_[i].pose, u);
  }
}

void RbpfGridSlam::matchParticle(std::size_t i, const Pose2& sensor, const StepSpread& spread, std::size_t used,
                                 double min_matched)
{
  const int widen = spread.widen;
  matches_[i] = matcher_.match(maps_[i], predicted_[i], sensor, end_points_, widen);
  if (used > 0 && static_cast<double>(matches_[i].matched) >= min_matched)
    use_[i] = MatchUse::kMatch;
  if (use_[i] == MatchUse::kMatch && config_.odometry_veto > 0.0 &&
      vetoDistance(i, sensor, spread) > config_.odometry_veto)
  {
    // Vetoed: the odometry says the match cannot be where the particle went. The position falls back to the
    // odometry sample's; the heading is matched from there (walls fix it even where they fix no position),
    // unless that too is improbable.
    const int evaluations = matches_[i].evaluations;
    if (config_.veto_consensus)
    {
      refused_[i] = matches_[i];
      was_refused_[i] = 1;
    }
    matches_[i] = matcher_.match(maps_[i], predicted_[i], sensor, end_points_, widen, true);
    matches_[i].evaluations += evaluations;
    const bool turn_ok = static_cast<double>(matches_[i].matched) >= min_matched &&
                         spread.odometryDistance(matches_[i].pose, means_[i]) <= config_.odometry_veto;
    use_[i] = turn_ok ? MatchUse::kHeading : MatchUse::kVetoed;
  }
  // Not trusted, or vetoed: weighed at the odometry sample, which the particle keeps.
  if (use_[i] == MatchUse::kOdometry || use_[i] == MatchUse::kVetoed)
  {
    const int evaluations = matches_[i].evaluations;
    matches_[i] = matcher_.evaluate(maps_[i], predicted_[i], sensor, end_points_);
    matches_[i].evaluations += evaluations;
  }
}

double RbpfGridSlam::vetoDistance(std::size_t i, const Pose2& sensor, const StepSpread& spread)
{
  ScanMatch& m = matches_[i];
  const Pose2& mean = means_[i];
  if (config_.veto_information_gain <= 0.0)
    return spread.odometryDistance(m.pose, mean);
  // (S_odometry + S_match)^-1 = L_o (L_o + L_m)^-1 L_m: the match's covariance its information inverted.
  int evaluations = 0;
  const Eigen::Matrix3d info = config_.veto_information_gain *
                               matcher_.information(maps_[i], m.pose, sensor, end_points_, &evaluations);
  m.evaluations += evaluations;
  const Eigen::Vector3d delta(m.pose.x - mean.x, m.pose.y - mean.y, wrapAngle(m.pose.theta - mean.theta));
  const Eigen::Matrix3d lo = spread.covariance(mean).inverse();
  const Eigen::Matrix3d w = lo * (lo + info).inverse() * info;
  return delta.dot(0.5 * (w + w.transpose()) * delta);
}

void RbpfGridSlam::matchParticles(const Pose2& sensor, const StepSpread& spread, std::size_t used, double min_matched)
{
  const std::size_t n = particles_.size();
  // Proposal: each particle's odometry sample, scan-matched against its own map (independent per particle: read
  // only, so the matches may run on several threads).
  matches_.resize(n);
  use_.assign(n, MatchUse::kOdometry);
  refused_.resize(n);
  was_refused_.assign(n, 0);
  const auto match_range = [&](std::size_t first, std::size_t stride) {
    for (std::size_t i = first; i < n; i += stride)
      matchParticle(i, sensor, spread, used, min_matched);
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
}

int RbpfGridSlam::vetoByConsensus(const StepSpread& spread)
{
  std::vector<std::size_t> refused;
  std::size_t taken = 0;
  for (std::size_t i = 0; i < particles_.size(); ++i)
  {
    if (use_[i] == MatchUse::kMatch)
      ++taken;
    else if (was_refused_[i])
      refused.push_back(i);
  }
  if (2 * refused.size() <= taken + refused.size())
    return 0;  // not most of the trusted matches: each refused match is the particle's own
  // The common correction: the median of the refused matches' corrections, each in its particle's odometry frame.
  std::vector<double> cx, cy, ct;
  for (std::size_t i : refused)
  {
    const Pose2 c = means_[i].inverse() * refused_[i].pose;
    cx.push_back(c.x);
    cy.push_back(c.y);
    ct.push_back(wrapAngle(c.theta));
  }
  const auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const std::size_t k = v.size() / 2;
    return v.size() % 2 ? v[k] : 0.5 * (v[k - 1] + v[k]);
  };
  const Pose2 common(median(cx), median(cy), median(ct));
  int taken_now = 0;
  for (std::size_t i : refused)
  {
    if (spread.odometryDistance(refused_[i].pose, means_[i] * common) > config_.odometry_veto)
      continue;
    const int evaluations = matches_[i].evaluations;
    matches_[i] = refused_[i];
    matches_[i].evaluations = evaluations;
    use_[i] = MatchUse::kMatch;
    ++taken_now;
  }
  return taken_now;
}

void RbpfGridSlam::takeProposals(const StepSpread& spread, std::vector<int>* matched, GridSlamStep* step)
{
  const double sigma_xy = spread.sigma_xy, sigma_theta = spread.sigma_theta;
  for (std::size_t i = 0; i < particles_.size(); ++i)
  {
    GridParticle& p = particles_[i];
    const ScanMatch& m = matches_[i];
    step->matcher_evaluations += m.evaluations;
    // The pose: a small Gaussian around a trusted match (the weight is the likelihood at the match, GMapping's
    // "best score" normaliser), else the odometry sample itself.
    Pose2 pose = predicted_[i];
    step->matches_vetoed += use_[i] == MatchUse::kVetoed || use_[i] == MatchUse::kHeading ? 1 : 0;
    if (use_[i] == MatchUse::kMatch || use_[i] == MatchUse::kHeading)
    {
      pose = Pose2(m.pose.x + jitter_[i].x, m.pose.y + jitter_[i].y, wrapAngle(m.pose.theta + jitter_[i].theta));
      ++step->matches_trusted;
    }
    double motion_log = 0.0;
    if (config_.proposal_motion_weight > 0.0)
    {
      const Pose2& mean = means_[i];
      const double dx = pose.x - mean.x, dy = pose.y - mean.y, dt = wrapAngle(pose.theta - mean.theta);
      motion_log = -config_.proposal_motion_weight *
                   ((dx * dx + dy * dy) / (2.0 * sigma_xy * sigma_xy) + dt * dt / (2.0 * sigma_theta * sigma_theta));
    }
    p.pose = pose;
    (*matched)[i] = m.matched;
    log_weights_[i] = p.log_weight + config_.likelihood_gain * m.log_likelihood + motion_log;
  }
}

void RbpfGridSlam::mapAndResample(const ScanData& scan, const Pose2& sensor, const std::vector<int>& matched,
                                  GridSlamStep* step)
{
  const std::size_t n = particles_.size();
  // Every particle maps with its own pose (copy-on-write clones the shared tiles it writes), before resampling:
  // once per particle, not once per copy.
  const WeightingStep w = weighParticles([&](const WeightingStep& weighed) {
    best_index_ = weighed.best;
    step->best = static_cast<int>(best_index_);
    step->best_correlation = matched[best_index_];
    mapping_pose_ = particles_[best_index_].pose;
    for (std::size_t i = 0; i < n; ++i)
    {
      const int b = maps_[i].insertScan(particles_[i].pose * sensor, scan, config_.limits);
      if (i == best_index_)
        step->beams_mapped = b;
      if (config_.keep_trajectory)
        histories_[i] = std::make_shared<const TrajectoryNode>(particles_[i].pose, std::move(histories_[i]));
    }
  });
  step->neff = w.neff;
  step->resampled = w.resampled;
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
  const StepSpread spread = stepSpread();
  step.widen = spread.widen;
  const OdometryMotionNoise noise = scaledNoise(u, spread.spread);
  carried_ = Carried();
  drawSamples(u, noise);
  matchParticles(sensor, spread, used, min_matched);
  if (config_.veto_consensus && config_.odometry_veto > 0.0)
    step.matches_consensus = vetoByConsensus(spread);
  takeProposals(spread, &matched, &step);
  mapAndResample(scan, sensor, matched, &step);
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
