#ifndef RBPF_SLAM_CORE_GRID_RBPF_GRID_SLAM_H
#define RBPF_SLAM_CORE_GRID_RBPF_GRID_SLAM_H

#include <memory>
#include <vector>

#include "rbpf_slam/core/grid/grid_slam.h"
#include "rbpf_slam/core/filter/history_chain.h"

namespace rbpf_slam
{
namespace core
{
/**
 * @brief Grid SLAM as GMapping does it: every particle owns its map (copy-on-write by tiles: copying a particle
 * copies tile pointers, a scan clones only the tiles it writes); each particle's pose is sampled from the odometry
 * motion model, refined by hill-climbing scan matching against its own map, then drawn from a small Gaussian
 * around the match; its log-weight grows by likelihood_gain times the likelihood-field log-likelihood at the match
 * (GMapping's approximation of the proposal's normaliser), optionally with the motion model's factor; every
 * particle inserts the scan in its own map; the best particle (largest weight) is the estimate.
 */
class RbpfGridSlam : public GridSlam
{
public:
  /** @throws std::invalid_argument when config.validate() reports a problem. */
  explicit RbpfGridSlam(const GridSlamConfig& config);
  const OccupancyGrid& map() const override { return maps_[best_index_]; }
  const OccupancyGrid& particleMap(std::size_t i) const override { return maps_.at(i); }
  std::vector<Pose2> bestTrajectory() const override;

private:
  /** @brief A pose of a particle's history; ancestors shared between particles, released iteratively. */
  using TrajectoryNode = HistoryNode<Pose2>;

  void resetMaps() override;
  int startMaps(const Pose2& odometry, const ScanData& scan, const Pose2& sensor) override;
  GridSlamStep step(const OdometryIncrement& u, const ScanData& scan, const Pose2& sensor) override;

  ScanMatcher matcher_;
  std::vector<OccupancyGrid> maps_;  ///< one per particle
  std::vector<std::shared_ptr<const TrajectoryNode>> histories_;
  std::size_t best_index_ = 0;
  // Per step, per particle: the odometry sample, the jitter around its match, the match, whether it is trusted.
  std::vector<Pose2> predicted_, jitter_;
  std::vector<ScanMatch> matches_;
  std::vector<char> trusted_;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_GRID_RBPF_GRID_SLAM_H
