#ifndef RBPF_SLAM_CORE_TRUNK_SLAM_TRUNK_SWEEP_H
#define RBPF_SLAM_CORE_TRUNK_SLAM_TRUNK_SWEEP_H

#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/extraction/trunk_detector.h"
#include "rbpf_slam/core/fastslam/fastslam.h"
#include "rbpf_slam/core/filter/odometry_buffer.h"

/**
 * @file
 * @brief One sweep of trunks as the FastSLAM pipeline takes it: where the sensor sits, when each trunk was seen, what
 * the sensor could see, and the observations at one instant; how much a sweep adds as evidence, and the looks of
 * skipped sweeps fused into the next update.
 */
namespace rbpf_slam
{
namespace core
{
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
  /// 3D: why trunks beyond the detector's reach were not looked for although max_range is further (reachShortfall;
  /// empty: they were)
  std::string reach_shortfall;
};

/** @brief A sweep's period and tilt that are not finite (or a negative period) as 0: every trunk at the stamp, level. */
void zeroUnknownTiming(TrunkSweep* sweep);

/**
 * @brief The trunks @p detector finds in a 3D sweep (points in the sensor frame, levelled by the detector) that
 * starts at @p stamp and lasts @p period, from the sensor at @p mount: where the detector's configuration leaves
 * the sensor's height unknown, the mount's height stands for it (as the extraction nodelet takes it from TF).
 */
TrunkSweep detectSweep(TrunkDetector* detector, double stamp, double period,
                       const std::vector<Eigen::Vector3f>& points, const SensorMount& mount);
/** @brief The same for a 2D scan (taken as level; the sweep's geometry is the scan's angles). */
TrunkSweep detectScanSweep(TrunkDetector* detector, double stamp, double period, const PlanarScan& scan,
                           const SensorMount& mount);

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

/** @brief A trunk seen in a sweep that the filter skipped, in the odometry frame. */
struct LookPoint
{
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  ///< [m] odometry frame
  double radius = 0.0;                                  ///< [m]
  int id = -1;
};

/**
 * @brief The trunks of @p sweep as looks in the odometry frame, carried to @p t_mid (sweepObservations) and placed by
 * the odometry there: what a skipped sweep keeps for the next update's fusion.
 */
std::vector<LookPoint> sweepLooks(const TrunkSweep& sweep, const OdometryBuffer& odometry, double t_mid);

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

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_TRUNK_SLAM_TRUNK_SWEEP_H
