#ifndef RBPF_SLAM_CORE_GRID_SLAM_H
#define RBPF_SLAM_CORE_GRID_SLAM_H

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rbpf_slam/core/history_chain.h"
#include "rbpf_slam/core/occupancy_grid.h"
#include "rbpf_slam/core/particle_filter.h"
#include "rbpf_slam/core/pose2.h"
#include "rbpf_slam/core/random.h"
#include "rbpf_slam/core/scan_matcher.h"

namespace rbpf_slam
{
namespace core
{
/**
 * @brief The grid SLAM methods: `course` (one map, the best particle maps) and `rbpf` (
 * GMapping-like, each particle owns its map, scan-matched proposal, likelihood-field weights).
 */
enum class GridSlamMode
{
  kCourse,
  kRbpf
};
bool parseGridSlamMode(const std::string& name, GridSlamMode* mode);

/** @brief Configuration of GridSlam; defaults are the course's method (see README "Grid SLAM"). */
struct GridSlamConfig
{
  GridSlamMode mode = GridSlamMode::kCourse;
  /// Upper bound of `particles`: each particle owns a map (tens of MB apiece on a building in rbpf mode).
  static constexpr int kMaxParticles = 5000;
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
  /// `rbpf` mode only: the scan matcher / likelihood field (see ScanMatcherConfig).
  ScanMatcherConfig matcher;
  /// `rbpf` mode only: log-weight gain on the likelihood-field log-likelihood. GMapping divides its
  /// log-likelihood by the number of particles (its default 30) to keep the weights from collapsing.
  double likelihood_gain = 1.0 / 30.0;
  /// `rbpf` mode only: standard deviations [m, rad] of the Gaussian the pose is drawn from around the match.
  double proposal_sigma_xy = 0.005;
  double proposal_sigma_theta = 0.002;
  /// `rbpf` mode only: a match with fewer than this fraction of the end points matched is not trusted (the
  /// particle keeps its odometry sample, weighted at that pose).
  double min_matched_ratio = 0.3;
  /// `rbpf` mode only: the proposal's normaliser includes the motion model (Grisetti et al. 2007: the weight is
  /// the integral of p(z | x) p(x | x', u)): the log-weight also gains w * log N(match; odometry mean, motion
  /// covariance of the increment), so a match far from where the odometry puts the particle counts less.
  /// 0 = off (GMapping's code weighs by the likelihood at the match only).
  double proposal_motion_weight = 0.0;
  /// Travel thresholds (GMapping's linearUpdate / angularUpdate / temporalUpdate): a scan is processed only
  /// after the odometry has moved this far [m] or turned this much [rad] since the last processed scan, or
  /// (temporal_update > 0) this much time [s] has passed; the first scan is always processed. A standing robot
  /// then adds nothing to the map or the particles, and a fast scanner costs less. 0 / 0 / 0: every scan.
  double linear_update = 0.1;
  double angular_update = 0.05;
  double temporal_update = 0.0;
  /// `rbpf` mode: keep every particle's history (bestTrajectory(), the smoothed path); memory grows with the
  /// scans processed. A node that never asks for it turns it off.
  bool keep_trajectory = true;

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
  bool skipped = false;      ///< below the travel thresholds: nothing changed (mappingPose() is still the last one)
  double neff = 0.0;         ///< before resampling
  bool resampled = false;
  int best = 0;                ///< index of the particle whose pose updated the map (before resampling)
  int best_correlation = 0;    ///< its number of end points on occupied cells (rbpf: matched end points)
  int beams_mapped = 0;
  int matches_trusted = 0;     ///< rbpf mode: particles whose scan match was trusted
  long matcher_evaluations = 0;  ///< rbpf mode: poses scored by the scan matcher, all particles (cost diagnostic)
};

/**
 * @brief Grid SLAM. `rbpf` mode: every particle owns its map (copy-on-write by tiles: copying a particle copies
 * tile pointers, a scan clones only the tiles it writes); each particle's pose is sampled from the odometry
 * motion model, refined by hill-climbing scan matching against its own map, then drawn from a small Gaussian
 * around the match; its log-weight grows by likelihood_gain times the likelihood-field log-likelihood at the
 * match (GMapping's approximation of the proposal's normaliser); Neff < ratio * N resamples; every particle
 * inserts the scan in its own map; the best particle (largest weight) is the estimate.
 *
 * Course mode ("Odometry Based Mapping"): one log-odds map; each particle's pose moves by
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
   * @brief One scan: @p odometry is the robot's odometry pose at the scan's stamp [s] @p stamp (used by
   * temporal_update only), @p sensor the scanner's pose on the robot (base frame). Below the travel thresholds
   * nothing changes (step.skipped). @throws std::invalid_argument on a non-finite pose.
   * Non-finite scan angles throw std::invalid_argument too (nothing changes then). @throws std::out_of_range
   * (OccupancyGrid) when the scan reaches cells too far away for any map.
   */
  GridSlamStep update(const Pose2& odometry, const ScanData& scan, const Pose2& sensor, double stamp = 0.0);

  /**
   * @brief The robot's pose in the map at odometry pose @p odometry: the mapping pose carried by the odometry
   * travelled since the last processed scan (that pose itself when @p odometry is the last processed one).
   */
  Pose2 poseAt(const Pose2& odometry) const { return mapping_pose_ * (last_odometry_.inverse() * odometry); }

  /** @brief Forgets everything (map, particles); the next scan starts a new map. Same seed as built. */
  void reset();

  bool initialised() const { return initialised_; }
  const std::vector<GridParticle>& particles() const { return particles_; }
  /** @brief The particle with the largest weight. */
  const GridParticle& best() const;
  /**
   * @brief The particle whose pose last updated the map (before any resampling) - its pose. In rbpf mode, the
   * best particle's pose (largest weight at the last update).
   */
  const Pose2& mappingPose() const { return mapping_pose_; }
  /** @brief The map: course mode's one map; in rbpf mode the best particle's (the one of mappingPose()). */
  const OccupancyGrid& map() const
  {
    return config_.mode == GridSlamMode::kRbpf && !maps_.empty() ? maps_[best_index_] : map_;
  }
  /** @brief rbpf mode: particle @p i's map (course mode: the one map). */
  const OccupancyGrid& particleMap(std::size_t i) const
  {
    return config_.mode == GridSlamMode::kRbpf ? maps_.at(i) : map_;
  }
  /**
   * @brief rbpf mode: the poses of the best particle's history, one per update() since the first scan (its
   * ancestors' poses before resampling); course mode: empty.
   */
  std::vector<Pose2> bestTrajectory() const;
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
  GridSlamStep updateRbpf(const OdometryIncrement& u, const ScanData& scan, const Pose2& sensor);
  /** @brief A pose of a particle's history; ancestors shared between particles, released iteratively. */
  using TrajectoryNode = HistoryNode<Pose2>;

  GridSlamConfig config_;
  Random random_;
  std::vector<GridParticle> particles_;
  std::vector<double> log_weights_, weights_;
  OccupancyGrid map_;
  bool initialised_ = false;
  Pose2 last_odometry_;  ///< of the last processed scan
  double last_stamp_ = 0.0;
  Pose2 mapping_pose_;
  std::vector<std::pair<double, double>> end_points_;
  // rbpf mode
  ScanMatcher matcher_;
  std::vector<OccupancyGrid> maps_;  // one per particle
  std::vector<std::shared_ptr<const TrajectoryNode>> histories_;
  std::size_t best_index_ = 0;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_GRID_SLAM_H
