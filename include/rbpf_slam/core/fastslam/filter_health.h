#ifndef RBPF_SLAM_CORE_FASTSLAM_FILTER_HEALTH_H
#define RBPF_SLAM_CORE_FASTSLAM_FILTER_HEALTH_H

#include <deque>
#include <string>

#include "rbpf_slam/core/fastslam/fastslam.h"

namespace rbpf_slam
{
namespace core
{
/** @brief How the landmark filter is doing over its last updates. */
enum class HealthLevel
{
  kOk,
  kWarn,  ///< something is wrong: HealthStatus::cause says what
};

/** @brief Why the health warns (the first rule that holds, in this order). */
enum class HealthCause
{
  kNone,
  kRecreated,     ///< new landmarks where confirmed ones were deleted (recreated_warn)
  kUnmatched,     ///< few observations match confirmed landmarks while many new ones are made
  kInconsistent,  ///< a revisit the smoother could not bring together with the map (until a loop closes)
  kOverconfident, ///< the innovations exceed the uncertainty the filter claims
  kSavedMapUnobserved,  ///< a saved map's trees are not re-observed
};

struct HealthConfig
{
  int window = 100;            ///< updates the figures are taken over
  /// Warn when at least this many new landmarks in the window lie where confirmed ones were deleted; 0: the rule is
  /// off (with loop closure, whose search judges a map made again beside itself: the smoother's verdict on the
  /// revisit, FilterHealth::revisit, warns instead).
  int recreated_warn = 3;
  /// Warn when fewer than this share of a full window's observations matched confirmed landmarks while the
  /// filter made more new landmarks than it matched confirmed ones (a map seen for the first time passes: its
  /// landmarks are confirmed after a few looks).
  double matched_confirmed_warn = 0.3;
  int min_observations = 30;   ///< no verdict on the share from fewer observations
  /// Tracking in a saved map: warn when fewer than this share of the observations of the last prior_window updates
  /// (at least min_observations) matched the saved map's trees (the robot is lost, or outside the saved map; a
  /// healthy second visit matches about two thirds, the rest being clutter, new and unmapped trees). Negative: no
  /// saved map (the rule is off).
  double matched_prior_warn = -1.0;
  int prior_window = 30;
  /// Warn when the best particle's innovations, against all the uncertainty the filter claims (claimed_nis),
  /// average more than this per match over the window (at least min_observations matches): chi-square with 2
  /// degrees of freedom averages 2, and 6 means errors about 1.7 times what the cloud's spread and the noise allow.
  double claimed_nis_warn = 6.0;
};

/** @brief The figures of the window and the verdict. */
struct HealthStatus
{
  HealthLevel level = HealthLevel::kOk;
  HealthCause cause = HealthCause::kNone;  ///< why it warns
  std::string message;             ///< one line: the verdict and why
  int updates = 0;                 ///< in the window
  double neff_ratio = 1.0;         ///< mean Neff / N over the window
  double resampled_share = 0.0;    ///< share of the window's updates that resampled
  double matched_confirmed_share = 0.0;  ///< observations matched to confirmed landmarks / observations
  double matched_prior_share = 0.0;      ///< observations matched to a saved map's trees / observations
  /// the saved map's rule alone (matched_prior_warn): its trees are not being re-observed
  bool saved_map_unobserved = false;
  int observations = 0;
  int created = 0;
  int recreated = 0;               ///< new landmarks where confirmed ones were deleted
  int deleted = 0;
  double relocalizing_share = 0.0; ///< always 0 (FastSlamUpdateStats::relocalizing; kept for the diagnostics' keys)
  double pose_spread = 0.0;        ///< [m] of the last update
  /// Mean squared Mahalanobis distance of the window's matches (2 for a filter whose errors are within its
  /// uncertainty; far above: the pose is further off than the particles' spread says).
  double mean_nis = 0.0;
  /// The same against the claimed uncertainty (FastSlamUpdateStats::claimed_nis), per match; 0 without matches.
  double claimed_nis = 0.0;
  /// the claimed-uncertainty rule alone (claimed_nis_warn): the cloud is surer than its innovations allow
  bool overconfident = false;
  /// the smoother refused the last loop found as inconsistent, and none has closed since (FilterHealth::revisit)
  bool map_inconsistent = false;
};

/**
 * @brief Watches a FastSLAM filter's update statistics over a sliding window and says when its map is being
 * rebuilt instead of re-observed: new landmarks appearing where confirmed ones were just deleted, and few
 * observations matching confirmed landmarks while many new ones are made. Both are what a lost pose looks like
 * from inside the filter; neither needs the truth.
 */
class FilterHealth
{
public:
  explicit FilterHealth(const HealthConfig& config = HealthConfig());
  /** @brief Adds one update's statistics (@p particles: the filter's particle count); returns the new status. */
  const HealthStatus& add(const FastSlamUpdateStats& stats, int particles);
  const HealthStatus& status() const { return status_; }
  /**
   * @brief The smoother's verdict on a revisit, for the updates from the next one on: @p consistent false when it
   * refused a loop because the solved graph could not bring its trees together (their normalised residuals beyond
   * their chi-square bound, or no convergence; @p why says which): the map is bent where the robot came back, and
   * the health warns until a loop closes (@p consistent true).
   */
  void revisit(bool consistent, const std::string& why);
  /** @brief Updates so far that ended in a warning. */
  int warnings() const { return warnings_; }

private:
  struct Entry
  {
    double neff_ratio;
    bool resampled, relocalizing;
    int observations, matched, matched_confirmed, matched_prior, created, recreated, deleted;
    double nis;
    double claimed_nis;
    int claimed_matches;
  };
  HealthConfig config_;
  std::deque<Entry> window_;
  HealthStatus status_;
  int warnings_ = 0;
  bool inconsistent_ = false;
  std::string inconsistent_why_;
};

const char* toString(HealthLevel level);
/** @brief The cause's name in files and summaries: none, recreated, unmatched, inconsistent, overconfident,
 * saved_map_unobserved. */
const char* toString(HealthCause cause);

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FASTSLAM_FILTER_HEALTH_H
