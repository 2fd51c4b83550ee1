#ifndef RBPF_SLAM_CORE_FASTSLAM_TRUNK_SLAM_PIPELINE_H
#define RBPF_SLAM_CORE_FASTSLAM_TRUNK_SLAM_PIPELINE_H

#include <cmath>
#include <deque>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/forest_map/constellation.h"
#include "rbpf_slam/core/fastslam/fastslam.h"
#include "rbpf_slam/core/fastslam/filter_health.h"
#include "rbpf_slam/core/forest_map/forest_changes.h"
#include "rbpf_slam/core/forest_map/gnss.h"
#include "rbpf_slam/core/filter/odometry_buffer.h"
#include "rbpf_slam/core/filter/sensor_pipeline.h"
#include "rbpf_slam/core/extraction/trunk_detector.h"

namespace rbpf_slam
{
namespace core
{
/** @brief The lidar on base_link: planar pose and height (for the lever arm on a tilted body). */
struct SensorMount
{
  double x = 0.0, y = 0.0, z = 0.0, yaw = 0.0;
};

/**
 * @brief Which bearings a sweep covers in its period: it starts at @p start_angle and turns counter-clockwise
 * through @p span. A spinning lidar starts behind (-pi) and covers 2 pi; a 2D scanner covers angle_min ..
 * angle_min + (n - 1) * angle_increment.
 */
struct SweepGeometry
{
  double start_angle = -M_PI;
  double span = 2.0 * M_PI;
};

/**
 * @brief @p config with the sensor's height above the ground taken from its mount: where the configuration
 * leaves it unknown (0), the sensor's height @p mount_z on base_link stands for it (base_link on the ground).
 */
TrunkDetectorConfig withMountHeight(TrunkDetectorConfig config, double mount_z);

/** @brief [s] from a 2D scan's first beam to its last, @p time_increment apart; 0 when that is not given (not
 * finite or <= 0: every beam at the stamp) or the scan has fewer than 2 beams. */
double scanPeriod(double time_increment, std::size_t beams);

/** @brief The sweep geometry of a 2D scan: from angle_min through its last beam. */
SweepGeometry scanGeometry(const PlanarScan& scan);

/** @brief The trunks of one sweep as a detector gives them, with what it takes to carry them to one instant. */
struct TrunkSweep
{
  double stamp = 0.0;   ///< [s] the sweep's first instant
  double period = 0.0;  ///< [s] its duration (0: every trunk at the stamp)
  double tilt_roll = 0.0, tilt_pitch = 0.0;  ///< [rad] the tilt the detector estimated and removed
  SweepGeometry geometry;
  SensorMount mount;  ///< the sensor on base_link
  SensorScope scope;  ///< what the sensor could see (sensor frame; NaN where it does not say)
  std::vector<TrunkObservation> trunks;  ///< sensor frame, levelled
};

/**
 * @brief What the detector @p config could see of the 2D scan @p scan: its bearings (angle_min to the last beam),
 * its ranges (range_min..range_max within the detector's min_range..max_range), the detector's detection
 * probability.
 */
SensorScope scanScope(const PlanarScan& scan, const TrunkDetectorConfig& config);
/**
 * @brief The same for a 3D sweep: all round, from the detector's min_range to the nearer of its max_range and
 * @p reach (the range to which the cloud's resolution lets it find a trunk; NaN: not known).
 */
SensorScope sweepScope(const TrunkDetectorConfig& config, double reach = NAN);

/** @brief The state of a global relocalization in a saved map. */
struct RelocalizationStatus
{
  bool active = false;      ///< a search took place on this update
  bool found = false;       ///< this update found the robot (the filter starts here)
  int trunks = 0;           ///< distinct trunks gathered so far (seen at least twice)
  int best_inliers = 0;     ///< of the best hypothesis
  int second_inliers = 0;   ///< of the runner-up (0: none)
  int hypotheses = 0;       ///< distinct hypotheses the particles were spread over (when found)
  double travel = 0.0;      ///< [m] odometry travel since the search began
  double seconds = 0.0;     ///< [s] CPU time of the search on this update
  std::string reason;       ///< why not found yet
  /// a search after tracking was lost (the health warned); the filter tracks on meanwhile
  bool lost = false;
  /// that search ended on this update: it found a pose distinct from the estimate and the particles were moved there
  bool recovered = false;
  /// that search ended on this update: it found the estimate's own pose (tracking was not lost)
  bool confirmed = false;
  /// that search ended on this update without a result: nothing found within a window of travel
  bool gave_up = false;
};

/** @brief Parameters of the search for the start pose in a saved map. */
struct RelocalizationConfig
{
  ConstellationConfig constellation;
  double merge_distance = 0.5;  ///< [m] detections this close in the odometry frame are one trunk
  int min_sightings = 2;        ///< a trunk takes part once seen this often
  double window = 30.0;         ///< [m] of travel: trunks gathered longer ago are forgotten (odometry drifts)
  double hypothesis_share = 0.5;  ///< particles go to every hypothesis with this share of the best's inliers
  double spread_xy = 0.1;       ///< [m] the particles' spread around each hypothesis
  double spread_theta = 0.02;   ///< [rad]
  /// With a saved map and FastSlamConfig::relocalize_when_lost: the map is searched again when the filter's health
  /// warns (its trees not re-observed: a lost pose), while the filter tracks on; a pose found farther than
  /// recover_distance or recover_angle from the estimate replaces it (the particles spread over it and the
  /// estimate, on the saved map).
  double recover_distance = 1.0;  ///< [m]
  /// ... and only when the found pose explains at least this many of the trunks gathered since the search began and
  /// recover_margin more than the estimate does (the estimate is the alternative: a chance match in a dense map
  /// must not replace it)
  int recover_min_inliers = 8;
  int recover_margin = 3;
  double recover_angle = 0.2;     ///< [rad]
};

/** @brief One sweep after extraction and the filter update. */
struct PipelineUpdate
{
  double stamp = 0.0;                 ///< [s] the sweep's middle, where the filter updated
  Pose2 odometry;                     ///< odometry at that instant
  Pose2 estimate;                     ///< the filter's estimate of base_link in the map after the update
  int timeline = 0;                   ///< restarts before this update (a restart flushes the old timeline's sweeps)
  Pose2 mount;                        ///< the sensor's planar pose on base_link
  bool odometry_covered = true;       ///< false: processed after waiting, with odometry that ends before the sweep
  std::vector<TrunkObservation> trunks;  ///< as extracted (sensor frame, levelled)
  FastSlamUpdateStats stats;
  HealthStatus health;                ///< the filter's health over its last updates, this one included
  /// false: the robot had not moved update_min_travel or turned update_min_turn since the last filter update; the
  /// sweep was not given to the filter and the estimate is the last one moved by the odometry since
  bool filtered = true;
  /// false: still searching where the robot is in a saved map (setPriorMap without a start): no estimate yet
  bool localized = true;
  /// set on the update that found the robot in a saved map (and on every update while searching): what the
  /// constellation search said
  RelocalizationStatus relocalization;
};

/**
 * @brief The observations of one sweep at the instant @p t_ref: each trunk (sensor frame, levelled, seen
 * during the sweep that starts at @p stamp and lasts @p period) is moved by the lever arm of the tilt the
 * detector removed (mount.z * (tan pitch, -tan roll)), then carried from its own instant (bearing b at
 * (b - start_angle) / span of the sweep) to @p t_ref by the odometry between the two.
 */
std::vector<LandmarkObservation> sweepObservations(const std::vector<TrunkObservation>& trunks, double stamp,
                                                   double period, double tilt_roll, double tilt_pitch,
                                                   const SensorMount& mount, const OdometryBuffer& odometry,
                                                   double t_ref, const SweepGeometry& geometry = SweepGeometry());

/** @brief The map of a timeline that a restart (time jumping back) ended: the best particle's trees then. */
struct TimelineMap
{
  int timeline = 0;  ///< restarts before it (0: the first timeline)
  std::vector<Landmark> trees;
  std::vector<Viewpoint> viewpoints;
  GeoAnchor anchor;
};

/** @brief A trunk seen in a sweep that the filter skipped, in the odometry frame. */
struct LookPoint
{
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  ///< [m] odometry frame
  double radius = 0.0;                                  ///< [m]
  int id = -1;
};

/**
 * @brief Fuses the looks skipped since the last update into @p obs (seen from @p sensor, odometry frame): each
 * observation takes the mean position and radius of itself and of the nearest skipped look of each sweep inside
 * the association gate @p gate (same id where ids are known), and keeps its own covariance. The looks from
 * nearby poses share most of their error, so they are counted as one look: the mean removes the part that
 * differs between them, the covariance stays that of one. Returns how many skipped looks were fused.
 */
int fuseSkippedLooks(std::vector<LandmarkObservation>* obs, const Pose2& sensor,
                     const std::vector<std::vector<LookPoint>>& skipped, double gate);

/**
 * @brief The share of one independent look that a sweep carries (evidence counted once), from the sensor's motion
 * @p sensor_motion since the last update: its travel over evidence_view_change times the median range of the
 * sweep's trunks (the travel after which they are seen from a new view), or its turn over evidence_view_change,
 * whichever is more, at most 1. Sweeps of the same trunks from about the same place repeat the same errors (the fit
 * of the same visible arc, the same occluders, the same clutter): the filter weighs each sweep's likelihood by
 * this share (tempered likelihood: the observation covariance divided by it), so that standing still or creeping
 * adds no more confidence than the looks it brings. 1 when evidence_view_change is 0 or the sweep saw no trunk.
 */
double evidenceShare(const FastSlamConfig& config, const std::vector<TrunkObservation>& trunks,
                     const Pose2& sensor_motion);

/**
 * @brief Trunk extraction and FastSLAM on stamped sweeps and wheel odometry, ROS-free: the one pipeline of the
 * FastSLAM nodelet (fed with TrunkArray messages: addTrunks) and of every offline runner (the bag runner and the
 * simulator runner: addSweep / addScan extract the trunks here).
 *
 * - Time (SensorPipeline): late, duplicate and non-finite stamps are dropped, a jump back beyond the threshold
 *   restarts the pipeline (waiting sweeps are flushed with the odometry they have, then filter and detector start
 *   over with their seeds); odometry may arrive late: a sweep waits until odometry covers its end (or
 *   PipelineTiming::odometry_wait).
 * - The map frame is the odometry frame at the first sweep's middle: the particles start at that odometry pose,
 *   so map -> odom starts as the identity (REP-105).
 * - Each trunk is seen at its own instant of the sweep (bearing b at (b - start_angle) / span; a spinning lidar
 *   starts behind), carried to the sweep's middle by the odometry between the two instants, and moved by the
 *   lever arm of the tilt the detector removed; the filter updates there.
 */
class TrunkSlamPipeline : public SensorPipeline<TrunkSweep, PipelineUpdate>
{
public:
  TrunkSlamPipeline(const TrunkDetectorConfig& detector, const FastSlamConfig& filter,
                    const PipelineTiming& timing = PipelineTiming());

