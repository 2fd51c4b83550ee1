#include "rbpf_slam/core/forest_map/loop_closing.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

namespace rbpf_slam
{
namespace core
{
const char* toString(LoopEvent::Kind k)
{
  switch (k)
  {
    case LoopEvent::Kind::kClosed:
      return "closed";
    case LoopEvent::Kind::kRejected:
      return "rejected";
    default:
      return "none";
  }
}

std::string LoopClosureConfig::validate() const
{
  if (!(search_interval >= 0.0) || !(retry_interval >= 0.0))
    return "loop_closure/search_interval and retry_interval must be >= 0";
  if (detection.confirmations < 1)
    return "loop_closure/confirmations must be >= 1";
  if (!(detection.recent_time > 0.0) || !(detection.old_time > 0.0))
    return "loop_closure/recent_time and old_time must be > 0";
  if (detection.constellation.min_inliers < 3)
    return "loop_closure/min_trees must be >= 3";
  const std::string s = smoother.validate();
  return s.empty() ? s : "loop_closure/" + s;
}

LoopClosing::LoopClosing(const LoopClosureConfig& config, const FastSlamConfig& filter)
  : config_(config), detector_(config.detection), smoother_(config.smoother, filter)
{
}

void LoopClosing::reset()
{
  detector_.reset();
  smoother_.clear();
  archive_.clear();
  last_search_ = -1e300;
  retry_after_ = -1e300;
}

LoopEvent LoopClosing::afterUpdate(FastSlam* filter, double stamp, const Pose2& odometry, const Pose2& mount,
                                   const std::vector<LandmarkObservation>& observations, double share)
{
  LoopEvent event;
  smoother_.add(stamp, odometry, mount, observations, share);
  if (!config_.enabled || stamp - last_search_ < config_.search_interval || stamp < retry_after_)
    return event;
  last_search_ = stamp;
  const LandmarkMap& map = filter->best().map;
  const Pose2& robot = filter->best().pose;
  // The archive of old trees: those of the map now old, kept; those seen again, dropped; those the map lost, kept.
  std::unordered_map<int, std::size_t> in_map;
  for (std::size_t i = 0; i < map.size(); ++i)
  {
    const Landmark& l = map[i];
    in_map[l.id] = i;
    if (l.provisional || !std::isfinite(l.last_seen))
      continue;
    if (stamp - l.last_seen >= config_.detection.old_time)
      archive_[l.id] = l;
    else
      archive_.erase(l.id);
  }
  std::vector<Landmark> archived;
  for (const auto& a : archive_)
    if (!in_map.count(a.first))
      archived.push_back(a.second);
  const LoopClosure loop = detector_.search(map, stamp, Eigen::Vector2d(robot.x, robot.y), archived);
  if (!loop.found)
    return event;
  detector_.reset();
  event.correction = loop.correction;
  event.matched = static_cast<int>(loop.merged.size());
  std::unordered_map<int, Eigen::Vector2d> position;
  for (std::size_t i = 0; i < map.size(); ++i)
    position[map[i].id] = map[i].mean;
  for (const Landmark& l : archived)
    position[l.id] = l.mean;
  for (const auto& m : loop.merged)
    event.links.emplace_back(position[m.first], position[m.second]);
  const std::vector<Pose2> path = filter->bestHistory();
  // The map's trees and the archived ones the loop matched.
  std::vector<Landmark> trees = filter->bestTrees();
  for (const auto& m : loop.merged)
    if (!in_map.count(m.second) && archive_.count(m.second))
    {
      trees.push_back(archive_[m.second]);
      in_map[m.second] = trees.size() - 1;
    }
  const SmoothedRun run = smoother_.solve(path, trees, loop.merged);
  event.seconds = run.seconds;
  event.seconds_covariance = run.seconds_covariance;
  event.keyframes = run.keyframes;
  event.identity_chi2 = run.identity_chi2;
  event.identity_bound = run.identity_bound;
  if (!run.ok)
  {
    event.kind = LoopEvent::Kind::kRejected;
    event.reason = run.reason;
    ++rejected_;
    retry_after_ = stamp + config_.retry_interval;  // the same loop would be found, and refused, again at once
    return event;
  }
  const Pose2& now = run.poses.back();
  event.shift = std::hypot(now.x - path.back().x, now.y - path.back().y);
  // The spread the smoother allows, at least the floors (the cloud's own when the marginal is not known).
  Eigen::Matrix3d spread = run.has_covariance ? run.last_covariance : filter->poseCovariance();
  const SmootherConfig& sc = config_.smoother;
  spread(0, 0) = std::max(spread(0, 0), sc.spread_floor_xy * sc.spread_floor_xy);
  spread(1, 1) = std::max(spread(1, 1), sc.spread_floor_xy * sc.spread_floor_xy);
  spread(2, 2) = std::max(spread(2, 2), sc.spread_floor_theta * sc.spread_floor_theta);
  LandmarkMap smoothed;
  for (const Landmark& l : run.trees)
    smoothed.add(l);
  filter->redraw(now, spread, smoothed, run.poses);
  for (const auto& m : loop.merged)
    archive_.erase(m.second);  // merged into a tree just seen: no longer old
  event.kind = LoopEvent::Kind::kClosed;
  ++closed_;
  return event;
}

SmoothedRun LoopClosing::smoothRun(const FastSlam& filter) const
{
  // At the end of a run (or for a saved map) there is no budget to keep: the filter is not waiting.
  return smoother_.solve(filter.bestHistory(), filter.bestTrees(), {}, std::numeric_limits<double>::infinity());
}

}  // namespace core
}  // namespace rbpf_slam
