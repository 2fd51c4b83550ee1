#ifndef RBPF_SLAM_CORE_TRUNK_SLAM_PIPELINE_H
#define RBPF_SLAM_CORE_TRUNK_SLAM_PIPELINE_H

#include <cmath>
#include <deque>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/fastslam.h"
#include "rbpf_slam/core/odometry_buffer.h"
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

/** @brief One sweep after extraction and the filter update. */
struct PipelineUpdate
{
  double stamp = 0.0;                 ///< [s] the sweep's middle, where the filter updated
  Pose2 odometry;                     ///< odometry at that instant
  std::vector<TrunkObservation> trunks;  ///< as extracted (sensor frame, levelled)
  FastSlamUpdateStats stats;
};

/**
 * @brief The observations of one sweep at the instant @p t_ref: each trunk (sensor frame, levelled, seen
 * during the sweep that starts at @p stamp and lasts @p period) is moved by the lever arm of the tilt the
 * detector removed (mount.z * (tan pitch, -tan roll)), then carried from its own instant (bearing b at
 * (b + pi) / 2 pi of the sweep) to @p t_ref by the odometry between the two.
 */
std::vector<LandmarkObservation> sweepObservations(const std::vector<TrunkObservation>& trunks, double stamp,
                                                   double period, double tilt_roll, double tilt_pitch,
                                                   const SensorMount& mount, const OdometryBuffer& odometry,
                                                   double t_ref, const SweepGeometry& geometry = SweepGeometry());

/**
 * @brief Trunk extraction and FastSLAM on sweeps and wheel odometry, shared by every offline runner (the
 * simulator runner and the bag runner), ROS-free.
 *
 * Odometry may arrive late: a sweep waits until odometry covers its end. Each trunk is seen at its own
 * instant of the sweep (bearing b at (b - start_angle) / span of the sweep; a spinning lidar starts behind);
 * it is carried to the sweep's middle by the odometry between the two instants, and the filter
 * updates there. On a tilted body the lidar on its mast is not above base_link: the tilt estimated by the
 * detector moves the trunks by mount.z * (tan pitch, -tan roll).
 */
class TrunkSlamPipeline
{
public:
  TrunkSlamPipeline(const TrunkDetectorConfig& detector, const FastSlamConfig& filter, const SensorMount& mount);

  /** @brief False (sample dropped) when the stamp goes backwards. */
  bool addOdometry(double stamp, const Pose2& pose);
  /** @brief Extracts the trunks now (points in the sensor frame) and queues the sweep for the filter. */
  void addSweep(double stamp, double period, const std::vector<Eigen::Vector3f>& points);
  /** @brief The same for a 2D scan (sensor frame; no levelling: the scanner is taken as level); @p period is
   * the time from the first beam to the last. */
  void addScan(double stamp, double period, const PlanarScan& scan);
  /** @brief Runs the filter on the queued sweeps that odometry covers (all of them with @p flush). */
  std::vector<PipelineUpdate> process(bool flush = false);

  const FastSlam& filter() const { return filter_; }
  double secondsExtraction() const { return seconds_extraction_; }
  double secondsFilter() const { return seconds_filter_; }

private:
  struct Pending
  {
    double stamp, period, tilt_roll, tilt_pitch;
    SweepGeometry geometry;
    std::vector<TrunkObservation> trunks;
  };
  TrunkDetector detector_;
  FastSlam filter_;
  SensorMount mount_;
  OdometryBuffer odometry_;
  std::deque<Pending> pending_;
  bool initialized_ = false;
  Pose2 last_odometry_;
  double seconds_extraction_ = 0.0, seconds_filter_ = 0.0;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_TRUNK_SLAM_PIPELINE_H
