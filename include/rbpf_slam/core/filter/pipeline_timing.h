#ifndef RBPF_SLAM_CORE_FILTER_PIPELINE_TIMING_H
#define RBPF_SLAM_CORE_FILTER_PIPELINE_TIMING_H

#include <cstddef>
#include <limits>

namespace rbpf_slam
{
namespace core
{
/** @brief How a pipeline treats time, the same in the node and offline. */
struct PipelineTiming
{
  /// [s] a stamp further back than this restarts the filter (core::StampGate); less is dropped as late.
  double time_jump_threshold = 1.0;
  /// [s] on the caller's clock, how long a sweep waits for odometry that covers it; then the newest odometry is
  /// used (extrapolated as constant). Infinite: it waits until odometry covers it or the input ends (flush).
  double odometry_wait = std::numeric_limits<double>::infinity();
  /// Sweeps waiting for odometry beyond this are dropped, oldest first (no odometry at all must not grow memory).
  std::size_t max_pending = 100;
  /// [s] odometry older than what the next waiting sweep needs, less this margin, is forgotten.
  double odometry_margin = 0.1;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FILTER_PIPELINE_TIMING_H
