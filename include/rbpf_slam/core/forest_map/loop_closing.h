#ifndef RBPF_SLAM_CORE_FOREST_MAP_LOOP_CLOSING_H
#define RBPF_SLAM_CORE_FOREST_MAP_LOOP_CLOSING_H

#include <functional>
#include <future>
#include <map>
#include <memory>
#include <string>
#include <unordered_map>
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
  double found = 0.0;    ///< [s] the update that found the loop (the solve ran from there to this update)
  int found_update = 0;  ///< ... its index (the filter's updates since the start)
  Pose2 correction;      ///< the detection's: map -> map, where the recent part of the map lies on the old
  int matched = 0;       ///< trees the detection matched (identities)
  double shift = 0.0;    ///< [m] how far the smoother moved the robot's pose
  double seconds = 0.0;  ///< the solve's (beside the filter: it does not hold it)
  double seconds_covariance = 0.0;  ///< ... of which the marginal covariance
  int keyframes = 0;
  double identity_chi2 = 0.0, identity_bound = 0.0;
  int dropped = 0;  ///< matched pairs dropped as not fitting the others (identity_chi2 is of the rest)
  /// refused by the smoother as inconsistent (SmoothedRun::inconsistent): the map disagrees with the revisit
  bool inconsistent = false;
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
 * solve is applied: the particles are drawn again around the smoothed pose, with the smoothed map and path;
 * anything else leaves the filter as it was. The solve runs beside the filter (a worker thread, on copies) and is
 * applied apply_after updates after the loop was found, carried to that update by the best particle's own motion
 * since; no search runs meanwhile. The update that applies it waits for the solve if it has not ended, so that the
 * result never depends on the computer's speed: one seed, one answer. Its work is bounded by max_iterations and
 * max_factors, and its time stated by LoopEvent::seconds. ROS-free.
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
  /** @brief The same, as a job to run later, on any thread: it holds copies of what it needs (the records, the
   * path, the trees), so that the caller need not hold the filter while it runs. */
  std::function<SmoothedRun()> smoothingJob(const FastSlam& filter) const;
  /** @brief Whether a solve is under way (its result not applied yet). */
  bool solving() const { return pending_ != nullptr; }
  /**
   * @brief The estimate to publish, from the filter's @p filter_estimate: the latest smoothing of the run (every
   * smooth_interval updates) at the update it started from, carried on by the filter's motion since. The filter's
   * own estimate before the first smoothing and after a loop (the filter is the smoothed estimate then).
   */
  Pose2 published(const Pose2& filter_estimate) const;
  /** @brief The smoother's marginal covariance of the pose the published estimate starts from (zero: none). */
  const Eigen::Matrix3d& publishedCovariance() const { return anchor_covariance_; }
  /** @brief The smoothed pose the published estimate starts from. */
  const Pose2& publishedFrom() const { return anchor_from_; }

  int closed() const { return closed_; }
  int rejected() const { return rejected_; }
  const LoopClosureConfig& config() const { return config_; }

private:
  /** @brief A loop the detection found: its identities, the archived trees it matched, what it found. */
  struct FoundLoop
  {
    bool found = false;
    std::vector<std::pair<int, int>> merged;
    std::vector<Landmark> archived;
    LoopEvent event;
    std::string refused;  ///< why it was refused before any solve (empty: to be solved)
  };
  /** @brief A loop (or the run, to publish its smoothed estimate) being solved beside the filter. */
  struct Pending
  {
    bool loop = true;          ///< a loop; else the run smoothed as it stands
    Pose2 estimate;            ///< the filter's estimate at the update that launched it
    std::future<SmoothedRun> result;
    int apply_at = 0;          ///< the update that applies it
    std::size_t records = 0;   ///< the updates recorded when it was found (the solved path's length)
    std::vector<std::pair<int, int>> merged;
    LoopEvent event;           ///< what the detection found
  };
  /** @brief Applies (or refuses) the loop's solve at @p stamp: the filter redrawn around the smoothed estimate. */
  LoopEvent apply(FastSlam* filter, double stamp, Pending* pending);
  /** @brief Searches the best particle's map for a revisit (the archive kept up to date); true with @p found. */
  bool search(const FastSlam& filter, double stamp, FoundLoop* found);
  /** @brief Why @p loop asks more of the robot's pose than the odometry can drift since its old trees were last
   * seen (drift_quantile); empty when it does not. @p in_map: the best particle's trees' indices by id. */
  std::string beyondDrift(const FastSlam& filter, const LoopClosure& loop, double stamp,
                          const std::unordered_map<int, std::size_t>& in_map) const;
  /** @brief Starts solving @p loop (or, not found, the run as it stands) beside the filter; returns @p applied, or
   * what the solve did when apply_after is 0. */
  LoopEvent launch(FastSlam* filter, double stamp, FoundLoop&& loop, const LoopEvent& applied);

  LoopClosureConfig config_;
  LoopDetector detector_;
  TrunkSmoother smoother_;
  double last_search_ = -1e300;
  double retry_after_ = -1e300;  ///< [s] no search before (after a refused loop)
  /// Confirmed trees of the best particle's map once old (not seen for old_time), by id, kept after the filter
  /// deletes them; dropped when seen again.
  std::map<int, Landmark> archive_;
  int closed_ = 0, rejected_ = 0;
  int updates_ = 0;
  int last_smoothing_ = 0;
  std::unique_ptr<Pending> pending_;
  std::unique_ptr<FoundLoop> queued_;  ///< found while the run was being smoothed
  Pose2 anchor_;                       ///< published = anchor_ * the filter's estimate
  Eigen::Matrix3d anchor_covariance_ = Eigen::Matrix3d::Zero();
  Pose2 anchor_from_;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FOREST_MAP_LOOP_CLOSING_H
