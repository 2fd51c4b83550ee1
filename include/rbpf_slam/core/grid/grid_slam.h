#ifndef RBPF_SLAM_CORE_GRID_GRID_SLAM_H
#define RBPF_SLAM_CORE_GRID_GRID_SLAM_H

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "rbpf_slam/core/grid/occupancy_grid.h"
#include "rbpf_slam/core/filter/particle_filter.h"
#include "rbpf_slam/core/filter/pose2.h"
#include "rbpf_slam/core/filter/random.h"
#include "rbpf_slam/core/grid/scan_matcher.h"

namespace rbpf_slam
{
namespace core
{
/**
 * @brief The grid SLAM methods: `single_map` (one map, written from the best particle's pose; particles weighted
 * by the correlation of their scan with it) and `rbpf` (GMapping-like: each particle owns its map, scan-matched
 * proposal, likelihood-field weights).
 */
enum class GridSlamMode
{
  kSingleMap,
  kRbpf
};
/** @brief "single_map" or "rbpf"; false (and @p mode unchanged) for anything else. */
bool parseGridSlamMode(const std::string& name, GridSlamMode* mode);
const char* gridSlamModeName(GridSlamMode mode);

/** @brief Configuration of GridSlam; the defaults are those of the single-map method. */
struct GridSlamConfig
{
  GridSlamMode mode = GridSlamMode::kSingleMap;
  /// Upper bound of `particles`: each particle owns a map (tens of MB apiece on a building in rbpf mode).
  static constexpr int kMaxParticles = 5000;
  int particles = 30;
  /// `rbpf` mode: threads that scan-match the particles (each particle's match is independent; the random draws
  /// are made before, in particle order, so any number of threads gives the same result). 1 = none started.
  int threads = 1;
  std::uint64_t seed = 0;
  /// Noise of each odometry increment (one per scan). An accuracy class for indoor wheel odometry on a
  /// flat floor: 5 % of a rotation, 0.01 rad per metre, 2 % of the distance; not fitted to a log.
  OdometryMotionNoise motion{ 0.05, 0.01, 0.02, 0.01 };
  /// Multinomial resampling when Neff < resample_neff_ratio * particles (rbpf's configuration takes low-variance).
  ResamplingPolicy resampling{ ResamplingMethod::kMultinomial, 0.5 };
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
  /// `rbpf` mode only: the odometry's veto. A trusted match whose pose is improbable under the motion model of the
  /// odometry travelled since the last processed scan is not taken: the particle keeps its odometry sample, weighed
  /// there. Improbable: its squared Mahalanobis distance from the odometry's mean (along the motion, across it, the
  /// heading; each variance the motion model's plus the match's own precision, half a cell and the matcher's last
  /// heading step) beyond this bound. The position then falls back to the odometry sample's and only the heading
  /// is matched (unless that too is beyond the bound: then the odometry sample, weighed there). 100 = ten standard
  /// deviations: a gate for gross errors, as real odometry has heavy tails (slip, gaps in the log) that the
  /// Gaussian class does not hold. 0 = off.
  double odometry_veto = 100.0;
  /// `rbpf` mode only: > 0: the odometry's veto counts the match's own uncertainty, its information
  /// (ScanMatcher::information) times this gain inverted, beside the motion model's: a correction in a direction
  /// the scan fixes poorly is not refused. 0 = the match's precision only (half a cell, the last heading step).
  double veto_information_gain = 0.0;
  /// `rbpf` mode only: the veto measured from the particles' common correction when it refuses most matches. The
  /// odometry is one measurement for all particles: when more than half of the particles' trusted matches are
  /// beyond the veto, the scan says the odometry itself is wrong (a slip, a jolt: beyond what its model holds). The
  /// common correction is the median of those matches' corrections (in each particle's odometry frame); a vetoed
  /// match within the veto of its odometry mean moved by it is taken. A match refused alone stays refused.
  bool veto_consensus = false;
  /// Travel thresholds (GMapping's linearUpdate / angularUpdate / temporalUpdate, with GMapping's defaults 1 m,
  /// 0.5 rad, off): a scan is processed only after the odometry has moved this far [m] or turned this much [rad]
  /// since the last processed scan, or (temporal_update > 0) this much time [s] has passed; the first scan is
  /// always processed. A standing robot then adds nothing to the map or the particles (and no memory), and a
  /// fast scanner costs less. 0 / 0 / 0: every scan.
  double linear_update = 1.0;
  double angular_update = 0.5;
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
  int matches_vetoed = 0;      ///< rbpf mode: particles whose match the odometry vetoed (GridSlamConfig::odometry_veto)
  int matches_consensus = 0;   ///< rbpf mode: of the vetoed, taken with the common correction (veto_consensus)
  int widen = 0;               ///< rbpf mode: doublings of the matcher's first steps for the travel folded in
  long matcher_evaluations = 0;  ///< rbpf mode: poses scored by the scan matcher, all particles (cost diagnostic)
};

/**
 * @brief What the maps of all particles hold in memory (GridSlam::mapMemory()). Per-particle maps share tiles
 * copy-on-write: a tile held by several particles counts once. Counted: each tile's storage (OccupancyGrid::Tile
 * and its hit_at cells when kept); not counted: each map's table of tile pointers and the allocator's overhead.
 */
struct GridMapMemory
{
  std::size_t tiles = 0;       ///< distinct tiles held by all particles' maps
  std::size_t bytes = 0;       ///< the storage of those tiles
  std::size_t best_tiles = 0;  ///< tiles of the best map (map())
  double best_area = 0.0;      ///< [m^2] the area the best map's tiles cover (best_tiles x a tile's area)
  int particles = 0;           ///< particles holding the maps

