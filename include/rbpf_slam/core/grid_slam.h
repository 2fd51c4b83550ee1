#ifndef RBPF_SLAM_CORE_GRID_SLAM_H
#define RBPF_SLAM_CORE_GRID_SLAM_H

#include <cstdint>
#include <string>
#include <vector>

#include "rbpf_slam/core/occupancy_grid.h"
#include "rbpf_slam/core/particle_filter.h"
#include "rbpf_slam/core/pose2.h"
#include "rbpf_slam/core/random.h"

namespace rbpf_slam
{
namespace core
{
/** @brief The grid SLAM methods; `course` is issue 8's, `rbpf` (per-particle maps) comes later. */
enum class GridSlamMode
{
  kCourse
};
bool parseGridSlamMode(const std::string& name, GridSlamMode* mode);

/** @brief Configuration of GridSlam; defaults are the course's method (see README "Grid SLAM"). */
struct GridSlamConfig
{
  GridSlamMode mode = GridSlamMode::kCourse;
  int particles = 30;
  std::uint64_t seed = 0;
  /// Noise of each odometry increment (one per scan). An accuracy class for indoor wheel odometry on a
  /// flat floor: 5 % of a rotation, 0.01 rad per metre, 2 % of the distance; not fitted to a log.
  OdometryMotionNoise motion{ 0.05, 0.01, 0.02, 0.01 };
  ResamplingMethod resampling = ResamplingMethod::kMultinomial;  ///< the course's
  double resample_neff_ratio = 0.5;  ///< resample when Neff < ratio * particles
  /// Log-weight added per scan end point that falls on an occupied cell of the map (the correlation);
  /// the weights are the softmax of the summed correlation.
  double correlation_gain = 1.0;
  int score_beam_step = 1;  ///< use every n-th beam for the correlation (1 = all)
  OccupancyGridConfig grid;
  ScanLimits limits;

  /** @brief Empty when valid, else a message naming the bad parameter. */
  std::string validate() const;
};

struct GridParticle
{
  Pose2 pose;
  double log_weight = 0.0;
  double weight = 0.0;
};

/** @brief What one update did, for diagnostics and tests. */
struct GridSlamStep
{
  bool initialised = false;  ///< the first scan: the map was started, nothing else
  double neff = 0.0;         ///< before resampling
  bool resampled = false;
  int best = 0;                ///< index of the particle whose pose updated the map (before resampling)
  int best_correlation = 0;    ///< its number of end points on occupied cells
  int beams_mapped = 0;
};

/**
 * @brief Grid SLAM, course mode ("Odometry Based Mapping"): one log-odds map; each particle's pose moves by
 * the odometry increment with rot1-trans-rot2 noise; the weights grow by the correlation of the particle's
 * scan end points with the map (softmax normalisation); Neff < ratio * N resamples; the best particle's pose
 * updates the map. The map frame is the odometry frame as it was at the first scan (the particles start at the
 * first odometry pose).
 */
class GridSlam
{
public:
  /** @throws std::invalid_argument when config.validate() reports a problem. */
  explicit GridSlam(const GridSlamConfig& config);

  /**
   * @brief One scan: @p odometry is the robot's odometry pose at the scan's stamp, @p sensor the scanner's
   * pose on the robot (base frame).
   */
  GridSlamStep update(const Pose2& odometry, const ScanData& scan, const Pose2& sensor);

  /** @brief Forgets everything (map, particles); the next scan starts a new map. Same seed as built. */
  void reset();

  bool initialised() const { return initialised_; }
  const std::vector<GridParticle>& particles() const { return particles_; }
  /** @brief The particle with the largest weight. */
  const GridParticle& best() const;
  /** @brief The particle whose pose last updated the map (before any resampling) - its pose. */
  const Pose2& mappingPose() const { return mapping_pose_; }
  const OccupancyGrid& map() const { return map_; }
  const GridSlamConfig& config() const { return config_; }
  /** @brief The odometry pose of the last scan. */
  const Pose2& lastOdometry() const { return last_odometry_; }

  /**
   * @brief The correlation of a scan taken from robot pose @p pose with @p map: the number of end points (of
   * every score_beam_step-th hit beam) that fall on occupied cells.
   */
  static int correlation(const OccupancyGrid& map, const Pose2& pose, const Pose2& sensor,
                         const std::vector<std::pair<double, double>>& end_points);
  /** @brief The end points of the hit beams in the sensor frame (every @p step-th beam). */
  static void scanEndPoints(const ScanData& scan, const ScanLimits& limits, int step,
                            std::vector<std::pair<double, double>>* end_points);

private:
  GridSlamConfig config_;
  Random random_;
  std::vector<GridParticle> particles_;
  std::vector<double> log_weights_, weights_;
  OccupancyGrid map_;
  bool initialised_ = false;
  Pose2 last_odometry_;
  Pose2 mapping_pose_;
  std::vector<std::pair<double, double>> end_points_;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_GRID_SLAM_H
