#include "rbpf_slam/core/forest_map/gnss_anchoring.h"

#include <cmath>

namespace rbpf_slam
{
namespace core
{
GnssAnchoring::GnssAnchoring(const GnssFusionConfig& config) : gnss_config_(config), anchor_estimator_(config)
{
}

void GnssAnchoring::restart()
{
  anchor_estimator_.clear();  // a restart begins a new map frame (unless a saved map's)
  pending_fixes_.clear();
  gate_anchor_ = GeoAnchor();
  last_weigh_stamp_ = -1e300;
  next_anchor_check_ = -1e300;
}

GeoAnchor GnssAnchoring::anchor() const
{
  return combineAnchors(map_anchor_, anchor_estimator_.anchor());
}

std::string GnssAnchoring::add(const GnssFix& fix, const Eigen::Vector2d& antenna, double last_update)
{
  if (!gnss_config_.enabled)
    return "satellite fixes are not used (gps enabled: false)";
  std::string why = gnssFixProblem(fix, gnss_config_.max_sigma);
  if (why.empty() && !antenna.allFinite())
    why = "antenna position not finite";
  if (why.empty() && std::isfinite(last_update) && fix.stamp < last_update - 1.0)
    why = "older than the last filter update by more than 1 s";
  if (why.empty() && !pending_fixes_.empty() && fix.stamp <= pending_fixes_.back().fix.stamp)
    why = "stamp not after the previous fix's";
  if (!why.empty())
    return why;
  pending_fixes_.push_back({ fix, antenna });
  while (pending_fixes_.size() > 600)  // e.g. a long search without an update: keep the last ten minutes at 1 Hz
    pending_fixes_.pop_front();
  return "";
}

void GnssAnchoring::use(double t_mid, const Pose2& odom_mid, const OdometryBuffer& odometry, FastSlam* filter)
{
  if (pending_fixes_.empty() || pending_fixes_.front().fix.stamp > t_mid)
    return;  // no fix is due: the estimate (a mean over the particles) is not needed
  const Pose2 estimate = filter->estimate();
  const Eigen::Matrix2d pose_covariance = filter->poseCovariance().topLeftCorner<2, 2>();
  const Pose2 odom_mid_inv = odom_mid.inverse();
  if (!gate_anchor_.valid && map_anchor_.valid)
    gate_anchor_ = map_anchor_;
  while (!pending_fixes_.empty() && pending_fixes_.front().fix.stamp <= t_mid)
  {
    const PendingFix f = pending_fixes_.front();
    pending_fixes_.pop_front();
    if (odometry.empty() || f.fix.stamp < odometry.earliest())
      continue;  // before the odometry kept (e.g. while the start was searched): not placed
    // base_link at the fix's instant, in base_link at this update's, by the odometry between them.
    const Pose2 back = odom_mid_inv * odometry.at(f.fix.stamp);
    Eigen::Vector2d lever;
    back.transformPoint(f.antenna.x(), f.antenna.y(), &lever.x(), &lever.y());
    Eigen::Vector2d antenna_map;
    estimate.transformPoint(lever.x(), lever.y(), &antenna_map.x(), &antenna_map.y());
    // The innovation gate: once an anchor is known, a fix far from where it and the filter put the antenna (a
    // receiver's jump) does not weigh the particles. It still goes to the anchor's robust fit, which leaves it out
    // while such fixes are fewer than the others, and which follows them when they are the many: when the first
    // fixes were the wild ones, the anchor fitted to them would otherwise refuse every good fix after them.
    const bool gated = gate_anchor_.valid && gnssInnovation(f.fix, gate_anchor_, gnss_config_.sigma_floor,
                                                            antenna_map, pose_covariance) > kGnssGate2;
    anchor_estimator_.add(f.fix, antenna_map);
    if (gated)
      ++gnss_rejected_;
    else
      ++gnss_used_;
    // A fix weighs the particles at most once per correlation time; the anchor (a fit over every fix so far) is
    // refitted for it only when one is due (or the gate refused the fix), and at most ten times per correlation
    // time while it is not yet known.
    if (gnss_config_.weigh_max_anchor_sigma <= 0.0 || f.fix.stamp < next_anchor_check_ ||
        (!gated && f.fix.stamp - last_weigh_stamp_ < gnss_config_.correlation_time))
      continue;
    next_anchor_check_ = f.fix.stamp + 0.1 * gnss_config_.correlation_time;
    const GeoAnchor a = combineAnchors(map_anchor_, anchor_estimator_.anchor(&anchor_outliers_));
    if (a.valid)
      gate_anchor_ = a;
    if (gated || !a.valid || (a.sigma > gnss_config_.weigh_max_anchor_sigma && !map_anchor_.valid))
      continue;
    Eigen::Vector2d z;
    Eigen::Matrix2d cov;
    gnssInFrame(f.fix, a, gnss_config_.sigma_floor, &z, &cov);
    if (filter->weighPosition(z, cov, lever) >= 0.0)
    {
      last_weigh_stamp_ = f.fix.stamp;
      ++gnss_weighed_;
    }
  }
}

}  // namespace core
}  // namespace rbpf_slam
