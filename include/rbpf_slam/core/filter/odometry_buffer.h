#ifndef RBPF_SLAM_CORE_FILTER_ODOMETRY_BUFFER_H
#define RBPF_SLAM_CORE_FILTER_ODOMETRY_BUFFER_H

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <deque>

#include "rbpf_slam/core/filter/pose2.h"

namespace rbpf_slam
{
namespace core
{
/**
 * @brief Planar odometry poses by time stamp, for consumers whose observations arrive before the
 * odometry that covers them: linear interpolation of position, shortest-arc of heading; clamped at the ends.
 * Stamps must increase: an older stamp is refused (kBackwards), one within 1 us of the newest is a repeat.
 */
class OdometryBuffer
{
public:
  enum class AddResult
  {
    kAdded,
    kRepeated,
    kBackwards
  };

  AddResult add(double stamp, const Pose2& pose)
  {
    if (!samples_.empty())
    {
      const double last = samples_.back().stamp;
      if (std::abs(stamp - last) < 1e-6)
        return AddResult::kRepeated;
      if (stamp < last)
        return AddResult::kBackwards;
    }
    samples_.push_back({ stamp, pose });
    return AddResult::kAdded;
  }

  bool empty() const { return samples_.empty(); }
  std::size_t size() const { return samples_.size(); }
  /** @brief Newest stamp (undefined when empty). */
  double latest() const { return samples_.back().stamp; }
  /** @brief Oldest stamp (undefined when empty). */
  double earliest() const { return samples_.front().stamp; }
  /** @brief True when a sample at or after @p t is present (so at(t) interpolates, not extrapolates). */
  bool covers(double t) const { return !samples_.empty() && samples_.back().stamp >= t - 1e-6; }

  /** @brief Pose at @p t: interpolated between the samples around it, the first/last one outside. */
  Pose2 at(double t) const
  {
    if (samples_.empty())
      return Pose2();
    if (t <= samples_.front().stamp)
      return samples_.front().pose;
    if (t >= samples_.back().stamp)
      return samples_.back().pose;
    const auto it = std::lower_bound(samples_.begin(), samples_.end(), t,
                                     [](const Sample& s, double v) { return s.stamp < v; });
    const Sample& b = *it;
    const Sample& a = *(it - 1);
    const double s = (t - a.stamp) / std::max(1e-12, b.stamp - a.stamp);
    return interpolate(a.pose, b.pose, s);
  }

  /** @brief Calls @p f(stamp, pose) for every sample strictly between @p t0 and @p t1, oldest first. */
  template <typename F>
  void forEachBetween(double t0, double t1, F f) const
  {
    auto it = std::upper_bound(samples_.begin(), samples_.end(), t0,
                               [](double v, const Sample& s) { return v < s.stamp; });
    for (; it != samples_.end() && it->stamp < t1; ++it)
      f(it->stamp, it->pose);
  }

  /** @brief Forgets samples no longer needed for times >= @p t (keeps the last one at or before t). */
  void dropBefore(double t)
  {
    while (samples_.size() > 1 && samples_[1].stamp <= t)
      samples_.pop_front();
  }

  void clear() { samples_.clear(); }

private:
  struct Sample
  {
    double stamp;
    Pose2 pose;
  };
  std::deque<Sample> samples_;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FILTER_ODOMETRY_BUFFER_H
