#ifndef RBPF_SLAM_CORE_FOREST_MAP_LOOP_DETECTION_H
#define RBPF_SLAM_CORE_FOREST_MAP_LOOP_DETECTION_H

#include <string>
#include <vector>

#include "rbpf_slam/core/fastslam/landmark_map.h"
#include "rbpf_slam/core/filter/pose2.h"
#include "rbpf_slam/core/forest_map/constellation.h"
#include "rbpf_slam/core/forest_map/loop_closure_config.h"

namespace rbpf_slam
{
namespace core
{
/** @brief A revisit found: the rigid correction that carries the recent trees onto the old ones. */
struct LoopClosure
{
  bool found = false;       ///< confirmed on this search
  Pose2 correction;         ///< map -> map: where the recent part of the map should lie
  int recent = 0;           ///< recent trees searched with
  int old = 0;              ///< old trees they were matched against
  int inliers = 0;          ///< recent trees the correction puts on an old tree
  double rms = 0.0;         ///< [m] of their distances after the refit
  int agreeing = 0;         ///< consecutive searches that agree so far
  std::vector<std::pair<int, int>> merged;  ///< (recent id, old id): trees the loop shows to be one
  std::string reason;       ///< why not found (or empty)
};

/**
 * @brief Loop detection within a run from the tree map itself: the trees first seen recently (around the robot) are
 * matched by constellation (pairs, radii) against the trees not seen for a while (the map made long ago). A revisit
 * after drift shows as the same constellation displaced by a rigid transform. A false loop is the worst failure, so
 * a loop is reported only when the matcher accepts it (enough inliers, no ambiguous runner-up), it moves the trees by
 * more than the association could absorb, and confirmations consecutive searches agree on it. ROS-free and
 * deterministic.
 */
class LoopDetector
{
public:
  explicit LoopDetector(const LoopConfig& config = LoopConfig()) : config_(config) {}

  /** @brief One search in @p map at the filter's time @p now [s], the robot at @p robot (map frame); @p archived are
   * old trees the map no longer holds (LoopClosing keeps them: a drifted robot misses the trees it mapped long ago
   * where it believes they stand, and the filter deletes them just before they could close the loop). */
  LoopClosure search(const LandmarkMap& map, double now, const Eigen::Vector2d& robot,
                     const std::vector<Landmark>& archived = {});
  /** @brief Forgets the searches that agreed so far (e.g. after a loop was applied). */
  void reset() { agreeing_ = 0; }

private:
  LoopConfig config_;
  Pose2 last_;
  int agreeing_ = 0;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FOREST_MAP_LOOP_DETECTION_H
