#ifndef RBPF_SLAM_CORE_TRUNK_SLAM_TRUNK_SLAM_CONFIG_H
#define RBPF_SLAM_CORE_TRUNK_SLAM_TRUNK_SLAM_CONFIG_H

#include <string>

#include "rbpf_slam/core/fastslam/fastslam.h"
#include "rbpf_slam/core/forest_map/gnss.h"
#include "rbpf_slam/core/forest_map/loop_closure_config.h"

namespace rbpf_slam
{
namespace core
{
/**
 * @brief The trunk SLAM pipeline's configuration: the filter's (FastSlamConfig, which a FastSlam takes alone) and what
 * the pipeline runs around the filter, loop closure and satellite fixes. The filter knows neither.
 */
struct TrunkSlamConfig : FastSlamConfig
{
  TrunkSlamConfig() = default;
  /** @brief @p filter with loop closure and satellite fixes at their defaults (a filter's configuration is a
   * pipeline's). */
  TrunkSlamConfig(const FastSlamConfig& filter) : FastSlamConfig(filter) {}  // NOLINT(google-explicit-constructor)

  /// Loop closure within a run (TrunkSlamPipeline): a revisit found from the trees, the path and map smoothed, the
  /// particles drawn again around the smoothed pose. Not with a saved map (that run's relocalization holds it).
  LoopClosureConfig loop_closure;
  /// Satellite fixes (TrunkSlamPipeline::addFix): the map's anchor fitted to them, and a weak prior on the particles.
  GnssFusionConfig gnss;

  /** @brief The first problem of the filter's values, then of loop closure's and the fixes'; empty when valid. */
  std::string validate() const;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_TRUNK_SLAM_TRUNK_SLAM_CONFIG_H
