#ifndef RBPF_SLAM_CORE_FOREST_MAP_LOOP_CLOSURE_CONFIG_H
#define RBPF_SLAM_CORE_FOREST_MAP_LOOP_CLOSURE_CONFIG_H

#include <string>

#include "rbpf_slam/core/forest_map/constellation.h"

namespace rbpf_slam
{
namespace core
{
/** @brief Parameters of the search for a revisit within one run (LoopDetector). */
struct LoopConfig
{
  LoopConfig() { constellation.min_inliers = 4; }
  /// The pair search of the second visits; a loop needs min_inliers trees explained (4: a revisit of a sparse stand
  /// sees few trees at once, and the confirmations and the smoother's consistency test stand behind the count).
  ConstellationConfig constellation;
  double recent_time = 90.0;    ///< [s] trees first seen this recently ...
  double recent_radius = 30.0;  ///< [m] ... and this near the robot are the ones around it now
  double old_time = 60.0;       ///< [s] trees not seen for this long are the map made long ago
  double min_correction = 0.5;  ///< [m] a smaller shift of the recent trees is no loop: association handles it
  double min_angle = 0.05;      ///< [rad] ... unless they turn by more than this
  int confirmations = 3;        ///< consecutive searches that agree before a loop is reported
  double agree_distance = 0.3;  ///< [m] two searches agree when their corrections differ by less than this
  double agree_angle = 0.03;    ///< [rad] ... and this
};

/** @brief Parameters of the smoother that closes a loop (TrunkSmoother). */
struct SmootherConfig
{
  double keyframe_distance = 1.0;  ///< [m] a keyframe of the path every this much odometry travel ...
  double keyframe_angle = 0.3;     ///< [rad] ... or this much turning
  /// Squared Mahalanobis distance (2 dof) within which an observation is given to a tree of the map (the filter's
  /// own association gate: 99.9 % of a true match).
  double association_gate = 13.8;
  /// Scale of the Cauchy loss of the observation factors, in standard deviations: an observation this far off
  /// weighs half, so that a wrong association cannot bend the path.
  double robust_scale = 2.0;
  /// [m] Standard deviation of the identity of two trees a loop matched, beside their own covariances: the trees'
  /// centres are fitted to different sides of the bark on the two passes.
  double loop_sigma = 0.1;
  /// ... and this share of the trees' radius in quadrature (a trunk is no perfect circle: its centre fitted from
  /// two sides differs by a share of its radius).
  double loop_radius_share = 0.3;
  /// The loop is rejected when its identities' residuals after the solve exceed this quantile of the chi-square
  /// distribution (two degrees of freedom per matched tree).
  double loop_quantile = 0.999;
  /// When they do, the worst pair, if beyond the quantile (2 dof) on its own, is dropped and the rest solved again,
  /// while more than half of the pairs and at least loop_min_trees remain; at most this many solves of one loop
  /// (1: refused at once).
  int loop_rounds = 3;
  int loop_min_trees = 4;  ///< (the loop search's own minimum of matched trees)
  /// Levenberg-Marquardt iterations of one solve: a solve that does not converge within them leaves the filter as it
  /// was. A bound on work, not on time, so that every computer gives the same answer.
  int max_iterations = 50;
  /// A graph of more factors (keyframes' trees and odometry) is not solved: the bound on one solve's size.
  int max_factors = 200000;
  /// The particles are drawn again around the smoothed pose with the marginal covariance of the smoother's last
  /// pose, its standard deviations at least these [m], [rad].
  double spread_floor_xy = 0.02;
  double spread_floor_theta = 0.002;

  /** @brief Empty when valid, else a message naming the first bad parameter. */
  std::string validate() const;
};

/** @brief Loop closure within a run: detection on the best particle's map, the smoother, the particles redrawn. */
struct LoopClosureConfig
{
  bool enabled = true;
  double search_interval = 1.0;  ///< [s] between two searches for a revisit
  double retry_interval = 10.0;  ///< [s] after a loop the smoother refused, before the next search
  /// The smoother solves a loop beside the filter (a worker thread); its result is applied this many filter updates
  /// after the loop was found, however long the solve took (the update waits for it then), so that one seed gives
  /// one result on every computer. 0: solved and applied within the update that found it.
  int apply_after = 20;
  /// A loop must agree with the odometry: the correction it asks of the robot's pose (x, y, heading) must lie within
  /// this quantile of the chi-square (3 dof) of the odometry's drift since the old trees were last seen (its motion
  /// noise class). A larger correction is a wrong match (repetitive rows, a look-alike constellation).
  double drift_quantile = 0.999;
  /// Every this many filter updates the run is smoothed as it stands (beside the filter, applied apply_after updates
  /// later), and the estimate published is the smoothed pose carried on by the filter's motion since. 0: the
  /// filter's estimate is published.
  int smooth_interval = 50;
  LoopConfig detection;
  SmootherConfig smoother;

  std::string validate() const;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FOREST_MAP_LOOP_CLOSURE_CONFIG_H
