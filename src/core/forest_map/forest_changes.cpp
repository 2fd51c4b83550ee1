#include "rbpf_slam/core/forest_map/forest_changes.h"

#include <cmath>
#include <cstdio>
#include <map>

namespace rbpf_slam
{
namespace core
{
const char* toString(ChangeKind kind)
{
  switch (kind)
  {
    case ChangeKind::kFelled:
      return "felled";
    case ChangeKind::kNew:
      return "new";
    default:
      return "changed";
  }
}

int timesInView(const std::vector<Viewpoint>& viewpoints, const std::vector<Landmark>& trees, const Eigen::Vector2d& p,
                double radius, double range_margin, int enough)
{
  int views = 0;
  for (const Viewpoint& v : viewpoints)
  {
    const Eigen::Vector2d d = p - Eigen::Vector2d(v.sensor.x, v.sensor.y);
    const double range = d.norm();
    const double bearing = wrapAngle(std::atan2(d.y(), d.x()) - v.sensor.theta);
    if (!v.scope.contains(Eigen::Vector2d(range, bearing), range_margin))
      continue;
    bool hidden = false;
    for (const Landmark& t : trees)
    {
      if (t.provisional)
        continue;
      const Eigen::Vector2d e = t.mean - Eigen::Vector2d(v.sensor.x, v.sensor.y);
      const double front = e.norm();
      if (front < range && front > 1e-6 &&
          occludedBy(range, bearing, radius, front, wrapAngle(std::atan2(e.y(), e.x()) - v.sensor.theta), t.radius))
      {
        hidden = true;
        break;
      }
    }
    if (!hidden && ++views >= enough)
      break;
  }
  return views;
}

void ViewpointLog::reset(const std::vector<Viewpoint>& saved)
{
  viewpoints_.clear();
  cells_.clear();
  for (const Viewpoint& v : saved)
    add(v.sensor, v.scope);
}

bool ViewpointLog::add(const Pose2& sensor, const VisibilityScope& scope)
{
  if (!std::isfinite(sensor.x) || !std::isfinite(sensor.y) || !std::isfinite(sensor.theta))
    return false;
  const int heading =
      scope.fullTurn() ? 0 : static_cast<int>(std::floor((wrapAngle(sensor.theta) + M_PI) / (0.25 * M_PI))) % 8;
  const long ix = static_cast<long>(std::floor(sensor.x / kViewpointCell));
  const long iy = static_cast<long>(std::floor(sensor.y / kViewpointCell));
  // A viewpoint of the same heading within a cell's size (in this cell or a neighbour) stands for this one.
  for (long dx = -1; dx <= 1; ++dx)
    for (long dy = -1; dy <= 1; ++dy)
    {
      const auto it = cells_.find(std::make_tuple(ix + dx, iy + dy, heading));
      if (it == cells_.end())
        continue;
      for (const std::size_t k : it->second)
        if (std::hypot(viewpoints_[k].sensor.x - sensor.x, viewpoints_[k].sensor.y - sensor.y) < kViewpointCell)
          return false;
    }
  cells_[std::make_tuple(ix, iy, heading)].push_back(viewpoints_.size());
  viewpoints_.push_back(Viewpoint{ sensor, scope });
  return true;
}

std::vector<TreeChange> detectChanges(const std::vector<Landmark>& before, const std::vector<Landmark>& after,
                                      const ChangeConfig& config, const std::vector<Viewpoint>& viewpoints)
{
  std::map<int, const Landmark*> now, then;
  for (const Landmark& l : after)
    now[l.id] = &l;
  for (const Landmark& l : before)
    then[l.id] = &l;
  std::vector<TreeChange> changes;
  char buf[256];
  // A change of @p kind at the tree @p l: its id, centre, covariance and first sighting.
  const auto changeAt = [](ChangeKind kind, const Landmark& l) {
    TreeChange c;
    c.kind = kind;
    c.id = l.id;
    c.center = l.mean;
    c.covariance = l.covariance;
    c.first_seen = l.first_seen;
    return c;
  };
  for (const Landmark& b : before)
  {
    const auto it = now.find(b.id);
    TreeChange c = changeAt(ChangeKind::kFelled, b);
    c.dbh_before = 2.0 * b.radius;
    c.sigma_dbh_before = 2.0 * std::sqrt(std::max(0.0, b.radius_variance));
    if (it == now.end())
    {
      if (b.provisional)
        continue;  // a glimpse of the last visit, not a tree of the map
      c.last_seen = b.last_seen;
      c.evidence = "expected inside the sensor's scope and not hidden, not seen on this visit until removed";
      changes.push_back(c);
      continue;
    }
    const Landmark& a = *it->second;
    if (a.visit_observations < config.min_observations || !std::isfinite(a.visit_radius))
      continue;
    const double sigma = std::sqrt(std::max(0.0, b.radius_variance) + std::max(0.0, a.visit_radius_variance));
    const double d = a.visit_radius - b.radius;
    if (std::abs(d) <= config.growth_sigmas * sigma + config.growth_floor)
      continue;
    c.kind = ChangeKind::kChanged;
    c.center = a.mean;
    c.covariance = a.covariance;
    c.dbh_after = 2.0 * a.visit_radius;
    c.sigma_dbh_after = 2.0 * std::sqrt(std::max(0.0, a.visit_radius_variance));
    c.observations = a.visit_observations;
    c.last_seen = a.last_seen;
    std::snprintf(buf, sizeof(buf), "radius %+.1f mm from %d matches of this visit (%.1f sigma)", 1000.0 * d,
                  a.visit_observations, sigma > 0.0 ? std::abs(d) / sigma : INFINITY);
    c.evidence = buf;
    changes.push_back(c);
  }
  // A new tree where the saved map had not looked is new to the map, not known to be new: it is not reported, but
  // it still pairs with a felled tree beside it below (a saved tree made again is hidden behind its old self).
  std::vector<bool> unseen_place(changes.size(), false);
  for (const Landmark& a : after)
  {
    if (then.count(a.id) || a.provisional || a.visit_observations < config.min_observations)
      continue;
    int views = -1;  // not known: the saved map says nothing of where it looked
    if (!viewpoints.empty())
      views = timesInView(viewpoints, before, a.mean, a.radius, config.view_range_margin, config.min_views);
    unseen_place.push_back(views >= 0 && views < config.min_views);
    TreeChange c = changeAt(ChangeKind::kNew, a);
    c.dbh_after = 2.0 * a.radius;
    c.sigma_dbh_after = 2.0 * std::sqrt(std::max(0.0, a.radius_variance));
    c.observations = a.visit_observations;
    c.last_seen = a.last_seen;
    if (views >= 0)
      std::snprintf(buf, sizeof(buf),
                    "seen in %d matches of this visit where the saved map has no tree and had it in view from at "
                    "least %d viewpoints",
                    a.visit_observations, views);
    else
      std::snprintf(buf, sizeof(buf), "seen in %d matches of this visit where the saved map has no tree",
                    a.visit_observations);
    c.evidence = buf;
    changes.push_back(c);
  }
  // A felled tree with a new one beside it, of the same radius: the same tree, removed and made again.
  std::vector<bool> drop(changes.size(), false);
  for (std::size_t i = 0; i < changes.size(); ++i)
  {
    if (changes[i].kind != ChangeKind::kFelled)
      continue;
    for (std::size_t j = 0; j < changes.size(); ++j)
    {
      if (drop[j] || changes[j].kind != ChangeKind::kNew ||
          (changes[i].center - changes[j].center).norm() > config.remade_distance)
        continue;
      const double sigma = std::hypot(changes[i].sigma_dbh_before, changes[j].sigma_dbh_after);
      if (std::abs(changes[i].dbh_before - changes[j].dbh_after) <= 2.0 * (config.growth_sigmas * sigma + 0.03))
      {
        drop[i] = drop[j] = true;
        break;
      }
    }
  }
  std::vector<TreeChange> kept;
  for (std::size_t i = 0; i < changes.size(); ++i)
    if (!drop[i] && !unseen_place[i])
      kept.push_back(changes[i]);
  return kept;
}

}  // namespace core
}  // namespace rbpf_slam
