#ifndef RBPF_SLAM_CORE_GRID_SINGLE_MAP_GRID_SLAM_H
#define RBPF_SLAM_CORE_GRID_SINGLE_MAP_GRID_SLAM_H

#include "rbpf_slam/core/grid/grid_slam.h"

namespace rbpf_slam
{
namespace core
{
/**
 * @brief Grid SLAM on one map ("odometry-based mapping"): each particle's pose moves by the odometry increment
 * with rot1-trans-rot2 noise; its log-weight grows by correlation_gain times the number of its scan's end points
 * that fall on occupied cells of the one log-odds map; the best particle's pose writes the scan into the map.
 * Cheap, and only as good as the map written from one pose.
 */
class SingleMapGridSlam : public GridSlam
{
public:
  /** @throws std::invalid_argument when config.validate() reports a problem. */
  explicit SingleMapGridSlam(const GridSlamConfig& config);
  const OccupancyGrid& map() const override { return map_; }
  const OccupancyGrid& particleMap(std::size_t /*i*/) const override { return map_; }

private:
  void resetMaps() override;
  int startMaps(const Pose2& odometry, const ScanData& scan, const Pose2& sensor) override;
  GridSlamStep step(const OdometryIncrement& u, const ScanData& scan, const Pose2& sensor) override;

  OccupancyGrid map_;
  std::vector<int> correlations_;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_GRID_SINGLE_MAP_GRID_SLAM_H