  /** @brief Trunks a detector found (e.g. a TrunkArray); @p arrival on the caller's clock (see odometry_wait).
   * kOverLimit (dropped, its stamp not taken) for more than FastSlamConfig::max_trunks_per_sweep trunks; a sweep
   * whose scope is not complete (unreadable detections dropped) updates the landmarks it saw and misses none. */
  StampVerdict addTrunks(TrunkSweep sweep, double clock = NAN, double arrival = NAN);
  /** @brief Extracts the trunks of a 3D sweep (points in the sensor frame, @p period from its per-point times);
   * where the detector's configuration leaves the sensor height unknown, the mount's height stands for it. */
  StampVerdict addSweep(double stamp, double period, const std::vector<Eigen::Vector3f>& points,
                        const SensorMount& mount, double clock = NAN, double arrival = NAN);
  /** @brief The same for a 2D scan (no levelling: the scanner is taken as level); @p period is the time from the
   * first beam to the last; the sweep's geometry is the scan's angles. */
  StampVerdict addScan(double stamp, double period, const PlanarScan& scan, const SensorMount& mount,
                       double clock = NAN, double arrival = NAN);

  /**
   * @brief Starts the filter (now and after every restart) from a saved map: the map frame is then the saved
   * map's frame, every particle starts at @p start (base_link in that frame at the first update) and shares
   * @p trees. Confirmed trees start with the largest existence evidence (evidence_max), provisional ones with
   * none; ids, covariances, radii, counts and times are kept. An empty list and the identity are the default:
   * a new map whose frame is the odometry frame at the first update.
   */
  void setPriorMap(const std::vector<Landmark>& trees, const Pose2& start,
                   const RelocalizationConfig& relocalization = RelocalizationConfig());
  /// (Both setPriorMap throw std::invalid_argument for more trees than FastSlamConfig::max_landmarks.)
  /**
   * @brief The same with the start pose unknown: the pipeline gathers the trunks of the first sweeps in the
   * odometry frame (merged, each seen at least min_sightings times) and searches the saved map for them by
   * constellation (ConstellationMatcher) after each sweep; until the search is accepted, updates come out with
   * localized = false and no estimate. Then the particles start spread over the hypotheses that explain at least
   * hypothesis_share of the best's trunks (each around its pose), and the next sweeps weigh them.
   */
  void setPriorMap(const std::vector<Landmark>& trees, const RelocalizationConfig& relocalization);
  bool hasPriorMap() const { return has_prior_; }

