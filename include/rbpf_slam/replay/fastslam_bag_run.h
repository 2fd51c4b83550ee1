#ifndef RBPF_SLAM_REPLAY_FASTSLAM_BAG_RUN_H
#define RBPF_SLAM_REPLAY_FASTSLAM_BAG_RUN_H

#include "rbpf_slam/replay/bag_replay.h"

namespace rbpf_slam
{
namespace replay
{
/**
 * @brief FastSLAM on a bag (slam_bag --filter fastslam): the FastSLAM node's pipeline (core::TrunkSlamPipeline) fed
 * with the bag's point clouds, 2D scans or a detector's TrunkArrays, its odometry and satellite fixes, in record
 * order. Writes, with --out DIR, the run folder the node writes (io::FastSlamRunRecord::folder), and with --save-map
 * the tree map (and the changes since --map).
 * @return the exit code (0). @throws std::runtime_error naming the bag or the file when the run cannot be made.
 */
int runFastSlamBag(const SlamBagOptions& options);

/** @brief The name of the library that holds runFastSlamBag, which slam_bag loads only for a FastSLAM run. */
constexpr const char* kFastSlamRunnerLibrary = "librbpf_slam_fastslam_replay.so";
/** @brief runFastSlamBag's entry in that library, without C++ name mangling. */
constexpr const char* kFastSlamRunnerSymbol = "rbpf_slam_run_fastslam_bag";
/** @brief Its type: the options in, the exit code out; exceptions are caught by the caller. */
using FastSlamRunner = int (*)(const SlamBagOptions*);

}  // namespace replay
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_REPLAY_FASTSLAM_BAG_RUN_H
