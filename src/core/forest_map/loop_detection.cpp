#include "rbpf_slam/core/forest_map/loop_detection.h"

#include <cmath>
#include <stdexcept>

namespace rbpf_slam
{
namespace core
{
LoopClosure LoopDetector::search(const LandmarkMap& map, double now, const Eigen::Vector2d& robot,
                                 const std::vector<Landmark>& archived)
{
  LoopClosure out;
  std::vector<Landmark> old = archived;
  std::vector<TrunkPoint> recent;
  std::vector<int> recent_ids;
  for (std::size_t i = 0; i < map.size(); ++i)
  {
    const Landmark& l = map[i];
    if (l.provisional || !std::isfinite(l.first_seen) || !std::isfinite(l.last_seen))
      continue;
    if (now - l.first_seen <= config_.recent_time)
    {
      if ((l.mean - robot).norm() > config_.recent_radius)
        continue;
      recent.push_back(trunkPoint(l));
      recent_ids.push_back(l.id);
    }
    else if (now - l.last_seen >= config_.old_time)
      old.push_back(l);
  }
  out.recent = static_cast<int>(recent.size());
  out.old = static_cast<int>(old.size());
  const auto fail = [&](const std::string& why) {
    agreeing_ = 0;
    out.reason = why;
    return out;
  };
  if (out.recent < config_.constellation.min_inliers || out.old < config_.constellation.min_inliers)
    return fail("too few trees: " + std::to_string(out.recent) + " recent, " + std::to_string(out.old) + " old");
  ConstellationResult r;
  try
  {
    const ConstellationMatcher matcher(old, config_.constellation);
    r = matcher.match(recent);
  }
  catch (const std::invalid_argument& e)  // more pairs than the index takes (ConstellationConfig::max_pairs)
  {
    return fail(e.what());
  }
  if (!r.accepted || r.hypotheses.empty())
    return fail(r.reason.empty() ? "no constellation" : r.reason);
  const PoseHypothesis& h = r.hypotheses.front();
  out.inliers = h.inliers;
  out.rms = h.rms;
  out.correction = h.transform;
  if (std::hypot(h.transform.x, h.transform.y) < config_.min_correction && std::abs(h.transform.theta) < config_.min_angle)
  {
    // A correction at a tree's rotation centre is small in translation: judge the shift of the recent trees.
    double worst = 0.0;
    for (const TrunkPoint& t : recent)
    {
      double x = 0.0, y = 0.0;
      h.transform.transformPoint(t.center.x(), t.center.y(), &x, &y);
      worst = std::max(worst, std::hypot(x - t.center.x(), y - t.center.y()));
    }
    if (worst < config_.min_correction)
      return fail("the recent trees already lie on the old ones");
  }
  const Pose2 d = last_.inverse() * h.transform;
  const bool agrees = agreeing_ > 0 && std::hypot(d.x, d.y) < config_.agree_distance &&
                      std::abs(d.theta) < config_.agree_angle;
  agreeing_ = agrees ? agreeing_ + 1 : 1;
  last_ = h.transform;
  out.agreeing = agreeing_;
  if (agreeing_ < config_.confirmations)
  {
    out.reason = "waiting for confirmation (" + std::to_string(agreeing_) + " of " +
                 std::to_string(config_.confirmations) + ")";
    return out;
  }
  // The trees the loop shows to be one: each recent tree with the old tree its corrected position falls on.
  for (std::size_t i = 0; i < recent.size(); ++i)
  {
    double x = 0.0, y = 0.0;
    h.transform.transformPoint(recent[i].center.x(), recent[i].center.y(), &x, &y);
    int best = -1;
    double best_d = config_.constellation.inlier_gate;
    for (const Landmark& l : old)
    {
      const double dist = std::hypot(l.mean.x() - x, l.mean.y() - y);
      if (dist < best_d)
      {
        best_d = dist;
        best = l.id;
      }
    }
    if (best >= 0)
      out.merged.emplace_back(recent_ids[i], best);
  }
  out.found = true;
  return out;
}

}  // namespace core
}  // namespace rbpf_slam