  /**
   * @brief The maps that restarts ended since the last call (oldest first; at most kKeptEndedMaps are kept when
   * nobody takes them): a restart starts a new map, and the old one is the caller's to save.
   */
  std::vector<TimelineMap> takeEndedMaps();
  static constexpr std::size_t kKeptEndedMaps = 2;

  /**
   * @brief Where the map frame lies on the earth, when known (a saved map's anchor): fixes then weigh the particles
   * from the start, and this visit's own fit refines it (combineAnchors; an anchor of sigma 0 is kept as it is).
   * Not valid (the default): the anchor is fitted to the fixes.
   */
  void setMapAnchor(const GeoAnchor& anchor);
  /**
   * @brief Where the saved map was looked at from (its file's viewpoints; none: not known). This visit adds its
   * own, from the estimate after each filter update (ViewpointLog: one per metre of new ground), for the map it
   * saves and for telling new trees from trees the saved map had not reached (detectChanges).
   */
  void setMapViewpoints(const std::vector<Viewpoint>& viewpoints);
  /** @brief The saved map's viewpoints and this visit's (this timeline's: a restart starts a new map). */
  const std::vector<Viewpoint>& viewpoints() const { return viewpoints_.viewpoints(); }
  /**
   * @brief A satellite fix of the antenna (used as the filter configuration's gnss says; without fixes everything
   * works in the map frame alone) at @p antenna (x, y on base_link). Used at the next filter update whose
   * instant is at or after the fix's: the antenna's map position from the estimate there (carried back to the
   * fix's instant by the odometry) goes to the anchor's fit, and, once the anchor is known well enough
   * (weigh_max_anchor_sigma), at most one fix per correlation_time weighs the particles. Returns why the fix was
   * refused ("" when taken): no fix, a bad value, a stamp before the last update.
   */
  std::string addFix(const GnssFix& fix, const Eigen::Vector2d& antenna);
  /** @brief The map frame's anchor: the saved map's combined with the one fitted to this visit's fixes (either
   * alone when the other is not there; not valid: none yet). */
  GeoAnchor anchor() const;
  /** @brief Fixes that went into the anchor's fit, and fixes that weighed the particles. */
  int gnssFixesUsed() const { return gnss_used_; }
  int gnssFixesWeighed() const { return gnss_weighed_; }
  /** @brief Fixes the innovation gate refused (kGnssGate2: inconsistent with the anchor and the filter's pose). */
  int gnssFixesRejected() const { return gnss_rejected_; }
  /** @brief Localized in the map: always true without a saved map, or with a known start. */
  bool localized() const { return initialized_; }

