#ifndef RBPF_SLAM_REPLAY_GRID_BAG_RUN_H
#define RBPF_SLAM_REPLAY_GRID_BAG_RUN_H

#include "rbpf_slam/replay/bag_replay.h"

namespace rbpf_slam
{
namespace replay
{
/**
 * @brief Grid SLAM on a bag (slam_bag --filter grid): the grid node's pipeline (core::GridSlamPipeline) fed with the
 * bag's scans and odometry (nav_msgs/Odometry, or four wheels' angles with an optional gyro) in record order.
 * Writes, with --out DIR: estimate.tum and odometry.tum (one pose per scan), odometry_all.tum (every odometry pose),
 * estimate_best_history.tum (rbpf: the best particle's own history, one pose per processed scan), map.yaml + map.pgm
 * (map_server's layout), map.restartN.yaml + .pgm (the maps restarts ended), timing.txt and timing.json.
 * @return the exit code (0). @throws std::runtime_error naming the bag or the file when the run cannot be made.
 */
int runGridBag(const SlamBagOptions& options);

}  // namespace replay
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_REPLAY_GRID_BAG_RUN_H
