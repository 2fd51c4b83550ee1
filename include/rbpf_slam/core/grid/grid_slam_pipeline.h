#ifndef RBPF_SLAM_CORE_GRID_GRID_SLAM_PIPELINE_H
#define RBPF_SLAM_CORE_GRID_GRID_SLAM_PIPELINE_H

#include <cmath>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "rbpf_slam/core/grid/grid_slam.h"
#include "rbpf_slam/core/filter/sensor_pipeline.h"

namespace rbpf_slam
{
namespace core
{
/** @brief A scan waiting for its odometry. */
struct GridScan
{
  double stamp = 0.0;
  ScanData scan;
  Pose2 sensor;  ///< the scanner on base_link
};

/** @brief One scan through the pipeline. */
struct GridPipelineUpdate
{
  double stamp = 0.0;  ///< [s] the scan's
  Pose2 odometry;      ///< odometry at the scan
  Pose2 estimate;      ///< the robot's pose in the map at the scan (GridSlam::poseAt)
  Pose2 map_to_odom;   ///< map -> odom after the scan
  GridSlamStep step;
  int timeline = 0;  ///< restarts before this scan (a restart flushes the old timeline's scans)
  bool odometry_covered = true;  ///< false: processed after waiting, with odometry that ends before the scan
  /// The odometry stopped: the scan is more than kOdometryStopped past the newest odometry. It is not used (the
  /// robot may be moving while its pose cannot be told): the map and the particles are kept, the estimate is held.
  bool odometry_stopped = false;
  /// This scan began an outage of the odometry (the first with odometry_stopped): report it once.
  bool outage_began = false;
  /// This scan, covered again, ended an outage: how long the odometry was missing [s] (from the newest odometry
  /// before it to this scan) and the scans it kept out of the map; 0 otherwise.
  double outage_seconds = 0.0;
  int outage_scans = 0;
  /// Non-empty when the filter refused the scan (a non-finite pose, a scan out of any map's reach): nothing
  /// changed, the scan is dropped, and this says why.
  std::string error;
};

/**
 * @brief Grid SLAM on stamped scans and odometry poses, ROS-free: the one pipeline of the grid nodelet (odometry
 * from TF at each scan's stamp) and of the bag runner (odometry messages, or wheels and gyro).
 *
 * - Time (SensorPipeline): late, duplicate and non-finite stamps are dropped; a jump back beyond the threshold
 *   flushes the waiting scans with the odometry they have and restarts the map; a scan waits until odometry
 *   covers its stamp (or PipelineTiming::odometry_wait on the caller's clock); the odometry pose at the stamp is
 *   interpolated; a scan older than the first odometry is dropped.
 * - The map frame is the odometry frame at the first scan (map -> odom starts as the identity).
 */
/** @brief The map of a timeline that a restart (time jumping back) ended. */
struct GridTimelineMap
{
  int timeline = 0;  ///< restarts before it (0: the first timeline)
  OccupancyImage map;
};

class GridSlamPipeline : public SensorPipeline<GridScan, GridPipelineUpdate>
{
public:
  /// [s] a scan further than this past the newest odometry finds the odometry stopped (GridPipelineUpdate).
  static constexpr double kOdometryStopped = 0.5;
  /** @brief An outage of the odometry that has not ended: since when [s] (the newest odometry) and the scans it
   * kept out of the map so far; scans 0 when there is none. */
  struct Outage
  {
    double since = 0.0, last_scan = 0.0;
    int scans = 0;
  };
  const Outage& outage() const { return outage_; }

  /** @throws std::invalid_argument when @p config is not valid. */
  explicit GridSlamPipeline(const GridSlamConfig& config, const PipelineTiming& timing = PipelineTiming());

  /** @brief A scan taken by the sensor at @p sensor on base_link; @p arrival on the caller's clock. The same as
   * admitScan() then, when admitted, enqueueScan(). */
  StampVerdict addScan(double stamp, ScanData scan, const Pose2& sensor, double clock = NAN, double arrival = NAN);
  /** @brief The stamp rule for a scan on its arrival (a node that must first wait for the scan's odometry in TF):
   * kAccept or kReset (restarted here) admit it. */
  StampVerdict admitScan(double stamp, double clock = NAN) { return admitSensor(stamp, clock); }
  /** @brief An admitted scan into the queue that waits for odometry. */
  void enqueueScan(double stamp, ScanData scan, const Pose2& sensor, double arrival = NAN);

  const GridSlam& filter() const { return *filter_; }
  /** @brief The maps that restarts ended since the last call (only the latest is kept when nobody takes them: a
   * map image can be large): a restart starts a new map, and the old one is the caller's to save. */
  std::vector<GridTimelineMap> takeEndedMaps()
  {
    std::vector<GridTimelineMap> ended;
    ended.swap(ended_);
    return ended;
  }
  double secondsFilter() const { return seconds_filter_; }
  /** @brief The longest one update() took [s]. */
  double worstSeconds() const { return worst_seconds_; }

private:
  GridPipelineUpdate update(GridScan&& scan, bool covered) override;
  void resetFilter() override
  {
    if (filter_->initialised() && filter_->map().tileCount() > 0)
    {
      ended_.clear();
      ended_.push_back({ restarts() - 1, filter_->map().toImage() });
    }
    filter_->reset();
    outage_ = Outage();
  }

  std::unique_ptr<GridSlam> filter_;
  Outage outage_;
  std::vector<GridTimelineMap> ended_;
  double seconds_filter_ = 0.0, worst_seconds_ = 0.0;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_GRID_GRID_SLAM_PIPELINE_H
