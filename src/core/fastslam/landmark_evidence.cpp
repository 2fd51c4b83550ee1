#include "rbpf_slam/core/fastslam/landmark_evidence.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "rbpf_slam/core/filter/pose2.h"

namespace rbpf_slam
{
namespace core
{
const Eigen::Vector2d LandmarkEvidence::kNoView(std::numeric_limits<double>::quiet_NaN(),
                                                std::numeric_limits<double>::quiet_NaN());

namespace
{
void noteRange(Landmark* l, const Eigen::Vector2d& sensor)
{
  if (!sensor.allFinite())
    return;
  const double r = (sensor - l->mean).norm();
  l->seen_range = std::isfinite(l->seen_range) ? std::max(l->seen_range, r) : r;
}
}  // namespace

bool LandmarkEvidence::isNewView(const Landmark& l, const Eigen::Vector2d& sensor) const
{
  if (!(config_.view_change > 0.0) || !sensor.allFinite())
    return true;
  const Eigen::Vector2d d = sensor - l.mean;
  const double range = d.norm();
  if (!(range > 0.0))
    return false;
  if (!std::isfinite(l.view_direction) || !std::isfinite(l.view_log_range))
    return true;
  const double dd = wrapAngle(std::atan2(d.y(), d.x()) - l.view_direction), dr = std::log(range) - l.view_log_range;
  return dd * dd + dr * dr >= config_.view_change * config_.view_change;
}

bool LandmarkEvidence::takeView(Landmark* l, const Eigen::Vector2d& sensor) const
{
  if (!isNewView(*l, sensor))
    return false;
  if (sensor.allFinite())
  {
    const Eigen::Vector2d d = sensor - l->mean;
    l->view_direction = std::atan2(d.y(), d.x());
    l->view_log_range = std::log(d.norm());
  }
  return true;
}

void LandmarkEvidence::initialize(Landmark* l, const Eigen::Vector2d& sensor) const
{
  l->observations = 1;
  l->views = 1;
  l->evidence = config_.hit;
  l->provisional = config_.confirm_observations > 1;
  noteRange(l, sensor);
  takeView(l, sensor);
}

void LandmarkEvidence::recordHit(Landmark* l, const Eigen::Vector2d& sensor) const
{
  ++l->observations;
  noteRange(l, sensor);
  if (!takeView(l, sensor))
    return;
  ++l->views;
  l->evidence = std::min(config_.max, l->evidence + config_.hit);
  if (l->views >= config_.confirm_observations)
    l->provisional = false;
}

MissOutcome LandmarkEvidence::classifyUnseen(const std::vector<AssociationCandidate>& candidates,
                                             const LandmarkMap& map, std::size_t k, const VisibilityScope& scope) const
{
  const AssociationCandidate& cd = candidates[k];
  // A landmark the detector names by its id is there: a miss says only that the detector did not report it.
  if (map[cd.index].known_id)
    return MissOutcome::kOutOfScope;
  // Inside the scope for sure: a landmark predicted within two standard deviations of its prediction from an edge
  // may well lie outside, and is not expected to be seen.
  const double range_margin = 2.0 * std::sqrt(std::max(0.0, cd.A(0, 0)));
  const double bearing_margin = 2.0 * std::sqrt(std::max(0.0, cd.A(1, 1)));
  if (!scope.contains(cd.z, range_margin, bearing_margin))
  {
    // Just beyond the scope's far edge (the candidates reach a margin further): a provisional landmark here is
    // leaving the scope unconfirmed (the sensor moves a few centimetres per update, so none jumps the ring).
    // Landmarks outside the field of view or too near may come back into view as the robot turns or passes:
    // they are kept.
    if (config_.drop_unconfirmed_leaving_scope && scope.beyondFarEdge(cd.z) && map[cd.index].provisional)
      return MissOutcome::kLeavingUnconfirmed;
    return MissOutcome::kOutOfScope;
  }
  // Beyond the farthest range it was seen from, a trunk may be too thin for the beams' spacing there.
  const double seen_range = map[cd.index].seen_range;
  if (std::isfinite(seen_range) && cd.z.x() > seen_range + range_margin)
    return MissOutcome::kOutOfScope;
  const double own_radius = map[cd.index].radius;
  for (std::size_t m = 0; m < candidates.size(); ++m)
  {
    if (m == k)
      continue;
    if (occludedBy(cd.z.x(), cd.z.y(), own_radius, candidates[m].z.x(), candidates[m].z.y(),
                   map[candidates[m].index].radius))
      return MissOutcome::kHidden;
  }
  return MissOutcome::kMissed;
}

std::size_t LandmarkEvidence::applyMisses(LandmarkMap* map, const DataAssociation& association,
                                          const VisibilityScope& scope, std::vector<Eigen::Vector2d>* removed,
                                          const Eigen::Vector2d& sensor)
{
  const std::vector<AssociationCandidate>& candidates = association.candidates();
  to_delete_.clear();
  for (std::size_t k = 0; k < candidates.size(); ++k)
  {
    if (association.taken(k))
      continue;
    switch (classifyUnseen(candidates, *map, k, scope))
    {
      case MissOutcome::kLeavingUnconfirmed:
        to_delete_.push_back(candidates[k].index);
        break;
      case MissOutcome::kMissed:
      {
        // Not a new view: nothing changes, and the landmark's chunk stays shared with the other particles.
        if (!isNewView((*map)[candidates[k].index], sensor))
          break;
        bool remove = false;
        map->modify(candidates[k].index, [&](Landmark& l) {
          takeView(&l, sensor);
          // A miss weighs as much as the sensor was likely to report the landmark: with detection probability
          // p a landmark that is there gains p * hit - (1 - p) * p * miss per look on average, > 0 for any p
          // when hit >= miss, so a sensor that reports few of the landmarks it sees does not erase its map,
          // while one that misses nothing removes a phantom quickly.
          l.evidence -= config_.miss * scope.detection_probability;
          remove = l.evidence < config_.delete_below;
        });
        if (remove)
          to_delete_.push_back(candidates[k].index);
        break;
      }
      case MissOutcome::kOutOfScope:
      case MissOutcome::kHidden:
        break;
    }
  }
  // Highest index first: remove() moves the last landmark into the hole, which must not be one still to go.
  std::sort(to_delete_.rbegin(), to_delete_.rend());
  for (std::size_t j : to_delete_)
  {
    // Only confirmed landmarks are reported: a provisional one was never part of the map.
    if (removed && !(*map)[j].provisional)
      removed->push_back((*map)[j].mean);
    map->remove(j);
  }
  return to_delete_.size();
}

}  // namespace core
}  // namespace rbpf_slam
