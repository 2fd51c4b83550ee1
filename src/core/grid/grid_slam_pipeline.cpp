#include "rbpf_slam/core/grid/grid_slam_pipeline.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <utility>

namespace rbpf_slam
{
namespace core
{
namespace
{
constexpr double kStampTolerance = 1e-6;  ///< [s] stamps this close count as the same instant (OdometryBuffer's)
}  // namespace

GridSlamPipeline::GridSlamPipeline(const GridSlamConfig& config, const PipelineTiming& timing)
  : SensorPipeline(timing), filter_(GridSlam::create(config))
{
}

void GridSlamPipeline::enqueueScan(double stamp, ScanData scan, const Pose2& sensor, double arrival)
{
  enqueue(GridScan{ stamp, std::move(scan), sensor }, stamp, stamp, arrival);
}

StampVerdict GridSlamPipeline::addScan(double stamp, ScanData scan, const Pose2& sensor, double clock, double arrival)
{
  const StampVerdict v = admitScan(stamp, clock);
  if (v == StampVerdict::kAccept || v == StampVerdict::kReset)
    enqueueScan(stamp, std::move(scan), sensor, arrival);
  return v;
}

GridPipelineUpdate GridSlamPipeline::update(GridScan&& item, bool covered)
{
  GridPipelineUpdate u;
  u.stamp = item.stamp;
  u.odometry_covered = covered;
  u.odometry = odometry_.at(item.stamp);
  const auto t0 = std::chrono::steady_clock::now();
  const bool stopped = filter_->initialised() && !odometry_.empty() &&
                       item.stamp - odometry_.latest() > kOdometryStopped;
  if (stopped)
  {
    // The robot may be moving while its pose cannot be told: the scan is left out, the map kept.
    u.odometry_stopped = true;
    u.outage_began = outage_.scans == 0;
    if (u.outage_began)
      outage_.since = odometry_.latest();
    ++outage_.scans;
    outage_.last_scan = item.stamp;
    u.step.skipped = true;
    u.estimate = filter_->poseAt(u.odometry);
    u.map_to_odom = filter_->mapToOdom();
    return u;
  }
  if (outage_.scans > 0)
  {
    u.outage_seconds = item.stamp - outage_.since;
    u.outage_scans = outage_.scans;
    outage_ = Outage();
  }
  try
  {
    // No odometry before the scan: its pose would be a guess (TF refuses to extrapolate into the past too).
    if (item.stamp < odometry_.earliest() - kStampTolerance)
      throw std::invalid_argument("the scan is older than the first odometry");
    u.step = filter_->update(u.odometry, item.scan, item.sensor, item.stamp);
  }
  catch (const std::exception& e)  // refused before anything changed (GridSlam::update)
  {
    u.error = e.what();
  }
  const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  seconds_filter_ += dt;
  worst_seconds_ = std::max(worst_seconds_, dt);
  u.estimate = filter_->poseAt(u.odometry);
  u.map_to_odom = filter_->mapToOdom();
  return u;
}

}  // namespace core
}  // namespace rbpf_slam
