#include "rbpf_slam/core/forest_map/relocalization.h"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace rbpf_slam
{
namespace core
{
namespace
{
double since(std::chrono::steady_clock::time_point t0)
{
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

Relocalizer::Relocalizer(const std::vector<Landmark>& trees, const RelocalizationConfig& config, bool when_lost)
  : config_(config), matcher_(trees, config.constellation), when_lost_(when_lost)
{
}

void Relocalizer::reset()
{
  restartSearch();
  lost_search_ = false;
  lost_search_end_ = -1e300;
  last_unobserved_ = false;
}

void Relocalizer::restartSearch()
{
  gathered_.clear();
  search_travel_ = 0.0;
  search_started_ = false;
}

bool Relocalizer::search(const std::vector<TrunkObservation>& trunks, const Pose2& mount, const Pose2& odom_mid,
                         RelocalizationStatus* st, std::vector<Pose2>* starts)
{
  const auto t0 = std::chrono::steady_clock::now();
  const RelocalizationConfig& rc = config_;
  if (search_started_)
    search_travel_ += std::hypot(odom_mid.x - search_last_odometry_.x, odom_mid.y - search_last_odometry_.y);
  search_started_ = true;
  search_last_odometry_ = odom_mid;
  // The trunks of this sweep in the odometry frame, merged with those gathered before.
  const Pose2 sensor = odom_mid * mount;
  for (const TrunkObservation& t : trunks)
  {
    if (!std::isfinite(t.center.x()) || !std::isfinite(t.center.y()) || !std::isfinite(t.radius))
      continue;
    Eigen::Vector2d p;
    sensor.transformPoint(t.center.x(), t.center.y(), &p.x(), &p.y());
    Gathered* near = nullptr;
    double best = rc.merge_distance;
    for (Gathered& g : gathered_)
    {
      const double d = (g.center - p).norm();
      if (d < best)
      {
        best = d;
        near = &g;
      }
    }
    if (!near)
    {
      gathered_.push_back(Gathered());
      near = &gathered_.back();
      near->center = p;
      near->radius = t.radius;
    }
    else
    {
      const double w = 1.0 / (near->sightings + 1.0);
      near->center += w * (p - near->center);
      near->radius += w * (t.radius - near->radius);
    }
    ++near->sightings;
    near->travel = search_travel_;
  }
  gathered_.erase(std::remove_if(gathered_.begin(), gathered_.end(),
                                 [&](const Gathered& g) { return search_travel_ - g.travel > rc.window; }),
                  gathered_.end());
  std::vector<TrunkPoint> seen;
  for (const Gathered& g : gathered_)
    if (g.sightings >= rc.min_sightings)
    {
      TrunkPoint tp;
      tp.center = g.center;
      tp.radius = g.radius;
      tp.radius_sigma = 0.02;
      seen.push_back(tp);
    }
  // The nearest trunks first: they make the pairs of the search (max_pair_trunks).
  std::sort(seen.begin(), seen.end(), [&](const TrunkPoint& a, const TrunkPoint& b) {
    return (a.center - Eigen::Vector2d(sensor.x, sensor.y)).squaredNorm() <
           (b.center - Eigen::Vector2d(sensor.x, sensor.y)).squaredNorm();
  });
  last_seen_ = seen;
  st->active = true;
  st->trunks = static_cast<int>(seen.size());
  st->travel = search_travel_;
  bool found = false;
  if (static_cast<int>(seen.size()) < rc.constellation.min_inliers)
    st->reason = "gathering trunks: " + std::to_string(seen.size()) + " seen twice, " +
                 std::to_string(rc.constellation.min_inliers) + " needed";
  else
  {
    const ConstellationResult r = matcher_.match(seen);
    if (!r.hypotheses.empty())
      st->best_inliers = r.hypotheses.front().inliers;
    if (r.hypotheses.size() > 1)
      st->second_inliers = r.hypotheses[1].inliers;
    st->reason = r.reason;
    if (r.accepted)
    {
      starts->clear();
      start_log_weights_.clear();
      for (const PoseHypothesis& h : r.hypotheses)
        if (h.inliers >= rc.hypothesis_share * r.hypotheses.front().inliers)
        {
          starts->push_back(h.transform * odom_mid);
          start_log_weights_.push_back(matcher_.logLikelihood(seen, h.transform));
        }
      st->hypotheses = static_cast<int>(starts->size());
      gathered_.clear();
      found = true;
    }
  }
  st->seconds = since(t0);
  return found;
}

Relocalizer::Tracking Relocalizer::whileTracking(const std::vector<TrunkObservation>& trunks, const Pose2& mount,
                                                const Pose2& odom_mid, const std::function<Pose2()>& estimate_of,
                                                bool unobserved, double travel, RelocalizationStatus* status,
                                                std::vector<Pose2>* starts)
{
  const RelocalizationConfig& rc = config_;
  const bool before = last_unobserved_;
  last_unobserved_ = unobserved;
  if (!when_lost_)
    return Tracking::kNoSearch;
  // A search begins when the saved map's trees stop being re-observed, or while they stay so, a window of travel
  // after the last search ended (the estimate it confirmed may have been lost since).
  if (!lost_search_ && unobserved && (!before || travel - lost_search_end_ > rc.window))
  {
    lost_search_ = true;
    restartSearch();
  }
  if (!lost_search_)
    return Tracking::kNoSearch;
  RelocalizationStatus& st = *status;
  st = RelocalizationStatus();
  st.lost = true;
  Tracking result = Tracking::kSearching;
  if (search(trunks, mount, odom_mid, &st, starts))
  {
    const Pose2 estimate = estimate_of();
    const Pose2 d = between(estimate, starts->front());
    // The estimate's own support among the trunks the search gathered (odometry frame -> map by the estimate).
    const int estimate_inliers = matcher_.inliers(last_seen_, estimate * odom_mid.inverse());
    const bool distinct = std::hypot(d.x, d.y) > rc.recover_distance || std::abs(d.theta) > rc.recover_angle;
    if (!distinct)
      st.confirmed = true;
    else if (st.best_inliers >= std::max(rc.recover_min_inliers, rc.constellation.min_inliers) &&
             st.best_inliers >= estimate_inliers + rc.recover_margin)
    {
      // Found elsewhere: the particles start again on the saved map, over the hypotheses and the estimate (should
      // the search be the one that is wrong, the next sweeps say so).
      starts->push_back(estimate);
      start_log_weights_.push_back(matcher_.logLikelihood(last_seen_, estimate * odom_mid.inverse()));
      last_unobserved_ = false;
      st.recovered = true;
      st.found = true;
      result = Tracking::kRecovered;
    }
    else
    {
      st.reason = "found elsewhere with " + std::to_string(st.best_inliers) + " trunks, the estimate explains " +
                  std::to_string(estimate_inliers) + ": not enough to move the particles";
      return Tracking::kSearching;  // go on gathering
    }
    lost_search_ = false;
    lost_search_end_ = travel;
  }
  else if (search_travel_ > rc.window)
  {
    // Nothing found within a window of travel: this search ends; the next warning starts another.
    lost_search_ = false;
    lost_search_end_ = travel;
    st.gave_up = true;
  }
  return result;
}

}  // namespace core
}  // namespace rbpf_slam
