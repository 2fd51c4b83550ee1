#include "rbpf_slam/core/grid/grid_slam.h"

#include "rbpf_slam/core/grid/rbpf_grid_slam.h"
#include "rbpf_slam/core/grid/single_map_grid_slam.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <unordered_set>

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
  if (name == "single_map")
    *mode = GridSlamMode::kSingleMap;
  else if (name == "rbpf")
    *mode = GridSlamMode::kRbpf;
  else
    return false;
  return true;
}

const char* gridSlamModeName(GridSlamMode mode)
{
  return mode == GridSlamMode::kRbpf ? "rbpf" : "single_map";
}

std::string GridSlamConfig::validate() const
{
  if (!(std::isfinite(linear_update) && linear_update >= 0.0) || !(std::isfinite(angular_update) && angular_update >= 0.0) ||
      !std::isfinite(temporal_update))
    return "linear_update and angular_update must be >= 0, temporal_update finite (<= 0: off)";
  if (threads < 1 || threads > 64)
    return "threads must be in 1..64, not " + std::to_string(threads);
  if (particles < 1 || particles > kMaxParticles)
    return "particles must be in 1.." + std::to_string(kMaxParticles) + ", not " + std::to_string(particles);
  const std::string r = resampling.validate();
  if (!r.empty())
    return r;
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
  if (!(std::isfinite(odometry_veto) && odometry_veto >= 0.0))
    return "odometry_veto must be >= 0 (0 = off)";
  if (!(std::isfinite(veto_information_gain) && veto_information_gain >= 0.0))
    return "veto_information_gain must be >= 0 (0 = off)";
  std::string e = motion.validate();
  if (e.empty())
    e = matcher.validate();
  if (e.empty())
    e = grid.validate();
  if (e.empty())
    e = limits.validate();
  return e;
}

std::unique_ptr<GridSlam> GridSlam::create(const GridSlamConfig& config)
{
  if (config.mode == GridSlamMode::kRbpf)
    return std::unique_ptr<GridSlam>(new RbpfGridSlam(config));
  return std::unique_ptr<GridSlam>(new SingleMapGridSlam(config));
}

GridSlam::GridSlam(const GridSlamConfig& config) : config_(config), random_(config.seed)
{
  const std::string e = config_.validate();
  if (!e.empty())
    throw std::invalid_argument("grid SLAM: " + e);
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
  resetMaps();
  initialised_ = false;
  last_odometry_ = Pose2();
  seen_odometry_ = Pose2();
  last_scan_increment_ = OdometryIncrement();
  last_stamp_ = 0.0;
  mapping_pose_ = Pose2();
}

GridMapMemory GridSlam::mapMemory() const
{
  GridMapMemory m;
  m.particles = static_cast<int>(particles_.size());
  std::unordered_set<const OccupancyGrid::Tile*> seen;
  for (std::size_t i = 0; i < particles_.size(); ++i)
  {
    const OccupancyGrid& g = particleMap(i);
    for (int ty = g.tileY0(); ty < g.tileY0() + g.tilesY(); ++ty)
      for (int tx = g.tileX0(); tx < g.tileX0() + g.tilesX(); ++tx)
      {
        const OccupancyGrid::Tile* t = g.tileAt(tx, ty);
        if (t != nullptr && seen.insert(t).second)
          m.bytes += OccupancyGrid::tileBytes(*t);
      }
  }
  m.tiles = seen.size();
  if (!particles_.empty())
  {
    m.best_tiles = map().tileCount();
    m.best_area = static_cast<double>(m.best_tiles) * map().tileArea();
  }
  return m;
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
  if (initialised_)
  {
    const OdometryIncrement moved = decomposeOdometry(last_odometry_, odometry);
    const double turned = std::fabs(wrapAngle(odometry.theta - last_odometry_.theta));
    const bool travelled = moved.trans >= config_.linear_update || turned >= config_.angular_update;
    const bool waited = config_.temporal_update > 0.0 && stamp - last_stamp_ >= config_.temporal_update;
    if (!travelled && !waited && (config_.linear_update > 0.0 || config_.angular_update > 0.0))
    {
      carry(decomposeOdometry(seen_odometry_, odometry));
      seen_odometry_ = odometry;
      GridSlamStep skipped;
      skipped.skipped = true;
      skipped.neff = weights_.empty() ? static_cast<double>(particles_.size()) : effectiveSampleSize(weights_);
      return skipped;
    }
  }
  last_stamp_ = stamp;
  if (!initialised_)
  {
    // The map frame coincides with the odometry frame at the first scan (map -> odom starts as the identity,
    // as REP-105 tools expect): every particle starts at the first odometry pose.
    initialised_ = true;
    last_odometry_ = odometry;
    seen_odometry_ = odometry;
    mapping_pose_ = odometry;
    for (auto& p : particles_)
      p.pose = odometry;
    GridSlamStep first;
    first.initialised = true;
    first.neff = static_cast<double>(particles_.size());
    first.beams_mapped = startMaps(odometry, scan, sensor);
    return first;
  }
  const OdometryIncrement u = decomposeOdometry(last_odometry_, odometry);
  last_scan_increment_ = decomposeOdometry(seen_odometry_, odometry);
  last_odometry_ = odometry;
  seen_odometry_ = odometry;
  return step(u, scan, sensor);
}

WeightingStep GridSlam::weighParticles(const std::function<void(const WeightingStep&)>& before_resampling)
{
  const auto set_weights = [this, &before_resampling](const WeightingStep& w) {
    for (std::size_t i = 0; i < particles_.size(); ++i)
    {
      particles_[i].log_weight = log_weights_[i];
      particles_[i].weight = weights_[i];
    }
    if (before_resampling)
      before_resampling(w);
  };
  WeightingStep w = weighAndResample(&log_weights_, &weights_, config_.resampling, random_, set_weights);
  if (w.resampled)
  {
    applyResampling(&particles_, w.keep);
    for (std::size_t i = 0; i < particles_.size(); ++i)
    {
      particles_[i].log_weight = log_weights_[i];
      particles_[i].weight = weights_[i];
    }
  }
  return w;
}

PoseMoments GridSlam::cloudMoments(const Pose2& odometry) const
{
  std::vector<Pose2> poses;
  std::vector<double> weights;
  poses.reserve(particles_.size());
  weights.reserve(particles_.size());
  const Pose2 since = last_odometry_.inverse() * odometry;
  for (const auto& p : particles_)
  {
    poses.push_back(p.pose * since);
    weights.push_back(p.weight);
  }
  return poseMoments(poses, weights);
}

}  // namespace core
}  // namespace rbpf_slam
