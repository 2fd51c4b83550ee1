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
  bool covers(double t) const { return !samples_.empty() && samples_.back().stamp >= t - kCoverTolerance; }
  /// [s] a sample this little before a stamp covers it (stamps printed to the microsecond)
  static constexpr double kCoverTolerance = 1e-6;

  /**
   * @brief Pose at @p t: the first sample that covers t (covers()' tolerance) when it is at or before t, else the
   * pose between it and the one before; the first/last one outside. So the pose at t is what it was when that sample
   * was the newest: it does not depend on the samples that came after it.
   */
  Pose2 at(double t) const
  {
    if (samples_.empty())
      return Pose2();
    const auto it = std::lower_bound(samples_.begin(), samples_.end(), t - kCoverTolerance,
                                     [](const Sample& s, double v) { return s.stamp < v; });
    if (it == samples_.end())
      return samples_.back().pose;
    if (it->stamp <= t || it == samples_.begin())
      return it->pose;
    const Sample& a = *(it - 1);
    const Sample& b = *it;
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