  /** @brief bytes in MB (10^6 bytes). */
  double megabytes() const { return static_cast<double>(bytes) * 1e-6; }
  /**
   * @brief MB per particle per 1000 m^2 of the best map: megabytes() / particles / (best_area / 1000); 0 while
   * nothing is mapped.
   */
  double megabytesPerParticlePer1000SquareMetres() const
  {
    return particles > 0 && best_area > 0.0 ? megabytes() / particles / (best_area * 1e-3) : 0.0;
  }
};

/**
 * @brief Grid SLAM: the interface of both methods, and what they share. update() refuses non-finite input, applies
 * the travel thresholds, starts the map(s) at the first scan (the map frame is the odometry frame as it was then:
 * every particle starts at the first odometry pose, map -> odom starts as the identity) and hands every further
 * scan to the method's step(); the methods weigh their particles and resample through the particle-filter
 * skeleton (weighAndResample()). Make one with create().
 */
class GridSlam
{
public:
  /** @brief The method config.mode names. @throws std::invalid_argument when config.validate() reports a problem. */
  static std::unique_ptr<GridSlam> create(const GridSlamConfig& config);
  virtual ~GridSlam() = default;

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
  /** @brief map -> odom: the mapping pose against the odometry pose it was estimated at. */
  Pose2 mapToOdom() const { return mapping_pose_ * last_odometry_.inverse(); }

  /** @brief Forgets everything (map, particles); the next scan starts a new map. Same seed as built. */
  void reset();

  bool initialised() const { return initialised_; }
  const std::vector<GridParticle>& particles() const { return particles_; }
  /** @brief The particle with the largest weight. */
  const GridParticle& best() const;
  /**
   * @brief The pose that last updated the map: single_map, the best particle's before any resampling; rbpf, the
   * best particle's (largest weight at the last update).
   */
  const Pose2& mappingPose() const { return mapping_pose_; }
  /** @brief The map: single_map's one map; rbpf, the best particle's (the one of mappingPose()). */
  virtual const OccupancyGrid& map() const = 0;
  /** @brief Particle @p i's map (single_map: the one map). */
  virtual const OccupancyGrid& particleMap(std::size_t i) const = 0;
  /**
   * @brief rbpf: the poses of the best particle's history, one per processed scan since the first (its ancestors'
   * poses before resampling); single_map: empty.
   */
  virtual std::vector<Pose2> bestTrajectory() const { return {}; }
  const GridSlamConfig& config() const { return config_; }
  /**
   * @brief The memory the maps hold: distinct tiles of all particles' maps (shared tiles once), their bytes, and
   * the area of the best map. Walks every particle's tile table: for reports, not for every scan.
   */
  GridMapMemory mapMemory() const;
  /** @brief The odometry pose of the last processed scan. */
  const Pose2& lastOdometry() const { return last_odometry_; }
  /**
   * @brief The particle cloud carried by the odometry from the last processed scan to @p odometry (a scan's
   * odometry pose): its weighted mean and covariance, the filter's stated uncertainty of the pose there (what the
   * node publishes on `pose`).
   */
  PoseMoments cloudMoments(const Pose2& odometry) const;

  /**
   * @brief The correlation of a scan taken from robot pose @p pose with @p map: the number of end points (of
   * every score_beam_step-th hit beam) that fall on occupied cells.
   */
  static int correlation(const OccupancyGrid& map, const Pose2& pose, const Pose2& sensor,
                         const std::vector<std::pair<double, double>>& end_points);
  /** @brief The end points of the hit beams in the sensor frame (every @p step-th beam). */
  static void scanEndPoints(const ScanData& scan, const ScanLimits& limits, int step,
                            std::vector<std::pair<double, double>>* end_points);

protected:
  explicit GridSlam(const GridSlamConfig& config);
  /** @brief The method's maps back to none (called by reset()). */
  virtual void resetMaps() = 0;
  /** @brief The first scan, every particle at @p odometry: starts the map(s); returns the beams mapped. */
  virtual int startMaps(const Pose2& odometry, const ScanData& scan, const Pose2& sensor) = 0;
  /**
   * @brief Every further scan above the travel thresholds, the odometry increment @p u since the last processed
   * one; lastScanIncrement() is the part since the scan before (processed or not).
   */
  virtual GridSlamStep step(const OdometryIncrement& u, const ScanData& scan, const Pose2& sensor) = 0;
  /**
   * @brief A scan below the travel thresholds moved the odometry by @p u since the scan before: a method may note
   * the spread it adds (the particles, the maps and the weights must not change). Default: nothing.
   */
  virtual void carry(const OdometryIncrement& u) { (void)u; }
  /** @brief The odometry increment since the scan before the one being processed (processed or not). */
  const OdometryIncrement& lastScanIncrement() const { return last_scan_increment_; }
  /**
   * @brief The skeleton's weighting step on log_weights_ (each particle's previous log-weight plus its scan's
   * log-likelihood): sets the particles' weights, runs @p before_resampling (the particles as weighed), and
   * resamples when Neff is low (particles_ rebuilt; the method rebuilds its own per-particle state from the
   * returned keep).
   */
  WeightingStep weighParticles(const std::function<void(const WeightingStep&)>& before_resampling);

  GridSlamConfig config_;
  Random random_;
  std::vector<GridParticle> particles_;
  std::vector<double> log_weights_, weights_;
  Pose2 mapping_pose_;
  std::vector<std::pair<double, double>> end_points_;

private:
  bool initialised_ = false;
  Pose2 last_odometry_;  ///< of the last processed scan
  Pose2 seen_odometry_;  ///< of the last scan, processed or not
  OdometryIncrement last_scan_increment_;
  double last_stamp_ = 0.0;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_GRID_GRID_SLAM_H
