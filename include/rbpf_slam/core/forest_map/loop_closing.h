#ifndef RBPF_SLAM_CORE_FOREST_MAP_LOOP_CLOSING_H
#define RBPF_SLAM_CORE_FOREST_MAP_LOOP_CLOSING_H

#include <map>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/fastslam/fastslam.h"
#include "rbpf_slam/core/forest_map/loop_closure_config.h"
#include "rbpf_slam/core/forest_map/loop_detection.h"
#include "rbpf_slam/core/forest_map/trunk_smoother.h"

namespace rbpf_slam
{
namespace core
{
/** @brief What loop closure did at one update. */
struct LoopEvent
{
  enum class Kind
  {
    kNone,      ///< no loop found (or none searched for) at this update
    kClosed,    ///< a loop was found, smoothed and applied: the particles were drawn again
    kRejected,  ///< a loop was found but the smoother refused it (reason): the filter is as it was
  };
  Kind kind = Kind::kNone;
  Pose2 correction;      ///< the detection's: map -> map, where the recent part of the map lies on the old
  int matched = 0;       ///< trees the detection matched (identities)
  double shift = 0.0;    ///< [m] how far the smoother moved the robot's pose
  double seconds = 0.0;  ///< the solve's
  double seconds_covariance = 0.0;  ///< ... of which the marginal covariance
  int keyframes = 0;
  double identity_chi2 = 0.0, identity_bound = 0.0;
  std::string reason;
  /// The matched trees (recent, old positions, in the map before the loop), e.g. to show the loop.
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> links;
};
const char* toString(LoopEvent::Kind k);

/**
 * @brief Loop closure within one run of the filter: after each update it records what the filter took (for the
 * smoother), searches the best particle's map for a revisit every search_interval (LoopDetector), and on a
 * confirmed one smooths the best particle's path and trees with the loop's identities (TrunkSmoother). The old trees
 * it searches include those the filter has deleted since they became old (a drifted robot misses them where it
 * believes they stand): a loop brings them back, merged with the trees seen again. A consistent
 * solve within its budget is applied: the particles are drawn again around the smoothed pose, with the smoothed
 * map and path; anything else leaves the filter as it was. The solve runs in the update that confirmed the loop
 * (so that one seed gives one result): its cost is bounded by max_iterations and stated by LoopEvent::seconds.
 * ROS-free.
 */
class LoopClosing
{
public:
  LoopClosing(const LoopClosureConfig& config, const FastSlamConfig& filter);

  /** @brief Forgets the run (the filter started over). */
  void reset();
  /**
   * @brief After the filter's update at @p stamp with odometry @p odometry, its sensor at @p mount on base_link,
   * the observations @p observations of evidence share @p share: records it, and searches for a loop when due.
   */
  LoopEvent afterUpdate(FastSlam* filter, double stamp, const Pose2& odometry, const Pose2& mount,
                        const std::vector<LandmarkObservation>& observations, double share);
  /** @brief The run smoothed as it stands (no new loop): the best particle's path and trees. */
  SmoothedRun smoothRun(const FastSlam& filter) const;

  int closed() const { return closed_; }
  int rejected() const { return rejected_; }
  const LoopClosureConfig& config() const { return config_; }

private:
  LoopClosureConfig config_;
  LoopDetector detector_;
  TrunkSmoother smoother_;
  double last_search_ = -1e300;
  double retry_after_ = -1e300;  ///< [s] no search before (after a refused loop)
  /// Confirmed trees of the best particle's map once old (not seen for old_time), by id, kept after the filter
  /// deletes them; dropped when seen again.
  std::map<int, Landmark> archive_;
  int closed_ = 0, rejected_ = 0;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FOREST_MAP_LOOP_CLOSING_H
