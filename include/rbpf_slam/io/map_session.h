#ifndef RBPF_SLAM_IO_MAP_SESSION_H
#define RBPF_SLAM_IO_MAP_SESSION_H

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "rbpf_slam/core/trunk_slam/trunk_slam_pipeline.h"
#include "rbpf_slam/core/forest_map/forest_changes.h"
#include "rbpf_slam/io/files.h"
#include "rbpf_slam/io/forest_map_file.h"

namespace rbpf_slam
{
namespace io
{
/** @brief How a FastSLAM run starts: a new map, or a saved tree map with the start given or searched. */
struct MapStart
{
  std::string map_file;  ///< the saved tree map ("" = a new map whose frame is the odometry frame at the first update)
  bool search = true;    ///< with map_file: search the start pose from the trunks seen (else start at @c start)
  core::Pose2 start;     ///< base_link in the saved map's frame at the first update (search false)
};

/** @brief One map file and what it holds, as a session writes it. */
struct MapFile
{
  std::string path;
  std::string content;
  std::size_t trees = 0;
  int restart = 0;  ///< of a map a restart ended: the restart's number (1: the first)
};

/**
 * @brief The tree map of one FastSLAM run, for the node and slam_bag alike: starting from a saved map, the current
 * map, the changes since the saved one, and the files of a map under one naming rule. A map saved as @c FILE.csv is
 * written as
 *
 * - @c FILE.csv: the trees, the anchor and the viewpoints (io/forest_map_file.h);
 * - @c FILE.geojson: the trees in WGS84, when the map is anchored;
 * - @c FILE_changes.csv and, anchored, @c FILE_changes.geojson: the changes since the saved map, when the run started
 *   from one;
 * - @c FILE.restartN.csv: the map that the N-th restart (time jumping back) ended.
 *
 * The pipeline is the caller's and must outlive the session.
 */
class FastSlamMapSession
{
public:
  /**
   * @brief Starts @p pipeline from the saved map of @p start (read line by line, at most max_landmarks trees,
   * @p cancelled polled), or leaves it to start a new map. @throws std::runtime_error naming the file and the line.
   */
  FastSlamMapSession(core::TrunkSlamPipeline* pipeline, const MapStart& start,
                     const std::function<bool()>& cancelled = std::function<bool()>());

  bool fromSavedMap() const { return !start_.map_file.empty(); }
  const MapStart& start() const { return start_; }
  const ForestMap& saved() const { return saved_; }
  /** @brief How the run started, in words (a log line). */
  std::string startDescription() const;

  /** @brief The map now: the trees (TrunkSlamPipeline::smoothed() with loop closure, else the best particle's; none
   * before the first update), the anchor, the viewpoints. @p smoothed: the smoothed run when the caller has it
   * already (TrunkSlamPipeline::smoothingJob(), solved without holding the pipeline). */
  ForestMap currentMap(const core::SmoothedRun* smoothed = nullptr) const;
  /** @brief The changes of the trees @p now since the saved map (none without one). */
  std::vector<core::TreeChange> changes(const std::vector<core::Landmark>& now) const;
  /**
   * @brief The files of the current map saved as @p path (see the class); @p summary gets what was written, in
   * words (the trees and, from a saved map, the counts of the changes).
   */
  std::vector<FileContent> mapFiles(const std::string& path, std::string* summary = nullptr,
                                    const core::SmoothedRun* smoothed = nullptr) const;
  /** @brief The maps that restarts ended since the last call, as files beside @p path (FILE.restartN.csv). */
  std::vector<MapFile> endedMapFiles(const std::string& path);

private:
  core::TrunkSlamPipeline* pipeline_;
  MapStart start_;
  ForestMap saved_;
};

}  // namespace io
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_IO_MAP_SESSION_H
