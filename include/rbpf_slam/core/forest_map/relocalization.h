#ifndef RBPF_SLAM_CORE_FOREST_MAP_RELOCALIZATION_H
#define RBPF_SLAM_CORE_FOREST_MAP_RELOCALIZATION_H

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/extraction/trunk_detector.h"
#include "rbpf_slam/core/fastslam/landmark_map.h"
#include "rbpf_slam/core/filter/pose2.h"
#include "rbpf_slam/core/forest_map/constellation.h"

namespace rbpf_slam
{
namespace core
{
/** @brief The state of a global relocalization in a saved map. */
struct RelocalizationStatus
{
  bool active = false;      ///< a search took place on this update
  bool found = false;       ///< this update found the robot (the filter starts here)
  int trunks = 0;           ///< distinct trunks gathered so far (seen at least twice)
  int best_inliers = 0;     ///< of the best hypothesis
  int second_inliers = 0;   ///< of the runner-up (0: none)
  int hypotheses = 0;       ///< distinct hypotheses the particles were spread over (when found)
  double travel = 0.0;      ///< [m] odometry travel since the search began
  double seconds = 0.0;     ///< [s] CPU time of the search on this update
  std::string reason;       ///< why not found yet
  /// a search after tracking was lost (the health warned); the filter tracks on meanwhile
  bool lost = false;
  /// that search ended on this update: it found a pose distinct from the estimate and the particles were moved there
  bool recovered = false;
  /// that search ended on this update: it found the estimate's own pose (tracking was not lost)
  bool confirmed = false;
  /// that search ended on this update without a result: nothing found within a window of travel
  bool gave_up = false;
};

/** @brief Parameters of the search for the start pose in a saved map. */
struct RelocalizationConfig
{
  ConstellationConfig constellation;
  double merge_distance = 0.5;  ///< [m] detections this close in the odometry frame are one trunk
  int min_sightings = 2;        ///< a trunk takes part once seen this often
  double window = 30.0;         ///< [m] of travel: trunks gathered longer ago are forgotten (odometry drifts)
  double hypothesis_share = 0.5;  ///< particles go to every hypothesis with this share of the best's inliers
  double spread_xy = 0.1;       ///< [m] the particles' spread around each hypothesis
  double spread_theta = 0.02;   ///< [rad]
  /// With a saved map and FastSlamConfig::relocalize_when_lost: the map is searched again when the filter's health
  /// warns (its trees not re-observed: a lost pose), while the filter tracks on; a pose found farther than
  /// recover_distance or recover_angle from the estimate replaces it (the particles spread over it and the
  /// estimate, on the saved map).
  double recover_distance = 1.0;  ///< [m]
  /// ... and only when the found pose explains at least this many of the trunks gathered since the search began and
  /// recover_margin more than the estimate does (the estimate is the alternative: a chance match in a dense map
  /// must not replace it)
  int recover_min_inliers = 8;
  int recover_margin = 3;
  double recover_angle = 0.2;     ///< [rad]
};

/**
 * @brief Where the robot is in a saved map, from the trunks it sees: the search for the start pose, and the search
 * again while tracking when the saved map's trees stop being re-observed (a lost pose). The trunks of successive
 * sweeps are gathered in the odometry frame (merged within merge_distance, each taking part once seen
 * min_sightings times, forgotten a window of travel later) and matched against the saved map by constellation
 * (ConstellationMatcher). The filter is the caller's: this class says where to start the particles.
 */
class Relocalizer
{
public:
  /** @p when_lost: also search while tracking (FastSlamConfig::relocalize_when_lost). */
  Relocalizer(const std::vector<Landmark>& trees, const RelocalizationConfig& config, bool when_lost);

  /** @brief Forgets every search (a restart of the filter). */
  void reset();

  /**
   * @brief One sweep of the search: @p trunks (sensor frame) seen from the sensor at @p mount on base_link, base_link
   * at @p odom_mid in the odometry frame. True when the search was accepted: @p starts then holds the poses to start
   * from (base_link in the saved map), every hypothesis with hypothesis_share of the best's trunks (their weights:
   * startLogWeights()); @p status says what the search saw either way.
   */
  bool search(const std::vector<TrunkObservation>& trunks, const Pose2& mount, const Pose2& odom_mid,
              RelocalizationStatus* status, std::vector<Pose2>* starts);

  /** @brief What a sweep while tracking did. */
  enum class Tracking
  {
    kNoSearch,   ///< no search is running (the status untouched)
    kSearching,  ///< a search ran (the status says how it stands: gathering, confirmed the estimate, gave up)
    kRecovered,  ///< found elsewhere: start the particles again over the starts (the hypotheses and the estimate)
  };
  /**
   * @brief A sweep while tracking, @p estimate giving the filter's estimate (asked only when a search finds a pose):
   * a search begins when @p unobserved (the health says
   * the saved map's trees are not re-observed) turns true, or a window of travel after the last search ended while it
   * stays so; @p travel is the odometry travel of the timeline. A pose found farther than recover_distance or
   * recover_angle from the estimate, explaining recover_min_inliers trunks and recover_margin more than the estimate
   * does, replaces it (kRecovered, @p starts); one near the estimate confirms it; nothing within a window of travel
   * gives up.
   */
  Tracking whileTracking(const std::vector<TrunkObservation>& trunks, const Pose2& mount, const Pose2& odom_mid,
                         const std::function<Pose2()>& estimate, bool unobserved, double travel,
                         RelocalizationStatus* status,
                         std::vector<Pose2>* starts);

  const RelocalizationConfig& config() const { return config_; }

  /**
   * @brief For the starts of the last accepted search (or recovery), one each in their order: how well each explains
   * the trunks gathered (ConstellationMatcher::logLikelihood), to weigh the particles started there: a hypothesis
   * that explains fewer trunks, or explains them worse, starts lighter instead of as a lottery the first sweep's
   * few matches decide.
   */
  const std::vector<double>& startLogWeights() const { return start_log_weights_; }

private:
  void restartSearch();

  RelocalizationConfig config_;
  ConstellationMatcher matcher_;
  bool when_lost_ = false;
  struct Gathered
  {
    Eigen::Vector2d center = Eigen::Vector2d::Zero();
    double radius = 0.0;
    int sightings = 0;
    double travel = 0.0;  ///< odometry travel at the last sighting
  };
  std::vector<Gathered> gathered_;
  double search_travel_ = 0.0;
  bool search_started_ = false;
  Pose2 search_last_odometry_;
  std::vector<TrunkPoint> last_seen_;  ///< the trunks of the last search step (odometry frame)
  bool lost_search_ = false;           ///< a search after lost tracking is running
  double lost_search_end_ = -1e300;    ///< [m] odometry travel when the last one ended
  bool last_unobserved_ = false;
  std::vector<double> start_log_weights_;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FOREST_MAP_RELOCALIZATION_H
