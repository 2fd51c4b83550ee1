#include "rbpf_slam/core/grid_slam.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace rbpf_slam
{
namespace core
{
namespace
{
/** Throws std::invalid_argument naming @p what unless @p pose is finite. */
void requireFinite(const Pose2& pose, const char* what)
{
  if (std::isfinite(pose.x) && std::isfinite(pose.y) && std::isfinite(pose.theta))
    return;
  throw std::invalid_argument(std::string("grid SLAM: the ") + what + " pose is not finite (x " +
                              std::to_string(pose.x) + ", y " + std::to_string(pose.y) + ", theta " +
                              std::to_string(pose.theta) + "): scan not used");
}
}  // namespace

bool parseGridSlamMode(const std::string& name, GridSlamMode* mode)
{
  if (name == "course")
  {
    *mode = GridSlamMode::kCourse;
    return true;
  }
  if (name == "rbpf")
  {
    *mode = GridSlamMode::kRbpf;
    return true;
  }
  return false;
}

std::string GridSlamConfig::validate() const
{
  if (!(std::isfinite(linear_update) && linear_update >= 0.0) || !(std::isfinite(angular_update) && angular_update >= 0.0) ||
      !std::isfinite(temporal_update))
    return "linear_update and angular_update must be >= 0, temporal_update finite (<= 0: off)";
  if (particles < 1 || particles > kMaxParticles)
    return "particles must be in 1.." + std::to_string(kMaxParticles) + ", not " + std::to_string(particles);
  if (!(std::isfinite(resample_neff_ratio) && resample_neff_ratio >= 0.0 && resample_neff_ratio <= 1.0))
    return "resample_neff_ratio must be in [0, 1]";
  if (!(std::isfinite(correlation_gain) && correlation_gain >= 0.0))
    return "correlation_gain must be >= 0";
  if (score_beam_step < 1)
    return "score_beam_step must be >= 1";
  if (!(std::isfinite(likelihood_gain) && likelihood_gain >= 0.0))
    return "likelihood_gain must be >= 0";
  if (!(std::isfinite(proposal_sigma_xy) && proposal_sigma_xy >= 0.0))
    return "proposal_sigma_xy must be >= 0";
  if (!(std::isfinite(proposal_sigma_theta) && proposal_sigma_theta >= 0.0))
    return "proposal_sigma_theta must be >= 0";
  if (!(std::isfinite(min_matched_ratio) && min_matched_ratio >= 0.0 && min_matched_ratio <= 1.0))
    return "min_matched_ratio must be in [0, 1]";
  if (!(std::isfinite(proposal_motion_weight) && proposal_motion_weight >= 0.0))
    return "proposal_motion_weight must be >= 0";
  std::string e = motion.validate();
  if (e.empty())
    e = matcher.validate();
  if (e.empty())
    e = grid.validate();
  if (e.empty())
    e = limits.validate();
  return e;
}

GridSlam::GridSlam(const GridSlamConfig& config)
  : config_(config), random_(config.seed), map_(config.grid), matcher_(config.matcher)
{
  const std::string e = config_.validate();
  if (!e.empty())
    throw std::invalid_argument("grid SLAM: " + e);
  reset();
}

void GridSlam::reset()
{
  random_.seed(config_.seed);
  const std::size_t n = static_cast<std::size_t>(config_.particles);
  particles_.assign(n, GridParticle());
  for (auto& p : particles_)
  {
    p.weight = 1.0 / static_cast<double>(n);
    p.log_weight = std::log(p.weight);
  }
  map_ = OccupancyGrid(config_.grid);
  maps_.clear();
  histories_.clear();
  if (config_.mode == GridSlamMode::kRbpf)
  {
    maps_.assign(n, OccupancyGrid(config_.grid));
    histories_.assign(n, nullptr);
  }
  best_index_ = 0;
  initialised_ = false;
  last_odometry_ = Pose2();
  last_stamp_ = 0.0;
  mapping_pose_ = Pose2();
}

const GridParticle& GridSlam::best() const
{
  return *std::max_element(particles_.begin(), particles_.end(),
                           [](const GridParticle& a, const GridParticle& b) { return a.weight < b.weight; });
}

void GridSlam::scanEndPoints(const ScanData& scan, const ScanLimits& limits, int step,
                             std::vector<std::pair<double, double>>* end_points)
{
  end_points->clear();
  for (std::size_t i = 0; i < scan.ranges.size(); i += static_cast<std::size_t>(step))
  {
    double length = 0.0;
    if (classifyBeam(scan.ranges[i], scan, limits, &length) != BeamKind::kHit)
      continue;
    const double a = scan.angle_min + static_cast<double>(i) * scan.angle_increment;
    end_points->emplace_back(length * std::cos(a), length * std::sin(a));
  }
}

int GridSlam::correlation(const OccupancyGrid& map, const Pose2& pose, const Pose2& sensor,
                          const std::vector<std::pair<double, double>>& end_points)
{
  const Pose2 s = pose * sensor;
  const double c = std::cos(s.theta), si = std::sin(s.theta);
  int count = 0;
  for (const auto& e : end_points)
  {
    int ix, iy;
    map.cellOf(s.x + c * e.first - si * e.second, s.y + si * e.first + c * e.second, &ix, &iy);
    count += map.occupied(ix, iy) ? 1 : 0;
  }
  return count;
}

GridSlamStep GridSlam::update(const Pose2& odometry, const ScanData& scan, const Pose2& sensor, double stamp)
{
  // Checked before anything changes: a non-finite pose would spread to every particle and turn into cell
  // indices far outside any map.
  requireFinite(odometry, "odometry");
  requireFinite(sensor, "sensor");
  if (!std::isfinite(scan.angle_min) || !std::isfinite(scan.angle_increment))
    throw std::invalid_argument("grid SLAM: the scan's angle_min or angle_increment is not finite: scan not used");
  GridSlamStep step;
  if (initialised_)
  {
    const OdometryIncrement moved = decomposeOdometry(last_odometry_, odometry);
    const double turned = std::fabs(wrapAngle(odometry.theta - last_odometry_.theta));
    const bool travelled = moved.trans >= config_.linear_update || turned >= config_.angular_update;
    const bool waited = config_.temporal_update > 0.0 && stamp - last_stamp_ >= config_.temporal_update;
    if (!travelled && !waited && (config_.linear_update > 0.0 || config_.angular_update > 0.0))
    {
      step.skipped = true;
      step.neff = weights_.empty() ? static_cast<double>(particles_.size()) : effectiveSampleSize(weights_);
      return step;
    }
  }
  last_stamp_ = stamp;
  if (!initialised_)
  {
    // The map frame coincides with the odometry frame at the first scan (map -> odom starts as the identity,
    // as REP-105 tools expect): every particle starts at the first odometry pose.
    initialised_ = true;
    last_odometry_ = odometry;
    mapping_pose_ = odometry;
    for (auto& p : particles_)
      p.pose = odometry;
    step.initialised = true;
    step.neff = static_cast<double>(particles_.size());
    if (config_.mode == GridSlamMode::kRbpf)
    {
      // One map for all: the others share its tiles until they write.
      step.beams_mapped = maps_[0].insertScan(odometry * sensor, scan, config_.limits);
      const auto root = config_.keep_trajectory ? std::make_shared<const TrajectoryNode>(odometry, nullptr) : nullptr;
      for (std::size_t i = 0; i < maps_.size(); ++i)
      {
        if (i > 0)
          maps_[i] = maps_[0];
        histories_[i] = root;
      }
      best_index_ = 0;
    }
    else
      step.beams_mapped = map_.insertScan(odometry * sensor, scan, config_.limits);
    return step;
  }
  const OdometryIncrement u = decomposeOdometry(last_odometry_, odometry);
  last_odometry_ = odometry;
  if (config_.mode == GridSlamMode::kRbpf)
    return updateRbpf(u, scan, sensor);
  // Prediction: every particle takes the odometry increment with its own noise.
  for (auto& p : particles_)
    p.pose = sampleOdometryMotion(p.pose, u, config_.motion, random_);

  // Correction: correlation of each particle's end points with the one map, softmax-normalised.
  scanEndPoints(scan, config_.limits, config_.score_beam_step, &end_points_);
  const std::size_t n = particles_.size();
  log_weights_.resize(n);
  std::vector<int> corr(n);
  for (std::size_t i = 0; i < n; ++i)
  {
    corr[i] = correlation(map_, particles_[i].pose, sensor, end_points_);
    log_weights_[i] = particles_[i].log_weight + config_.correlation_gain * corr[i];
  }
  normalizeLogWeights(&log_weights_, &weights_);
  for (std::size_t i = 0; i < n; ++i)
  {
    particles_[i].log_weight = log_weights_[i];
    particles_[i].weight = weights_[i];
  }
  step.best = static_cast<int>(std::max_element(weights_.begin(), weights_.end()) - weights_.begin());
  step.best_correlation = corr[static_cast<std::size_t>(step.best)];
  mapping_pose_ = particles_[static_cast<std::size_t>(step.best)].pose;

  // Mapping with the best particle's pose.
  step.beams_mapped = map_.insertScan(mapping_pose_ * sensor, scan, config_.limits);

  step.neff = effectiveSampleSize(weights_);
  if (step.neff < config_.resample_neff_ratio * static_cast<double>(n))
  {
    const std::vector<int> keep = resample(weights_, config_.resampling, random_);
    std::vector<GridParticle> next(n);
    for (std::size_t i = 0; i < n; ++i)
    {
      next[i].pose = particles_[static_cast<std::size_t>(keep[i])].pose;
      next[i].weight = 1.0 / static_cast<double>(n);
      next[i].log_weight = std::log(next[i].weight);
    }
    particles_.swap(next);
    step.resampled = true;
  }
  return step;
}

GridSlamStep GridSlam::updateRbpf(const OdometryIncrement& u, const ScanData& scan, const Pose2& sensor)
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
  // the end point sideways), floored: the matcher's motion prior and the motion factor of the weight.
  MatchPrior prior;
  {
    const OdometryNoiseSigmas s = odometryNoiseSigmas(u, config_.motion);
    prior.sigma_xy = std::max(std::hypot(s.trans, u.trans * s.rot1), config_.matcher.prior_floor_xy);
    prior.sigma_theta = std::max(std::hypot(s.rot1, s.rot2), config_.matcher.prior_floor_theta);
  }
  for (std::size_t i = 0; i < n; ++i)
  {
    GridParticle& p = particles_[i];
    // Proposal: odometry sample, scan-matched against the particle's own map, then a small Gaussian around the
    // match. The weight is the likelihood at the match (GMapping's "best score" normaliser).
    const Pose2 predicted = sampleOdometryMotion(p.pose, u, config_.motion, random_);
    prior.centre = predicted;
    ScanMatch m = matcher_.match(maps_[i], predicted, sensor, end_points_, &prior);
    step.matcher_evaluations += m.evaluations;
    Pose2 pose;
    if (used > 0 && static_cast<double>(m.matched) >= min_matched)
    {
      pose = Pose2(m.pose.x + random_.gaussian(config_.proposal_sigma_xy),
                   m.pose.y + random_.gaussian(config_.proposal_sigma_xy),
                   wrapAngle(m.pose.theta + random_.gaussian(config_.proposal_sigma_theta)));
      ++step.matches_trusted;
    }
    else
    {
      pose = predicted;
      m = matcher_.evaluate(maps_[i], predicted, sensor, end_points_);
    }
    double motion_log = 0.0;
    if (config_.proposal_motion_weight > 0.0)
    {
      const Pose2 mean = applyOdometry(p.pose, u);
      const double dx = pose.x - mean.x, dy = pose.y - mean.y, dt = wrapAngle(pose.theta - mean.theta);
      motion_log = -config_.proposal_motion_weight *
                   ((dx * dx + dy * dy) / (2.0 * prior.sigma_xy * prior.sigma_xy) +
                    dt * dt / (2.0 * prior.sigma_theta * prior.sigma_theta));
    }
    p.pose = pose;
    matched[i] = m.matched;
    log_weights_[i] = p.log_weight + config_.likelihood_gain * m.log_likelihood + motion_log;
  }
  normalizeLogWeights(&log_weights_, &weights_);
  for (std::size_t i = 0; i < n; ++i)
  {
    particles_[i].log_weight = log_weights_[i];
    particles_[i].weight = weights_[i];
  }
  best_index_ = static_cast<std::size_t>(std::max_element(weights_.begin(), weights_.end()) - weights_.begin());
  step.best = static_cast<int>(best_index_);
  step.best_correlation = matched[best_index_];
  mapping_pose_ = particles_[best_index_].pose;

  // Every particle maps with its own pose (copy-on-write clones the shared tiles it writes).
  for (std::size_t i = 0; i < n; ++i)
  {
    const int b = maps_[i].insertScan(particles_[i].pose * sensor, scan, config_.limits);
    if (i == best_index_)
      step.beams_mapped = b;
    if (config_.keep_trajectory)
      histories_[i] = std::make_shared<const TrajectoryNode>(particles_[i].pose, std::move(histories_[i]));
  }

  step.neff = effectiveSampleSize(weights_);
  if (step.neff < config_.resample_neff_ratio * static_cast<double>(n))
  {
    const std::vector<int> keep = resample(weights_, config_.resampling, random_);
    std::vector<GridParticle> next(n);
    std::vector<OccupancyGrid> next_maps;
    next_maps.reserve(n);
    std::vector<std::shared_ptr<const TrajectoryNode>> next_histories(n);
    std::size_t next_best = n;
    for (std::size_t i = 0; i < n; ++i)
    {
      const std::size_t k = static_cast<std::size_t>(keep[i]);
      next[i].pose = particles_[k].pose;
      next[i].weight = 1.0 / static_cast<double>(n);
      next[i].log_weight = std::log(next[i].weight);
      next_maps.push_back(maps_[k]);  // copies tile pointers only
      next_histories[i] = histories_[k];
      if (k == best_index_ && next_best == n)
        next_best = i;
    }
    particles_.swap(next);
    maps_.swap(next_maps);
    histories_.swap(next_histories);
    // The estimate stays the particle that was best, if it survived (it nearly always does).
    best_index_ = next_best < n ? next_best : 0;
    if (next_best == n)
      mapping_pose_ = particles_[0].pose;
    step.resampled = true;
  }
  return step;
}

std::vector<Pose2> GridSlam::bestTrajectory() const
{
  std::vector<Pose2> poses;
  if (config_.mode != GridSlamMode::kRbpf || histories_.empty())
    return poses;
  for (const TrajectoryNode* node = histories_[best_index_].get(); node; node = node->parent.get())
    poses.push_back(node->value);
  std::reverse(poses.begin(), poses.end());
  return poses;
}

}  // namespace core
}  // namespace rbpf_slam
