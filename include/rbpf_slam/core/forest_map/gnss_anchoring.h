#ifndef RBPF_SLAM_CORE_FOREST_MAP_GNSS_ANCHORING_H
#define RBPF_SLAM_CORE_FOREST_MAP_GNSS_ANCHORING_H

#include <deque>
#include <string>

#include <Eigen/Core>

#include "rbpf_slam/core/fastslam/fastslam.h"
#include "rbpf_slam/core/filter/odometry_buffer.h"
#include "rbpf_slam/core/filter/pose2.h"
#include "rbpf_slam/core/forest_map/gnss.h"

namespace rbpf_slam
{
namespace core
{
/**
 * @brief Where the map frame lies on the earth, from satellite fixes of an antenna on the robot, and the fixes'
 * weight on the particles (as GnssFusionConfig says; without fixes everything works in the map frame alone).
 *
 * A fix waits until the filter update at or after its instant: the antenna's map position from the estimate there
 * (carried back to the fix's instant by the odometry) goes to the anchor's fit, and once the anchor is known well
 * enough (weigh_max_anchor_sigma), at most one fix per correlation_time weighs the particles. Once an anchor is
 * known, a fix beyond the innovation gate (kGnssGate2: a receiver's jump) is rejected: it weighs no particle, and
 * only the anchor's robust fit sees it (which leaves such fixes out while they are fewer than the others, and
 * follows them when wild first fixes had made the anchor and the good ones are now the many).
 */
class GnssAnchoring
{
public:
  explicit GnssAnchoring(const GnssFusionConfig& config);

  /**
   * @brief The saved map's anchor (valid: fixes weigh the particles from the start; this visit's fit refines it,
   * combineAnchors; sigma 0 is kept as it is). Not valid (the default): the anchor is fitted to the fixes.
   */
  void setMapAnchor(const GeoAnchor& anchor) { map_anchor_ = anchor; }
  /**
   * @brief A fix of the antenna at @p antenna (x, y on base_link); @p last_update [s] is the last filter update's
   * instant (NaN: none yet). Returns why it was refused ("" when taken): fixes not used, a bad value, a stamp more
   * than 1 s before the last update or not after the previous fix's.
   */
  std::string add(const GnssFix& fix, const Eigen::Vector2d& antenna, double last_update);
  /**
   * @brief Uses the fixes up to the filter update at @p t_mid (base_link at @p odom_mid in the odometry frame, the
   * odometry kept in @p odometry) with @p filter's estimate, and weighs @p filter's particles with those due.
   */
  void use(double t_mid, const Pose2& odom_mid, const OdometryBuffer& odometry, FastSlam* filter);
  /** @brief The saved map's anchor combined with the one fitted to this visit's fixes (either alone when the other
   * is not there; not valid: none yet). */
  GeoAnchor anchor() const;
  /** @brief Forgets this timeline's fixes and fit (a restart begins a new map frame); the saved map's anchor and
   * the counts stay. */
  void restart();

  /** @brief Fixes inside the gate (or before any anchor), fixes that weighed the particles, fixes the gate refused. */
  int used() const { return gnss_used_; }
  int weighed() const { return gnss_weighed_; }
  int rejected() const { return gnss_rejected_; }
  /** @brief Fixes the anchor's last fit left out (far from the others: a receiver's fault before any anchor). */
  int anchorOutliers() const { return anchor_outliers_; }

private:
  GnssFusionConfig gnss_config_;
  GeoAnchor map_anchor_;
  GeoAnchorEstimator anchor_estimator_;
  struct PendingFix
  {
    GnssFix fix;
    Eigen::Vector2d antenna;
  };
  std::deque<PendingFix> pending_fixes_;
  double last_weigh_stamp_ = -1e300;
  double next_anchor_check_ = -1e300;  ///< [s] the anchor is not refitted for weighing before this fix stamp
  int gnss_used_ = 0, gnss_weighed_ = 0, gnss_rejected_ = 0, anchor_outliers_ = 0;
  GeoAnchor gate_anchor_;  ///< the last anchor computed (or the saved map's): the fixes' innovation gate
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FOREST_MAP_GNSS_ANCHORING_H
