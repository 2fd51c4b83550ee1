#include "rbpf_slam/core/grid/single_map_grid_slam.h"

#include <algorithm>

namespace rbpf_slam
{
namespace core
{
SingleMapGridSlam::SingleMapGridSlam(const GridSlamConfig& config) : GridSlam(config), map_(config.grid)
{
  reset();
}

void SingleMapGridSlam::resetMaps()
{
  map_ = OccupancyGrid(config_.grid);
}

int SingleMapGridSlam::startMaps(const Pose2& odometry, const ScanData& scan, const Pose2& sensor)
{
  return map_.insertScan(odometry * sensor, scan, config_.limits);
}

GridSlamStep SingleMapGridSlam::step(const OdometryIncrement& u, const ScanData& scan, const Pose2& sensor)
{
  GridSlamStep step;
  // Prediction: every particle takes the odometry increment with its own noise.
  for (auto& p : particles_)
    p.pose = sampleOdometryMotion(p.pose, u, config_.motion, random_);

  // Correction: the correlation of each particle's end points with the one map.
  scanEndPoints(scan, config_.limits, config_.score_beam_step, &end_points_);
  const std::size_t n = particles_.size();
  log_weights_.resize(n);
  correlations_.resize(n);
  for (std::size_t i = 0; i < n; ++i)
  {
    correlations_[i] = correlation(map_, particles_[i].pose, sensor, end_points_);
    log_weights_[i] = particles_[i].log_weight + config_.correlation_gain * correlations_[i];
  }
  // Mapping with the best particle's pose, before resampling.
  const WeightingStep w = weighParticles([&](const WeightingStep& weighed) {
    step.best = static_cast<int>(weighed.best);
    step.best_correlation = correlations_[weighed.best];
    mapping_pose_ = particles_[weighed.best].pose;
    step.beams_mapped = map_.insertScan(mapping_pose_ * sensor, scan, config_.limits);
  });
  step.neff = w.neff;
  step.resampled = w.resampled;
  return step;
}

}  // namespace core
}  // namespace rbpf_slam
