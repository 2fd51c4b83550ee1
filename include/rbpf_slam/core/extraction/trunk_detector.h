#ifndef RBPF_SLAM_CORE_EXTRACTION_TRUNK_DETECTOR_H
#define RBPF_SLAM_CORE_EXTRACTION_TRUNK_DETECTOR_H

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace rbpf_slam
{
namespace core
{
/** @brief How a trunk's centre is found. */
enum class TrunkMethod : std::uint8_t
{
  kCentroid = 0,  ///< centre of the clipped cluster (the paper's method; biased towards the sensor)
  kCircle = 1,    ///< RANSAC circle on the horizontal projection, refined by least squares
  kArc = 2,       ///< arcs too short to fit: centre one (prior) radius behind the arc's middle
};

/** @brief Parses "centroid" or "circle"; false for anything else. */
bool parseTrunkMethod(const std::string& text, TrunkMethod* method);
const char* trunkMethodName(TrunkMethod method);

/**
 * @brief Parameters of the trunk detector. Lengths in metres, angles in radians.
 *
 * The same core serves a 3D lidar (detect()) and a 2D scanner (detectScan()); the ground, height band,
 * voxel and verticality settings apply to 3D input only.
 */
struct TrunkDetectorConfig
{
  TrunkMethod method = TrunkMethod::kCircle;

  // --- 3D: ground and height band -------------------------------------------------------------------
  double ground_cell = 1.0;       ///< [m] grid cell of the ground estimate (lowest points per cell)
  double ground_max_slope = 0.35; ///< [-] ground rises at most this much per metre between cells
  /// [m] the seen ground departs at most this much from the plane through the ground under the sensor; higher
  /// lowest points and places with no point take the plane's height (needs sensor_height); 0 = no plane
  double ground_relief = 0.5;
  double sensor_height = 0.0;     ///< [m] sensor above the ground under it (e.g. from TF); 0 = unknown
  double min_height = 0.8;        ///< [m] band above the local ground kept for trunks (from 0.5 m below breast
  double max_height = 2.3;        ///< [m] height, over most shrubs' bulk, to 1 m above it)
  double voxel_size = 0.0;        ///< [m] voxel downsampling of the band; 0 = off
  bool level_by_trunks = true;    ///< estimate the sensor's tilt from the verticality of the trunks

  // --- clustering ------------------------------------------------------------------------------------
  double cluster_tolerance = 0.25;  ///< [m] Euclidean clustering distance (3D); break distance of scan arcs
  int min_points = 6;               ///< 3D: clusters with fewer points are dropped
  /// 2D: arcs of fewer beams are dropped. A far trunk spans one or two beams; on simulated car scans of a park
  /// (scan_trunk_benchmark) single beams raise the recall from 41 % to 72 % at the same share of clutter.
  int scan_min_beams = 1;
  /// [m] 2D: an arc of fewer than min_fit_points beams must stand in front of its background: the beams beside
  /// both of its ends return nothing or from at least this much further (a trunk is an isolated object; a kink or a
  /// step of a wall or a car's side is not). About a large trunk's diameter, so that a surface just behind the
  /// trunk does not pass for its background.
  double scan_min_jump = 1.0;
  int max_points = 20000;           ///< and with more

  // --- fit and acceptance -----------------------------------------------------------------------------
  double min_radius = 0.04;         ///< [m]
  double max_radius = 0.6;          ///< [m]
  double ransac_threshold = 0.04;   ///< [m] inlier distance of the RANSAC circle
  int ransac_iterations = 100;
  double min_inlier_ratio = 0.7;    ///< inliers / cluster points
  double min_vertical_extent = 0.6; ///< [m] 3D: a trunk spans at least this much of the band
  double max_tilt = 0.35;           ///< [rad] 3D: clusters whose axis leans more are not trunks
  /// 3D circle method: fit each stem as a column of consistent cross-sections, a leaning cylinder (fitStemAxes(),
  /// the settings below), several per cluster, and take the sensor's tilt from the stems' axes; off: one circle per
  /// cluster's horizontal projection (split in two for touching trunks) and the tilt from the clusters.
  bool column_fit = true;
  double slice_height = 0.1;        ///< [m] 3D: slices of a cluster that show a stem's continuity (about a ring)
  int min_slices = 3;               ///< 3D: a stem holds at least two points on each of this many slices
  double max_stem_lean = 0.15;      ///< [rad] 3D: a stem's axis leans at most this much after levelling
  /// [rad] 3D: the scatter of stems' own leans about the vertical, per axis. The seen ground's plane gives the tilt
  /// (ground_relief) unless the stems' median axis departs from it by more than this scatter explains at 95 %
  /// (sloping ground: the robot stands on the slope it sees); 0 = the stems' axes always
  double stem_lean_sigma = 0.04;
  /// 3D: points a stem's bark would hide (inside it by more than ransac_threshold, or, in one sweep, behind it within
  /// its silhouette), as a share of its inliers, at most: foliage and bushes return from inside and behind any
  /// circle fitted to their front, bark from its surface only
  double max_interior_share = 0.15;
  /// 3D, one sweep: a stem is opaque, so the beams through its silhouette return from its bark; at most this share
  /// of the silhouette's cells (per slice) may return from more than twice ransac_threshold behind it (beams grazing
  /// its edge). Foliage and a circle fitted across a gap let beams through.
  double max_see_through = 0.1;
  /// 3D, one sweep: per slice, a stem's inliers span at least this share of the bearings its circle covers, where
  /// nothing nearer returned (mean over its slices): each ring crosses a stem's whole silhouette unless something
  /// hides part of it; a circle through foliage meets scattered points
  double min_silhouette_coverage = 0.5;
  /// 3D: the cloud shows stems from all sides (accumulated or merged sweeps): a stem's points may go all round it.
  /// Off (one sweep), points on a stem's far side, which its bark hides from the sensor, count against it.
  bool seen_from_all_sides = false;
  int max_stems_per_cluster = 4;    ///< 3D: stems looked for in one cluster (touching trunks, stems joined by branches)
  double max_arc_angle = 3.2;       ///< [rad] a trunk is seen over at most about half its circumference
  int min_fit_points = 8;           ///< fewer points (or an arc narrower than min_fit_arc) use the arc fallback
  double min_fit_arc = 0.6;         ///< [rad] angle subtended at the centre below which circles are unreliable
  double arc_radius_prior = 0.15;   ///< [m] radius assumed by the arc fallback when the arc cannot say
  double arc_radius_sigma = 0.08;   ///< [m] its standard deviation
  double range_sigma = 0.02;        ///< [m] sensor range noise, for the covariances
  double range_offset = 0.0;        ///< [m] 2D: added to every valid range (the scanner's range calibration)
  double min_range = 0.5;           ///< [m] trunks whose centre is nearer or further are dropped
  double max_range = 30.0;          ///< [m]
  /// [rad] 3D: the sensor's horizontal angle between two points of a ring (its driver's azimuth resolution, e.g.
  /// 0.2 deg for a 16-ring lidar at 10 Hz): how far a trunk still gives min_points on one ring (the reach) follows
  /// from it. 0: inferred from the cloud's points (estimateAzimuthStep), which an unevenly spaced cloud (a
  /// resampled or merged scan) can make short.
  double azimuth_resolution = 0.0;
  /// [m] 3D: the reach set outright (trunks are looked for up to the nearer of it and max_range); 0: from
  /// azimuth_resolution or the cloud.
  double sensor_reach = 0.0;
  /// Share of the trunks inside its scope the detector reports (consumers weigh a miss by it), in (0, 1].
  double detection_probability = 0.9;
  std::uint64_t seed = 0;           ///< of the RANSAC sampler

  /** @brief Empty when valid, else a message naming the first bad parameter. */
  std::string validate() const;
};

/** @brief One trunk: centre etc. in the detector's output frame (sensor origin, levelled, z up). */
struct TrunkObservation
{
  Eigen::Vector2d center = Eigen::Vector2d::Zero();       ///< [m]
  double radius = 0.0;                                    ///< [m]
  double radius_variance = 0.0;                           ///< [m^2]
  double range = 0.0;                                     ///< [m] of the centre from the sensor
  double bearing = 0.0;                                   ///< [rad] of the centre
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();  ///< [m^2] of the centre
  int num_points = 0;
  int num_inliers = 0;
  double score = 0.0;  ///< [0, 1] confidence (inlier ratio times coverage)
  TrunkMethod method = TrunkMethod::kCircle;
  double height = 0.0;  ///< [m] height of the centre (middle of the band) above the sensor
  int id = -1;          ///< the landmark's id when the detector knows it (known association), else -1
};

/** @brief Where a 3D detector's reach comes from (TrunkDetectorStats::reach). */
enum class ReachSource
{
  kUnknown,     ///< no reach (2D, or too few points to tell)
  kConfigured,  ///< TrunkDetectorConfig::sensor_reach
  kResolution,  ///< TrunkDetectorConfig::azimuth_resolution, the sensor's
  kCloud,       ///< inferred from the spacing of the cloud's points along its rings
};

/** @brief Counts of one detect() call, for diagnostics and benchmarks. */
struct TrunkDetectorStats
{
  int input_points = 0;
  int finite_points = 0;
  int band_points = 0;
  int clusters = 0;
  int rejected_size = 0;
  int rejected_radius = 0;
  int rejected_inliers = 0;
  int rejected_shape = 0;  ///< too short, leaning, or an arc that is not a trunk's
  int rejected_clutter = 0; ///< 2D: a short arc that is no isolated convex object of a trunk's width
  int split_clusters = 0;   ///< clusters (or arcs) split into two touching trunks
  int trunks = 0;
  double tilt_roll = 0.0;   ///< [rad] sensor tilt estimated (3D)
  double tilt_pitch = 0.0;  ///< [rad]
  /// [rad] 3D: the tilt of the seen ground's plane (GroundModel::groundPlane(); 0 without one): the sensor's tilt
  /// against the terrain it stands on, not against gravity (trunks are levelled by tilt_roll and tilt_pitch)
  double ground_roll = 0.0;
  double ground_pitch = 0.0;  ///< [rad]
  bool tilt_from_ground = false;  ///< 3D column fit: tilt_roll and tilt_pitch are the ground's (else the stems')
  /// [m] 3D: how far a trunk of arc_radius_prior still gives min_points on one ring of this cloud (NaN: unknown)
  double reach = NAN;
  ReachSource reach_source = ReachSource::kUnknown;  ///< where reach comes from
  double azimuth_step = NAN;  ///< [rad] 3D: the step between a ring's points the reach was made from (NaN: none)
  // Wall time of the stages of detect() [ms].
  double ms_band = 0.0;     ///< ground estimate and height band
  double ms_cluster = 0.0;  ///< clustering and candidate selection
  double ms_tilt = 0.0;     ///< tilt from the trunks
  double ms_fit = 0.0;      ///< circle or column fits (with the tilt from the stems' axes) and rejection
};

/**
 * @brief The reach of a 3D detector (TrunkDetectorStats::reach and reach_source): @p config's sensor_reach when set,
 * else singleRingReach() of its azimuth_resolution when set, else of @p cloud_step (the cloud's own step; NaN:
 * unknown).
 */
void detectorReach(const TrunkDetectorConfig& config, double cloud_step, double* reach, ReachSource* source,
                   double* step);

/**
 * @brief Why trunks beyond the reach of @p stats are not looked for although @p config's max_range is further
 * (naming the step, its source and the parameters that set it); empty when the reach is not below max_range, is
 * unknown, or was set outright.
 */
std::string reachShortfall(const TrunkDetectorConfig& config, const TrunkDetectorStats& stats);

/** @brief A planar scan as REP-117 gives it. */
struct PlanarScan
{
  std::vector<float> ranges;
  double angle_min = 0.0;
  double angle_increment = 0.0;
  double range_min = 0.0;
  double range_max = 1e9;
};

/**
 * @brief Finds tree trunks in one lidar sweep: height clipping above the local ground, Euclidean
 * clustering, a RANSAC circle per cluster refined by least squares, rejection of non-trunks.
 *
 * Owns its random generator (seeded by config.seed) so results repeat. Not thread-safe: one instance per
 * thread; the config may be replaced between calls (setConfig()).
 */
class TrunkDetector
{
public:
  explicit TrunkDetector(const TrunkDetectorConfig& config = TrunkDetectorConfig());
  ~TrunkDetector();
  TrunkDetector(const TrunkDetector&) = delete;
  TrunkDetector& operator=(const TrunkDetector&) = delete;

  /** @throws std::invalid_argument when config.validate() is not empty. */
  void setConfig(const TrunkDetectorConfig& config);
  const TrunkDetectorConfig& config() const { return config_; }

  /**
   * @brief 3D input: points in the sensor frame (non-finite points are skipped).
   * @param level rotation from the sensor frame to a frame whose z axis is up (e.g. from TF); identity
   *        when unknown. When config.level_by_trunks, a residual tilt is estimated on top of it.
   * Results are in the levelled frame at the sensor's origin.
   */
  std::vector<TrunkObservation> detect(const std::vector<Eigen::Vector3f>& points,
                                       const Eigen::Matrix3d& level = Eigen::Matrix3d::Identity(),
                                       TrunkDetectorStats* stats = nullptr);

  /** @brief 2D input: each arc of the scan (range jumps break arcs) is a cluster; results in the scan frame. */
  std::vector<TrunkObservation> detectScan(const PlanarScan& scan, TrunkDetectorStats* stats = nullptr);

private:
  struct Impl;
  TrunkDetectorConfig config_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_EXTRACTION_TRUNK_DETECTOR_H
