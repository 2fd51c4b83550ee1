#ifndef RBPF_SLAM_CORE_GRID_SLAM_PIPELINE_H
#define RBPF_SLAM_CORE_GRID_SLAM_PIPELINE_H

#include <cmath>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "rbpf_slam/core/grid_slam.h"
#include "rbpf_slam/core/odometry_buffer.h"
#include "rbpf_slam/core/pipeline_timing.h"
#include "rbpf_slam/core/stamp_gate.h"

namespace rbpf_slam
{
namespace core
{
/** @brief One scan through the pipeline. */
struct GridPipelineUpdate
{
  double stamp = 0.0;  ///< [s] the scan's
  Pose2 odometry;      ///< odometry at the scan
  Pose2 estimate;      ///< the robot's pose in the map at the scan (GridSlam::poseAt)
  Pose2 map_to_odom;   ///< map -> odom after the scan
  GridSlamStep step;
  int timeline = 0;  ///< restarts before this scan (a restart flushes the old timeline's scans)
  /// Non-empty when the filter refused the scan (a non-finite pose, a scan out of any map's reach): nothing
  /// changed, the scan is dropped, and this says why.
  std::string error;
};

/**
 * @brief Grid SLAM on stamped scans and odometry poses, ROS-free: the one pipeline of the grid nodelet (odometry
 * from TF at each scan's stamp) and of the bag runner (odometry messages, or wheels and gyro).
 *
 * - Time: one TimelineGate for both streams: late, duplicate and non-finite stamps are dropped; a jump back beyond
 *   the threshold flushes the waiting scans with the odometry they have and restarts the map.
 * - A scan waits until odometry covers its stamp (or PipelineTiming::odometry_wait on the caller's clock); the
 *   odometry pose at the stamp is interpolated.
 * - The map frame is the odometry frame at the first scan (map -> odom starts as the identity).
 */
class GridSlamPipeline
{
public:
  /** @throws std::invalid_argument when @p config is not valid. */
  explicit GridSlamPipeline(const GridSlamConfig& config, const PipelineTiming& timing = PipelineTiming());

  /** @brief kInvalid for a non-finite pose; kReset when the map restarted on this message (it is then used). */
  StampVerdict addOdometry(double stamp, const Pose2& pose, double clock = NAN);
  /** @brief A scan taken by the sensor at @p sensor on base_link; @p arrival on the caller's clock. The same as
   * admitScan() then, when admitted, enqueueScan(). */
  StampVerdict addScan(double stamp, ScanData scan, const Pose2& sensor, double clock = NAN, double arrival = NAN);
  /** @brief The stamp rule for a scan on its arrival (a node that must first wait for the scan's odometry in TF):
   * kAccept or kReset (restarted here) admit it. */
  StampVerdict admitScan(double stamp, double clock = NAN);
  /** @brief An admitted scan into the queue that waits for odometry. */
  void enqueueScan(double stamp, ScanData scan, const Pose2& sensor, double arrival = NAN);
  /** @brief Runs the filter on the scans that odometry covers (or that waited long enough by @p now; all with
   * @p flush), with any a restart flushed. */
  std::vector<GridPipelineUpdate> process(double now = NAN, bool flush = false);

  const GridSlam& filter() const { return *filter_; }
  int restarts() const { return gate_.restarts(); }
  std::size_t droppedPending() const { return dropped_pending_; }
  double secondsFilter() const { return seconds_filter_; }
  /** @brief The longest one update() took [s]. */
  double worstSeconds() const { return worst_seconds_; }

private:
  struct Pending
  {
    double stamp;
    ScanData scan;
    Pose2 sensor;
    double arrival;
  };
  void restart();

  PipelineTiming timing_;
  std::unique_ptr<GridSlam> filter_;
  TimelineGate gate_;
  OdometryBuffer odometry_;
  std::deque<Pending> pending_;
  std::vector<GridPipelineUpdate> flushed_;
  std::size_t dropped_pending_ = 0;
  double seconds_filter_ = 0.0, worst_seconds_ = 0.0;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_GRID_SLAM_PIPELINE_H
