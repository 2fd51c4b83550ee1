#include "rbpf_slam/core/forest_changes.h"

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

std::vector<TreeChange> detectChanges(const std::vector<Landmark>& before, const std::vector<Landmark>& after,
                                      const ChangeConfig& config)
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
  for (const Landmark& a : after)
  {
    if (then.count(a.id) || a.provisional || a.visit_observations < config.min_observations)
      continue;
    TreeChange c = changeAt(ChangeKind::kNew, a);
    c.dbh_after = 2.0 * a.radius;
    c.sigma_dbh_after = 2.0 * std::sqrt(std::max(0.0, a.radius_variance));
    c.observations = a.visit_observations;
    c.last_seen = a.last_seen;
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
    if (!drop[i])
      kept.push_back(changes[i]);
  return kept;
}

}  // namespace core
}  // namespace rbpf_slam
