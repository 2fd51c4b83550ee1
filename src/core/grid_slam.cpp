#include "rbpf_slam/core/grid_slam.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace rbpf_slam
{
namespace core
{
bool parseGridSlamMode(const std::string& name, GridSlamMode* mode)
{
  if (name == "course")
  {
    *mode = GridSlamMode::kCourse;
    return true;
  }
  return false;
}

std::string GridSlamConfig::validate() const
{
  if (particles <= 0)
    return "particles must be > 0";
  if (!(std::isfinite(resample_neff_ratio) && resample_neff_ratio >= 0.0 && resample_neff_ratio <= 1.0))
    return "resample_neff_ratio must be in [0, 1]";
  if (!(std::isfinite(correlation_gain) && correlation_gain >= 0.0))
    return "correlation_gain must be >= 0";
  if (score_beam_step < 1)
    return "score_beam_step must be >= 1";
  std::string e = motion.validate();
  if (e.empty())
    e = grid.validate();
  if (e.empty())
    e = limits.validate();
  return e;
}

GridSlam::GridSlam(const GridSlamConfig& config) : config_(config), random_(config.seed), map_(config.grid)
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
  initialised_ = false;
  last_odometry_ = Pose2();
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

GridSlamStep GridSlam::update(const Pose2& odometry, const ScanData& scan, const Pose2& sensor)
{
  GridSlamStep step;
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
    step.beams_mapped = map_.insertScan(odometry * sensor, scan, config_.limits);
    return step;
  }
  // Prediction: every particle takes the odometry increment with its own noise.
  const OdometryIncrement u = decomposeOdometry(last_odometry_, odometry);
  last_odometry_ = odometry;
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

}  // namespace core
}  // namespace rbpf_slam
