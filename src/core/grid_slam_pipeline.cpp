#include "rbpf_slam/core/grid_slam_pipeline.h"

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
  : timing_(timing), filter_(GridSlam::create(config)), gate_(timing.time_jump_threshold)
{
}

void GridSlamPipeline::restart()
{
  // The old timeline's scans with the old timeline's odometry, then a new map (same seed as built).
  for (GridPipelineUpdate& u : process(NAN, true))
  {
    u.timeline = gate_.restarts() - 1;
    flushed_.push_back(std::move(u));
  }
  filter_->reset();
  odometry_ = OdometryBuffer();
}

StampVerdict GridSlamPipeline::addOdometry(double stamp, const Pose2& pose, double clock)
{
  if (!std::isfinite(pose.x) || !std::isfinite(pose.y) || !std::isfinite(pose.theta))
    return StampVerdict::kInvalid;
  const StampVerdict v = gate_.check(TimelineGate::kOdometry, stamp, clock);
  if (v == StampVerdict::kReset)
    restart();
  if (v == StampVerdict::kAccept || v == StampVerdict::kReset)
    odometry_.add(stamp, pose);
  return v;
}

StampVerdict GridSlamPipeline::admitScan(double stamp, double clock)
{
  const StampVerdict v = gate_.check(TimelineGate::kSensor, stamp, clock);
  if (v == StampVerdict::kReset)
    restart();
  return v;
}

void GridSlamPipeline::enqueueScan(double stamp, ScanData scan, const Pose2& sensor, double arrival)
{
  pending_.push_back({ stamp, std::move(scan), sensor, arrival });
  while (pending_.size() > timing_.max_pending)
  {
    pending_.pop_front();
    ++dropped_pending_;
  }
}

StampVerdict GridSlamPipeline::addScan(double stamp, ScanData scan, const Pose2& sensor, double clock, double arrival)
{
  const StampVerdict v = admitScan(stamp, clock);
  if (v == StampVerdict::kAccept || v == StampVerdict::kReset)
    enqueueScan(stamp, std::move(scan), sensor, arrival);
  return v;
}

std::vector<GridPipelineUpdate> GridSlamPipeline::process(double now, bool flush)
{
  std::vector<GridPipelineUpdate> done;
  done.swap(flushed_);
  while (!pending_.empty() && !odometry_.empty())
  {
    const Pending& front = pending_.front();
    const bool waited =
        std::isfinite(now) && std::isfinite(front.arrival) && now - front.arrival >= timing_.odometry_wait;
    if (!odometry_.covers(front.stamp) && !waited && !flush)
      break;
    GridPipelineUpdate u;
    u.stamp = front.stamp;
    u.odometry = odometry_.at(front.stamp);
    const auto t0 = std::chrono::steady_clock::now();
    try
    {
      // No odometry before the scan: its pose would be a guess (TF refuses to extrapolate into the past too).
      if (front.stamp < odometry_.earliest() - kStampTolerance)
        throw std::invalid_argument("the scan is older than the first odometry");
      u.step = filter_->update(u.odometry, front.scan, front.sensor, front.stamp);
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
    u.timeline = gate_.restarts();
    pending_.pop_front();
    const double keep_from = pending_.empty() ? u.stamp : std::min(u.stamp, pending_.front().stamp);
    odometry_.dropBefore(keep_from - timing_.odometry_margin);
    done.push_back(std::move(u));
  }
  return done;
}

}  // namespace core
}  // namespace rbpf_slam