  const FastSlam& filter() const { return *filter_; }
  /** @brief The filter's health monitor (restarts with the filter). */
  const FilterHealth& health() const { return health_; }
  bool initialized() const { return initialized_; }
  /** @brief The odometry pose of the last update (map -> odom = filter pose * its inverse). */
  const Pose2& lastOdometry() const { return last_odometry_; }
  double secondsExtraction() const { return seconds_extraction_; }
  double secondsFilter() const { return seconds_filter_; }

private:
  PipelineUpdate update(TrunkSweep&& sweep, bool covered) override;
  void resetFilter() override;
  /** @brief Queues @p sweep; false (dropped) when it holds more trunks than max_trunks_per_sweep. */
  bool enqueueSweep(TrunkSweep sweep, double arrival);
  /**
   * @brief Predicts the filter from the last update's odometry up to @p odom_mid at @p t_mid along the odometry's
   * own samples: steps of motion_step (odometry model) or blocks of motion_noise_time (velocity model); the last,
   * partial one carries its share of the noise.
   */
  void predictMotion(const FastSlamConfig& fc, const Pose2& odom_mid, double t_mid);
  std::vector<TimelineMap> ended_;

  TrunkDetectorConfig detector_config_;
  FastSlamConfig filter_config_;
  std::unique_ptr<TrunkDetector> detector_;
  std::unique_ptr<FastSlam> filter_;
  FilterHealth health_;
  bool initialized_ = false;
  bool has_prior_ = false;
  LandmarkMap prior_;
  std::vector<Viewpoint> prior_viewpoints_;
  ViewpointLog viewpoints_;
  Pose2 prior_start_;
  bool relocalize_ = false;
  RelocalizationConfig relocalization_config_;
  std::unique_ptr<ConstellationMatcher> matcher_;
  struct Gathered
  {
    Eigen::Vector2d center;
    double radius = 0.0;
    int sightings = 0;
    double travel = 0.0;  ///< odometry travel at the last sighting
  };
  std::vector<Gathered> gathered_;
  /// The observations of the sweeps skipped since the last update (updateMinTravel), in the odometry frame: fused
  /// into the next update's observations of the same trunks.
  std::vector<std::vector<LookPoint>> between_;
  /// Skipped sweeps kept for fusion (a robot that stands still for minutes keeps the first ones).
  static constexpr std::size_t kMaxSkippedLooks = 100;
  /// A sweep that carries less than this share of a look (evidenceShare; e.g. standing still) is not given to the
  /// filter: the estimate follows the odometry, and its trunks are fused into the next update's.
  static constexpr double kMinEvidenceShare = 0.01;
  double search_travel_ = 0.0;
  bool search_started_ = false;
  Pose2 search_last_odometry_;
  /** @brief One sweep of the search; true when it was accepted, with the poses to start from in @p starts. */
  bool relocalize(const TrunkSweep& sweep, const Pose2& odom_mid, RelocalizationStatus* status,
                  std::vector<Pose2>* starts);
  /** @brief With a saved map: the search while tracking, begun when the health warns (relocalize_when_lost);
   * moves the particles when it finds the robot elsewhere. Sets @p u's relocalization while it runs. */
  void searchWhenLost(const TrunkSweep& sweep, const Pose2& odom_mid, PipelineUpdate* u);
  /** @brief The health monitor's rules: with a saved map, also whether its trees are re-observed. */
  HealthConfig healthConfig() const;
  /** @brief Starts a new search (the trunks gathered so far forgotten). */
  void restartSearch();
  bool lost_search_ = false;      ///< a search after lost tracking is running
  double lost_search_end_ = -1e300;  ///< [m] odometry travel when the last one ended
  double travel_ = 0.0;           ///< [m] odometry travel of the timeline at the last update
  bool last_unobserved_ = false;
  std::vector<TrunkPoint> last_seen_;  ///< the trunks of the last search step (odometry frame)
  GnssFusionConfig gnss_config_;
  GeoAnchor map_anchor_;
  GeoAnchorEstimator anchor_estimator_;
  struct PendingFix
  {
    GnssFix fix;
    Eigen::Vector2d antenna;
  };
  std::deque<PendingFix> pending_fixes_;
  double last_weigh_stamp_ = -1e300;
  double next_anchor_check_ = -1e300;  ///< [s] the anchor is not refitted for weighing before this fix stamp
  int gnss_used_ = 0, gnss_weighed_ = 0, gnss_rejected_ = 0;
  GeoAnchor gate_anchor_;  ///< the last anchor computed (or the saved map's): the fixes' innovation gate
  /** @brief Uses the fixes up to the filter update at @p t_mid (odometry @p odom_mid). */
  void useFixes(double t_mid, const Pose2& odom_mid);
  Pose2 last_odometry_;
  Pose2 last_estimate_;
  double last_stamp_ = 0.0;
  double seconds_extraction_ = 0.0, seconds_filter_ = 0.0;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FASTSLAM_TRUNK_SLAM_PIPELINE_H
