#ifndef RBPF_SLAM_CORE_TRUNK_SLAM_TRUNK_SLAM_PIPELINE_H
#define RBPF_SLAM_CORE_TRUNK_SLAM_TRUNK_SLAM_PIPELINE_H

#include <cmath>
#include <deque>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/extraction/trunk_detector.h"
#include "rbpf_slam/core/fastslam/fastslam.h"
#include "rbpf_slam/core/fastslam/filter_health.h"
#include "rbpf_slam/core/trunk_slam/trunk_slam_config.h"
#include "rbpf_slam/core/trunk_slam/trunk_sweep.h"
#include "rbpf_slam/core/filter/odometry_buffer.h"
#include "rbpf_slam/core/filter/sensor_pipeline.h"
#include "rbpf_slam/core/forest_map/constellation.h"
#include "rbpf_slam/core/forest_map/forest_changes.h"
#include "rbpf_slam/core/forest_map/gnss.h"
#include "rbpf_slam/core/forest_map/gnss_anchoring.h"
#include "rbpf_slam/core/forest_map/loop_closing.h"
#include "rbpf_slam/core/forest_map/relocalization.h"

namespace rbpf_slam
{
namespace core
{
/** @brief One sweep after extraction and the filter update. */
struct PipelineUpdate
{
  double stamp = 0.0;                 ///< [s] the sweep's middle, where the filter updated
  Pose2 odometry;                     ///< odometry at that instant
  /// base_link in the map after the update, as published: the latest smoothing of the run carried on by the filter's
  /// motion since (LoopClosing::published), else the filter's estimate
  Pose2 estimate;
  /// The covariance of @c estimate (x, y, theta): the smoother's marginal at the pose it starts from, carried to the
  /// robot, plus the particle cloud's own; the cloud's alone without a smoothing (zero before the first update)
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  int timeline = 0;                   ///< restarts before this update (a restart flushes the old timeline's sweeps)
  Pose2 mount;                        ///< the sensor's planar pose on base_link
  bool odometry_covered = true;       ///< false: processed after waiting, with odometry that ends before the sweep
  std::vector<TrunkObservation> trunks;  ///< as extracted (sensor frame, levelled)
  FastSlamUpdateStats stats;
  HealthStatus health;                ///< the filter's health over its last updates, this one included
  /// false: the sweep carried too little of a new look (evidenceShare below kMinEvidenceShare, e.g. standing
  /// still); it was not given to the filter and the estimate is the last one moved by the odometry since
  bool filtered = true;
  /// false: still searching where the robot is in a saved map (setPriorMap without a start): no estimate yet
  bool localized = true;
  /// set on the update that found the robot in a saved map (and on every update while searching): what the
  /// constellation search said
  RelocalizationStatus relocalization;
  /// Loop closure at this update (LoopClosing): a loop closed (the estimate is then the smoothed one) or refused.
  LoopEvent loop;
};

/** @brief The map of a timeline that a restart (time jumping back) ended: the best particle's trees then. */
struct TimelineMap
{
  int timeline = 0;  ///< restarts before it (0: the first timeline)
  std::vector<Landmark> trees;
  std::vector<Viewpoint> viewpoints;
  GeoAnchor anchor;
};

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
  /** @throws std::invalid_argument when @p filter.validate() reports a problem. */
  TrunkSlamPipeline(const TrunkDetectorConfig& detector, const TrunkSlamConfig& filter,
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
  void setMapAnchor(const GeoAnchor& anchor) { gnss_.setMapAnchor(anchor); }
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
  std::string addFix(const GnssFix& fix, const Eigen::Vector2d& antenna)
  {
    return gnss_.add(fix, antenna, initialized_ ? last_stamp_ : NAN);
  }
  /** @brief The map frame's anchor: the saved map's combined with the one fitted to this visit's fixes (either
   * alone when the other is not there; not valid: none yet). */
  GeoAnchor anchor() const { return gnss_.anchor(); }
  /** @brief Fixes that went into the anchor's fit, and fixes that weighed the particles. */
  int gnssFixesUsed() const { return gnss_.used(); }
  /** @brief Why the extraction did not look for trunks up to its max_range, as the first sweep that fell short said
   * it (TrunkSweep::reach_shortfall; empty when none did), and how many sweeps fell short. */
  const std::string& reachShortfall() const { return reach_shortfall_; }
  int shortReachSweeps() const { return short_reach_sweeps_; }
  int gnssFixesWeighed() const { return gnss_.weighed(); }
  /** @brief Fixes the innovation gate refused (kGnssGate2: inconsistent with the anchor and the filter's pose). */
  int gnssFixesRejected() const { return gnss_.rejected(); }
  /** @brief Fixes the anchor's last fit left out as far from the others. */
  int gnssAnchorOutliers() const { return gnss_.anchorOutliers(); }
  /** @brief Localized in the map: always true without a saved map, or with a known start. */
  bool localized() const { return initialized_; }

  const FastSlam& filter() const { return *filter_; }
  /**
   * @brief The run smoothed as it stands (TrunkSmoother over the best particle's path and trees, every loop closed
   * so far in them): the path at every filter update of this timeline and the trees. Not ok (reason) without loop
   * closure (disabled, or a saved map), before two updates, or when the solve fails.
   */
  SmoothedRun smoothed() const;
  /** @brief The covariance of the published estimate @p estimate (PipelineUpdate::covariance). */
  Eigen::Matrix3d estimateCovariance(const Pose2& estimate) const;
  /** @brief smoothed() as a job to run later on any thread, without holding the pipeline (it holds copies). */
  std::function<SmoothedRun()> smoothingJob() const;
  /** @brief Loops closed and refused in this timeline. */
  int loopsClosed() const { return loops_ ? loops_->closed() : 0; }
  int loopsRejected() const { return loops_ ? loops_->rejected() : 0; }
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
  /** @brief The update of a sweep not given to the filter (@p sweep's trunks moved into it): @p estimate stands. */
  PipelineUpdate unfiltered(TrunkSweep&& sweep, double t_mid, const Pose2& odom_mid, const Pose2& estimate,
                            bool covered) const;
  /** @brief Queues @p sweep; false (dropped) when it holds more trunks than max_trunks_per_sweep. */
  bool enqueueSweep(TrunkSweep sweep, double arrival);
  std::vector<TimelineMap> ended_;

  TrunkDetectorConfig detector_config_;
  TrunkSlamConfig filter_config_;
  std::string reach_shortfall_;
  int short_reach_sweeps_ = 0;
  std::unique_ptr<TrunkDetector> detector_;
  std::unique_ptr<FastSlam> filter_;
  std::unique_ptr<LoopClosing> loops_;  ///< without a saved map, when enabled
  FilterHealth health_;
  bool initialized_ = false;
  bool has_prior_ = false;
  LandmarkMap prior_;
  std::vector<Viewpoint> prior_viewpoints_;
  ViewpointLog viewpoints_;
  Pose2 prior_start_;
  bool relocalize_ = false;  ///< the start is searched in the saved map
  /// With a saved map whose start is searched, or searched again when lost (relocalize_when_lost).
  std::unique_ptr<Relocalizer> relocalizer_;
  /// The observations of the sweeps skipped since the last update (kMinEvidenceShare), in the odometry frame: fused
  /// into the next update's observations of the same trunks.
  std::vector<std::vector<LookPoint>> between_;
  /// Skipped sweeps kept for fusion (a robot that stands still for minutes keeps the first ones).
  static constexpr std::size_t kMaxSkippedLooks = 100;
  /// A sweep that carries less than this share of a look (evidenceShare; e.g. standing still) is not given to the
  /// filter: the estimate follows the odometry, and its trunks are fused into the next update's.
  static constexpr double kMinEvidenceShare = 0.01;
  /** @brief With a saved map: the search while tracking, begun when the health warns (relocalize_when_lost);
   * moves the particles when it finds the robot elsewhere. Sets @p u's relocalization while it runs. */
  void searchWhenLost(const TrunkSweep& sweep, const Pose2& odom_mid, PipelineUpdate* u);
  /** @brief The health monitor's rules: with a saved map, also whether its trees are re-observed. */
  HealthConfig healthConfig() const;
  double travel_ = 0.0;  ///< [m] odometry travel of the timeline at the last update
  GnssAnchoring gnss_;
  Pose2 last_odometry_;
  Pose2 last_estimate_;
  Eigen::Matrix3d last_covariance_ = Eigen::Matrix3d::Zero();
  double last_stamp_ = 0.0;
  double seconds_extraction_ = 0.0, seconds_filter_ = 0.0;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_TRUNK_SLAM_TRUNK_SLAM_PIPELINE_H
