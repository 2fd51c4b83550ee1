#ifndef RBPF_SLAM_CORE_TRUNK_SLAM_PIPELINE_H
#define RBPF_SLAM_CORE_TRUNK_SLAM_PIPELINE_H

#include <cmath>
#include <deque>
#include <limits>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/fastslam.h"
#include "rbpf_slam/core/odometry_buffer.h"
#include "rbpf_slam/core/pipeline_timing.h"
#include "rbpf_slam/core/stamp_gate.h"
#include "rbpf_slam/core/trunk_detector.h"

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
  std::vector<TrunkObservation> trunks;  ///< sensor frame, levelled
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

/**
 * @brief Trunk extraction and FastSLAM on stamped sweeps and wheel odometry, ROS-free: the one pipeline of the
 * FastSLAM nodelet (fed with TrunkArray messages: addTrunks) and of every offline runner (the bag runner and the
 * simulator runner: addSweep / addScan extract the trunks here).
 *
 * - Time: each stream's stamps go through one TimelineGate: late, duplicate and non-finite stamps are dropped, a
 *   jump back beyond the threshold restarts the pipeline (waiting sweeps are flushed with the odometry they have,
 *   then filter and detector start over with their seeds).
 * - Odometry may arrive late: a sweep waits until odometry covers its end (or PipelineTiming::odometry_wait).
 * - The map frame is the odometry frame at the first sweep's middle: the particles start at that odometry pose,
 *   so map -> odom starts as the identity (REP-105).
 * - Each trunk is seen at its own instant of the sweep (bearing b at (b - start_angle) / span; a spinning lidar
 *   starts behind), carried to the sweep's middle by the odometry between the two instants, and moved by the
 *   lever arm of the tilt the detector removed; the filter updates there.
 */
class TrunkSlamPipeline
{
public:
  TrunkSlamPipeline(const TrunkDetectorConfig& detector, const FastSlamConfig& filter,
                    const PipelineTiming& timing = PipelineTiming());

  /**
   * @brief One odometry pose at @p stamp [s]; @p clock is the caller's current time (NaN: none). kInvalid for a
   * non-finite pose; kReset when the pipeline restarted on this message (it is then used).
   */
  StampVerdict addOdometry(double stamp, const Pose2& pose, double clock = NAN);
  /** @brief Trunks a detector found (e.g. a TrunkArray); @p arrival on the caller's clock (see odometry_wait). */
  StampVerdict addTrunks(TrunkSweep sweep, double clock = NAN, double arrival = NAN);
  /** @brief Extracts the trunks of a 3D sweep (points in the sensor frame, @p period from its per-point times). */
  StampVerdict addSweep(double stamp, double period, const std::vector<Eigen::Vector3f>& points,
                        const SensorMount& mount, double clock = NAN, double arrival = NAN);
  /** @brief The same for a 2D scan (no levelling: the scanner is taken as level); @p period is the time from the
   * first beam to the last; the sweep's geometry is the scan's angles. */
  StampVerdict addScan(double stamp, double period, const PlanarScan& scan, const SensorMount& mount,
                       double clock = NAN, double arrival = NAN);
  /**
   * @brief Runs the filter on the waiting sweeps that odometry covers, or that have waited odometry_wait by
   * @p now (all of them with @p flush), and returns them with any a restart flushed.
   */
  std::vector<PipelineUpdate> process(double now = NAN, bool flush = false);

  const FastSlam& filter() const { return *filter_; }
  bool initialized() const { return initialized_; }
  /** @brief The odometry pose of the last update (map -> odom = filter pose * its inverse). */
  const Pose2& lastOdometry() const { return last_odometry_; }
  const OdometryBuffer& odometry() const { return odometry_; }
  int restarts() const { return gate_.restarts(); }
  std::size_t pending() const { return pending_.size(); }
  /** @brief Sweeps dropped because more than max_pending waited for odometry. */
  std::size_t droppedPending() const { return dropped_pending_; }
  double secondsExtraction() const { return seconds_extraction_; }
  double secondsFilter() const { return seconds_filter_; }
  const PipelineTiming& timing() const { return timing_; }

private:
  struct Pending
  {
    TrunkSweep sweep;
    double arrival;
  };
  /** @brief The stamp rule for a sensor message; restarts the pipeline on a jump back. */
  StampVerdict admitSensor(double stamp, double clock);
  void restart();
  void enqueue(TrunkSweep sweep, double arrival);
  PipelineUpdate update(Pending p, bool covered);

  TrunkDetectorConfig detector_config_;
  FastSlamConfig filter_config_;
  PipelineTiming timing_;
  std::unique_ptr<TrunkDetector> detector_;
  std::unique_ptr<FastSlam> filter_;
  TimelineGate gate_;
  OdometryBuffer odometry_;
  std::deque<Pending> pending_;
  std::vector<PipelineUpdate> flushed_;  ///< updates of the sweeps a restart flushed, for the next process()
  bool initialized_ = false;
  Pose2 last_odometry_;
  std::size_t dropped_pending_ = 0;
  double seconds_extraction_ = 0.0, seconds_filter_ = 0.0;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_TRUNK_SLAM_PIPELINE_H
