#ifndef RBPF_SLAM_EVAL_FOREST_SLAM_RUNNER_H
#define RBPF_SLAM_EVAL_FOREST_SLAM_RUNNER_H

#include <string>
#include <vector>

#include "rbpf_slam/eval/evaluation.h"
#include "rbpf_slam/core/fastslam/fastslam.h"
#include "rbpf_slam/sim/forest_world.h"
#include "rbpf_slam/sim/scenario.h"
#include "rbpf_slam/core/extraction/trunk_detector.h"
#include "rbpf_slam/core/trunk_slam/trunk_slam_pipeline.h"

namespace rbpf_slam
{
namespace eval
{
/// [m] The visibility scope of the simulated runs where a filter's configuration leaves it to the sensor: trees
/// 1-12 m from the sensor (and, for a 2D scanner, inside its field of view) count as seen (for the recall). A
/// spinning lidar's filter gets the same scope; a 2D scanner's filter takes the one its scans state.
constexpr double kForestRunMinRange = 1.0, kForestRunMaxRange = 12.0;

/** @brief A simulated 2D scan as the trunk detector takes it (ranges as they are: the detector applies REP-117). */
core::PlanarScan toPlanarScan(const sim::LaserScan2D& scan);

struct ForestSlamRunConfig
{
  sim::ScenarioConfig scenario;
  core::TrunkDetectorConfig detector;
  core::TrunkSlamConfig filter;
};

/** @brief What one run produced, and its score against the truth (the truth is read only here). */
struct ForestSlamRunResult
{
  std::vector<double> stamps;             ///< [s] of each filter update (the middle of each sweep)
  std::vector<core::Pose2> estimate;      ///< the filter's online estimate, start frame (= map frame)
  std::vector<core::Pose2> odometry;      ///< dead reckoning at the same stamps
  std::vector<core::Pose2> truth;         ///< true pose at the same stamps, start frame
  std::vector<core::Landmark> landmarks;  ///< best particle's map at the end
  std::vector<MapPoint> trees;            ///< true trees (breast-height centre and radius), start frame
  std::vector<bool> tree_seen;            ///< came inside the visibility scope of the true sensor (and, for a 2D
                                          ///< scanner, inside its field of view)
  MapScore map;
  double final_error = 0.0;        ///< [m] position of the best particle at the end
  double final_error_odometry = 0.0;
  double ate = 0.0;                ///< [m] RMS over the updates
  double ate_odometry = 0.0;
  double seconds_extraction = 0.0; ///< wall time spent in extraction
  double seconds_filter = 0.0;     ///< wall time spent in the filter
  int sweeps = 0;                  ///< sweeps (3D lidar) or scans (2D scanner) fed to the pipelines
  double distance = 0.0;           ///< [m] driven (true path, at the updates)
  double simulated_seconds = 0.0;  ///< [s] simulated time of the run
  bool collided = false;           ///< the robot touched a trunk or a box; the run ended there
  sim::Collision collision;        ///< where and what (valid when collided)
  std::string collision_what;      ///< what was hit, in words (Collision::what)
  std::vector<core::FastSlamUpdateStats> update_stats;  ///< of each filter update
  int health_warnings = 0;         ///< updates whose health warned that the map was being rebuilt
  /// Share of the filter's updates in which the true position lay inside the particle cloud's 95 % region
  /// (insideRegion95; NaN without an update): about 0.95 for a filter whose stated uncertainty covers its error.
  double coverage = NAN;
  /// Loop closure (TrunkSlamConfig::loop_closure): loops closed and refused; closed loops that were false (the robot
  /// ended more than 1 m from the truth, and further than before the loop); the longest solve.
  int loops_closed = 0, loops_rejected = 0, false_loops = 0;
  double max_loop_seconds = 0.0;
  /// The run smoothed at its end (TrunkSlamPipeline::smoothed(); valid when smoothed): its final position error,
  /// ATE over the filter's updates, and its map's score.
  bool smoothed = false;
  double final_error_smoothed = NAN, ate_smoothed = NAN;
  MapScore map_smoothed;
  std::vector<core::Landmark> landmarks_smoothed;
  std::vector<double> stamps_smoothed;
  std::vector<core::Pose2> estimate_smoothed;
};

/**
 * @brief The deterministic in-process runner: simulator, noise relay and path follower in lockstep (the
 * Scenario), trunk extraction on each sweep, FastSLAM on odometry and trunks, as fast as it computes. The sensor is
 * the 3D lidar, or the 2D scanner when the 3D lidar is disabled and the 2D scanner enabled. A collision ends the run
 * (ForestSlamRunResult::collided).
 * Extraction and filter see only the sensor data and odometry, never the truth; the truth is used to
 * score the result at the end.
 *
 * Timing: wheel odometry arrives late (its latency); a sweep is processed once odometry covers it. Each trunk
 * is seen at its own instant of the sweep (its column); its position is carried to the sweep's middle by the
 * odometry between the two instants, and the filter updates at the middle.
 */
ForestSlamRunResult runForestSlam(const sim::ForestWorld& world, const ForestSlamRunConfig& config);
/// @p match_gate [m]: a feature within this of a true tree can be that tree (scoreMap's gate).

/** @brief One extraction + filter configuration among several run on the same simulated data. */
struct ForestSlamVariant
{
  core::TrunkDetectorConfig detector;
  core::TrunkSlamConfig filter;
};

/**
 * @brief runForestSlam() for several extraction + filter variants fed the very same simulated sweeps and
 * odometry (one simulation; the path follower steers on odometry or on the truth, never on a filter, so the data do
 * not depend on the filters).
 * Each result equals that of runForestSlam() with the variant's configuration; comparisons between variants
 * are paired (same data), and the simulation, which costs most, is done once.
 */
std::vector<ForestSlamRunResult> runForestSlamVariants(const sim::ForestWorld& world,
                                                       const sim::ScenarioConfig& scenario,
                                                       const std::vector<ForestSlamVariant>& variants,
                                                       double match_gate = 0.5);

}  // namespace eval
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_EVAL_FOREST_SLAM_RUNNER_H
