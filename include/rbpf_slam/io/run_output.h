#ifndef RBPF_SLAM_IO_RUN_OUTPUT_H
#define RBPF_SLAM_IO_RUN_OUTPUT_H

#include <map>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

#include "rbpf_slam/core/fastslam/fastslam.h"
#include "rbpf_slam/core/fastslam/filter_health.h"
#include "rbpf_slam/core/trunk_slam/trunk_slam_pipeline.h"
#include "rbpf_slam/core/fastslam/landmark_map.h"
#include "rbpf_slam/io/files.h"
#include "rbpf_slam/io/tum_file.h"
#include "rbpf_slam/core/filter/pose2.h"

namespace rbpf_slam
{
namespace io
{
/**
 * @brief The one landmark CSV of the package: the tree map file of forest_map_file.h without an anchor (slam_bag's
 * map.csv, the FastSLAM node's tree inventory, fastslam_benchmark's maps; rbpf_slam.evaluate.read_landmarks_csv
 * reads it back). kLandmarksCsvHeader is kForestMapHeader.
 */
extern const char* const kLandmarksCsvHeader;
/** @brief The CSV text of @p landmarks (with the header). */
std::string landmarksCsv(const std::vector<core::Landmark>& landmarks);
/** @brief Writes landmarksCsv() atomically. @throws std::runtime_error naming the file. */
void writeLandmarksCsv(const std::string& path, const std::vector<core::Landmark>& landmarks);

/**
 * @brief The run folder of a FastSLAM run, the same from the bag runner (slam_bag --out) and the node
 * (~run_folder): estimate.tum (the online estimate after each update, as published), odometry.tum (the odometry at
 * the same instants), estimate_best_history.tum (the final best particle's own trajectory over the last timeline),
 * updates.csv (per update: stamp, Neff, resampled, landmarks, observations, matched, new, deleted, ignored,
 * matched_confirmed, recreated, pose_spread, relocalizing, health, the particle cloud, loop: none, closed or
 * rejected, the published estimate and its covariance, health_cause), health.txt (the health: how many updates
 * warned, per cause, the first and the last warning), map.csv (the best particle's map, landmarksCsv()), loops.csv (every loop found: stamp, kind,
 * matched trees, the robot's shift, the solve's seconds and those of its marginal covariance, keyframes, chi-square and its bound, reason) and, with loop
 * closure, map_smoothed.csv and estimate_smoothed.tum (the run smoothed at its end: TrunkSlamPipeline::smoothed()).
 */
class FastSlamRunRecord
{
public:
  /** @param keep_tables false: only the counts and summaries are kept (memory that does not grow with the drive);
   * files() then has no trajectory or table to give. */
  explicit FastSlamRunRecord(bool keep_tables = true);
  bool keepsTables() const { return keep_tables_; }
  /** @brief One filter update; a new @p timeline (a restart) starts the best history over. @p covariance: the
   * estimate's as published (updates.csv's estimate_xx, _xy, _yy; empty without). */
  void addUpdate(double stamp, int timeline, const core::Pose2& estimate, const core::Pose2& odometry,
                 const core::FastSlamUpdateStats& stats, const core::HealthStatus& health,
                 const core::LoopEvent& loop = core::LoopEvent(), const Eigen::Matrix3d* covariance = nullptr);
  /** @brief One pipeline update (as above); while the pipeline searches a saved map (not localized) only the search
   * is recorded (relocalizationSummary), no pose. */
  void addUpdate(const core::PipelineUpdate& u);
  /** @brief How the search for the start in a saved map went (empty when there was none). */
  std::string relocalizationSummary() const;
  /** @brief How the searches while tracking went (FastSlamConfig::relocalize_when_lost; empty when there was none). */
  std::string lostSummary() const;
  /** @brief [s] the updates where a search while tracking moved the particles. */
  const std::vector<double>& recoveries() const { return recoveries_; }
  /** @brief Updates whose health was a warning. */
  std::size_t warnings() const { return warnings_; }
  /** @brief The health summary of health.txt (one paragraph). */
  std::string healthSummary() const;
  std::size_t updates() const { return updates_; }
  /** @brief Loops closed and refused, and the longest solve (one line; empty when no loop was found). */
  std::string loopSummary() const;
  int loopsClosed() const { return loops_closed_; }
  int loopsRejected() const { return loops_rejected_; }
  /** @brief The files of the folder @p dir with @p filter's present state (best history and map), and the smoothed
   * run when @p smoothed is given and ok. */
  std::vector<FileContent> files(const std::string& dir, const core::FastSlam& filter,
                                 const core::SmoothedRun* smoothed = nullptr) const;
  /**
   * @brief The whole run folder @p dir, as the node (~run_folder, save_run) and slam_bag (--out) write it: files()
   * with @p pipeline's filter and the run smoothed at its end, and timing.json (@p sweeps sensor messages used,
   * @p updates pipeline updates, the pipeline's processing seconds). @p smoothed: the run smoothed when the caller
   * has it already (solved without holding the pipeline).
   */
  std::vector<FileContent> folder(const std::string& dir, const core::TrunkSlamPipeline& pipeline, int sweeps,
                                  int updates, const core::SmoothedRun* smoothed = nullptr) const;

private:
  bool keep_tables_ = true;
  std::ostringstream estimate_, odometry_, table_;
  std::vector<double> stamps_;  ///< of the current timeline
  int timeline_ = -1;
  std::size_t updates_ = 0;
  std::size_t warnings_ = 0;
  double first_warning_ = 0.0, last_warning_ = 0.0;
  std::string last_warning_message_;
  std::map<std::string, std::size_t> warnings_by_cause_;  ///< by HealthCause's name
  int searching_ = 0;            ///< updates spent searching
  bool found_ = false;
  double found_stamp_ = 0.0, found_travel_ = 0.0, search_seconds_ = 0.0, max_search_seconds_ = 0.0;
  int found_hypotheses_ = 0, found_inliers_ = 0, found_trunks_ = 0;
  std::string last_reason_;
  int lost_searches_ = 0, confirmations_ = 0, lost_gave_up_ = 0;
  bool lost_searching_ = false;
  std::vector<double> recoveries_;
  std::ostringstream loops_;
  int loops_closed_ = 0, loops_rejected_ = 0;
  double max_loop_seconds_ = 0.0;
};

}  // namespace io
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_IO_RUN_OUTPUT_H
