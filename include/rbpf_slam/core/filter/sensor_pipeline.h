#ifndef RBPF_SLAM_CORE_FILTER_SENSOR_PIPELINE_H
#define RBPF_SLAM_CORE_FILTER_SENSOR_PIPELINE_H

#include <algorithm>
#include <cmath>
#include <deque>
#include <utility>
#include <vector>

#include "rbpf_slam/core/filter/odometry_buffer.h"
#include "rbpf_slam/core/filter/pipeline_timing.h"
#include "rbpf_slam/core/filter/pose2.h"
#include "rbpf_slam/core/filter/stamp_gate.h"

namespace rbpf_slam
{
namespace core
{
/**
 * @brief What every filter pipeline does with time, once: odometry and sensor stamps through one TimelineGate
 * (late, duplicate and non-finite stamps dropped; a jump back beyond the threshold flushes the waiting items with
 * the odometry they have, then restarts), sensor items waiting until odometry covers them (or
 * PipelineTiming::odometry_wait on the caller's clock, or a flush), bounded waiting, and odometry kept only as far
 * back as the next item needs. A pipeline derives from it and says how one item updates its filter (update())
 * and how its filter starts over (resetFilter()). @p Update needs `double stamp` and `int timeline`.
 */
template <typename Item, typename Update>
class SensorPipeline
{
public:
  virtual ~SensorPipeline() = default;

  /**
   * @brief One odometry pose at @p stamp [s]; @p clock is the caller's current time (NaN: none). kInvalid for a
   * non-finite pose; kReset when the pipeline restarted on this message (it is then used).
   */
  StampVerdict addOdometry(double stamp, const Pose2& pose, double clock = NAN)
  {
    if (!std::isfinite(pose.x) || !std::isfinite(pose.y) || !std::isfinite(pose.theta))
      return StampVerdict::kInvalid;
    const StampVerdict v = check(TimelineGate::kOdometry, stamp, clock);
    if (v == StampVerdict::kAccept || v == StampVerdict::kReset)
      odometry_.add(stamp, pose);
    return v;
  }

  /** @brief The filter on the items that odometry covers (or that waited long enough by @p now; all with
   * @p flush), with any that a restart flushed before them. */
  std::vector<Update> process(double now = NAN, bool flush = false)
  {
    std::vector<Update> done;
    done.swap(flushed_);
    while (!pending_.empty() && !odometry_.empty())
    {
      const Pending& front = pending_.front();
      const bool covered = odometry_.covers(front.end);
      const bool waited =
          std::isfinite(now) && std::isfinite(front.arrival) && now - front.arrival >= timing_.odometry_wait;
      if (!covered && !waited && !flush)
        break;
      Pending p = std::move(pending_.front());
      pending_.pop_front();
      Update u = update(std::move(p.item), covered);
      u.timeline = gate_.restarts();
      // Odometry older than what the next item needs is no longer kept.
      const double keep_from = pending_.empty() ? u.stamp : std::min(u.stamp, pending_.front().start);
      odometry_.dropBefore(keep_from - timing_.odometry_margin);
      done.push_back(std::move(u));
    }
    return done;
  }

  const OdometryBuffer& odometry() const { return odometry_; }
  /** @brief While no item waits, odometry before @p stamp is forgotten (the last sample at or before it is kept): a
   * source whose sensor is silent must not make memory grow. An item stamped before @p stamp then has the kept
   * sample's pose. */
  void forgetOdometryBefore(double stamp)
  {
    if (pending_.empty())
      odometry_.dropBefore(stamp);
  }
  int restarts() const { return gate_.restarts(); }
  std::size_t pending() const { return pending_.size(); }
  /** @brief [s] up to where each waiting item needs odometry, oldest first. */
  std::vector<double> waitingEnds() const
  {
    std::vector<double> ends;
    ends.reserve(pending_.size());
    for (const Pending& p : pending_)
      ends.push_back(p.end);
    return ends;
  }
  /** @brief Items dropped because more than max_pending waited for odometry. */
  std::size_t droppedPending() const { return dropped_pending_; }
  const PipelineTiming& timing() const { return timing_; }

protected:
  explicit SensorPipeline(const PipelineTiming& timing) : timing_(timing), gate_(timing.time_jump_threshold) {}

  /** @brief The stamp rule for a sensor message (restarts on a jump back): kAccept and kReset admit it. */
  StampVerdict admitSensor(double stamp, double clock) { return check(TimelineGate::kSensor, stamp, clock); }
  /** @brief An admitted item, its data from @p start [s] to @p end (odometry must cover @p end). */
  void enqueue(Item item, double start, double end, double arrival)
  {
    pending_.push_back({ std::move(item), start, end, arrival });
    while (pending_.size() > timing_.max_pending)  // no odometry at all: memory must not grow
    {
      pending_.pop_front();
      ++dropped_pending_;
    }
  }
  /** @brief One item through the filter; @p covered false: processed after waiting, odometry ends before it. */
  virtual Update update(Item&& item, bool covered) = 0;
  /** @brief The filter (and whatever else holds the old timeline) starts over. */
  virtual void resetFilter() = 0;

  OdometryBuffer odometry_;

private:
  struct Pending
  {
    Item item;
    double start, end, arrival;
  };
  StampVerdict check(TimelineGate::Stream stream, double stamp, double clock)
  {
    const StampVerdict v = gate_.check(stream, stamp, clock);
    if (v == StampVerdict::kReset)
    {
      // The old timeline's items with the old timeline's odometry, then everything starts over.
      for (Update& u : process(NAN, true))
      {
        u.timeline = gate_.restarts() - 1;
        flushed_.push_back(std::move(u));
      }
      resetFilter();
      odometry_ = OdometryBuffer();
    }
    return v;
  }

  PipelineTiming timing_;
  TimelineGate gate_;
  std::deque<Pending> pending_;
  std::vector<Update> flushed_;  ///< updates of the items a restart flushed, for the next process()
  std::size_t dropped_pending_ = 0;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FILTER_SENSOR_PIPELINE_H
