#include "rbpf_slam/core/forest_map/loop_closing.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <unordered_map>

#include <Eigen/Geometry>

namespace rbpf_slam
{
namespace core
{
namespace
{
/** @brief [m] The recent trees a loop matched fix its turn when they spread this far (RMS about their centre). */
constexpr double kMinSpreadForTurn = 3.0;
/** @brief Filter updates between two thinnings of the smoother's records (TrunkSmoother::thin). */
constexpr int kThinInterval = 50;

/** @brief The smoother's configuration, its minimum of a loop's pairs the search's. */
SmootherConfig smootherConfig(const LoopClosureConfig& c)
{
  SmootherConfig s = c.smoother;
  s.loop_min_trees = c.detection.constellation.min_inliers;
  return s;
}
}  // namespace

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
  if (apply_after < 0 || smooth_interval < 0)
    return "loop_closure/apply_after and smooth_interval must be >= 0";
  if (!(drift_quantile > 0.0 && drift_quantile <= 1.0))
    return "loop_closure/drift_quantile must lie in (0, 1] (1: no bound)";
  if (detection.constellation.min_inliers < 3)
    return "loop_closure/min_trees must be >= 3";
  const std::string s = smoother.validate();
  return s.empty() ? s : "loop_closure/" + s;
}

LoopClosing::LoopClosing(const LoopClosureConfig& config, const FastSlamConfig& filter)
  : config_(config), detector_(config.detection), smoother_(smootherConfig(config), filter)
{
}

void LoopClosing::reset()
{
  pending_.reset();  // waits for a solve under way, and forgets it
  queued_.reset();
  anchor_ = Pose2();
  anchor_covariance_.setZero();
  updates_ = 0;
  last_smoothing_ = 0;
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
  ++updates_;
  // Revisits of a place older than the trees a loop search calls recent keep one look per keyframe: the records grow
  // with the distance driven, not with the sweeps.
  if (updates_ % kThinInterval == 0)
    smoother_.thin(filter->bestHistory(), stamp - config_.detection.recent_time, config_.detection.old_time);
  if (pending_ && updates_ >= pending_->apply_at)
  {
    std::unique_ptr<Pending> p = std::move(pending_);
    event = apply(filter, stamp, p.get());
  }
  if (!pending_ && queued_)
  {
    // A loop found while the run was being smoothed: solved now, on the filter as it stands.
    std::unique_ptr<FoundLoop> loop = std::move(queued_);
    return launch(filter, stamp, std::move(*loop), event);
  }
  if (event.kind != LoopEvent::Kind::kNone || (pending_ && pending_->loop))
    return event;  // no search while a loop is being solved
  if (config_.enabled && stamp - last_search_ >= config_.search_interval && stamp >= retry_after_)
  {
    FoundLoop loop;
    if (search(*filter, stamp, &loop))
    {
      if (!loop.refused.empty())
      {
        event = loop.event;
        event.kind = LoopEvent::Kind::kRejected;
        event.reason = loop.refused;
        ++rejected_;
        retry_after_ = stamp + config_.retry_interval;
        return event;
      }
      if (pending_)
      {
        queued_.reset(new FoundLoop(std::move(loop)));
        return event;
      }
      return launch(filter, stamp, std::move(loop), event);
    }
  }
  if (!pending_ && config_.smooth_interval > 0 && updates_ - last_smoothing_ >= config_.smooth_interval)
    return launch(filter, stamp, FoundLoop(), event);
  return event;
}

bool LoopClosing::search(const FastSlam& filter, double stamp, FoundLoop* found)
{
  last_search_ = stamp;
  const LandmarkMap& map = filter.best().map;
  const Pose2& robot = filter.best().pose;
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
    return false;
  detector_.reset();
  found->found = true;
  found->event.found = stamp;
  found->event.found_update = updates_;
  found->event.correction = loop.correction;
  found->event.matched = static_cast<int>(loop.merged.size());
  std::unordered_map<int, Eigen::Vector2d> position;
  for (std::size_t i = 0; i < map.size(); ++i)
    position[map[i].id] = map[i].mean;
  for (const Landmark& l : archived)
    position[l.id] = l.mean;
  for (const auto& m : loop.merged)
    found->event.links.emplace_back(position[m.first], position[m.second]);
  found->refused = beyondDrift(filter, loop, stamp, in_map);
  // The archived trees the loop matched (the map's own are taken when it is solved).
  for (const auto& m : loop.merged)
    if (!in_map.count(m.second) && archive_.count(m.second))
      found->archived.push_back(archive_[m.second]);
  found->merged = loop.merged;
  return true;
}

std::string LoopClosing::beyondDrift(const FastSlam& filter, const LoopClosure& loop, double stamp,
                                     const std::unordered_map<int, std::size_t>& in_map) const
{
  // When the old trees were last seen: the odometry's drift since then bounds how far the map can be off. And what
  // the loop asks of the recent trees it matched: their mean shift, and their spread (whether they fix a turn).
  double last_old = -std::numeric_limits<double>::infinity();
  Eigen::Vector2d shift = Eigen::Vector2d::Zero(), centre = Eigen::Vector2d::Zero();
  std::vector<Eigen::Vector2d> recent;
  for (const auto& m : loop.merged)
  {
    const auto i = in_map.find(m.second);
    const auto a = archive_.find(m.second);
    const double seen = i != in_map.end() ? filter.best().map[i->second].last_seen :
                                            (a != archive_.end() ? a->second.last_seen : NAN);
    if (std::isfinite(seen))
      last_old = std::max(last_old, seen);
    const auto r = in_map.find(m.first);
    if (r == in_map.end())
      continue;
    const Eigen::Vector2d p = filter.best().map[r->second].mean;
    double x = 0.0, y = 0.0;
    loop.correction.transformPoint(p.x(), p.y(), &x, &y);
    shift += Eigen::Vector2d(x, y) - p;
    centre += p;
    recent.push_back(p);
  }
  if (!std::isfinite(last_old) || recent.empty() || !(config_.drift_quantile < 1.0))
    return "";
  shift /= static_cast<double>(recent.size());
  centre /= static_cast<double>(recent.size());
  double spread = 0.0;
  for (const Eigen::Vector2d& p : recent)
    spread += (p - centre).squaredNorm() / static_cast<double>(recent.size());
  // Trees within a few metres of each other do not fix a turn (a clump matches itself at any angle).
  const bool turn = std::sqrt(spread) >= kMinSpreadForTurn;
  Pose2 odometry_then;
  const Eigen::Matrix3d drift = smoother_.driftSince(std::min(last_old, stamp), &odometry_then);
  // The shift (and turn) the loop asks of the recent trees against the robot's drift, in the frame of the robot when
  // the old trees were last seen (its heading then: the heading now less the odometry's turn since).
  const Pose2& robot = filter.best().pose;
  const double heading_then = robot.theta - wrapAngle(smoother_.lastOdometry().theta - odometry_then.theta);
  const double c = std::cos(heading_then), s = std::sin(heading_then);
  const double dx = shift.x(), dy = shift.y();
  const Eigen::Vector3d d(c * dx + s * dy, -s * dx + c * dy, wrapAngle(loop.correction.theta));
  const Eigen::Matrix3d cov = drift + Eigen::Vector3d(1e-6, 1e-6, 1e-8).asDiagonal().toDenseMatrix();
  const int dof = turn ? 3 : 2;
  const double d2 = turn ? d.dot(cov.ldlt().solve(d)) :
                           d.head<2>().dot(cov.topLeftCorner<2, 2>().ldlt().solve(d.head<2>()));
  const double bound = chiSquareQuantile(config_.drift_quantile, dof);
  if (d2 <= bound)
    return "";
  char text[256];
  std::snprintf(text, sizeof(text),
                "its correction (%.2f m, %.1f deg%s) is beyond what the odometry can drift since the old trees were "
                "seen %.0f s ago (chi-square %.1f > %.1f)",
                std::hypot(dx, dy), d(2) * 180.0 / M_PI, turn ? "" : ", a clump: the turn not counted",
                stamp - last_old, d2, bound);
  return text;
}

LoopEvent LoopClosing::launch(FastSlam* filter, double stamp, FoundLoop&& loop, const LoopEvent& applied)
{
  pending_.reset(new Pending);
  Pending& p = *pending_;
  p.loop = loop.found;
  p.event = std::move(loop.event);
  p.merged = std::move(loop.merged);
  p.records = smoother_.size();
  p.apply_at = updates_ + config_.apply_after;
  p.estimate = filter->estimate();
  if (!p.loop)
    last_smoothing_ = updates_;
  // The map's trees and the archived ones the loop matched.
  std::vector<Landmark> trees = filter->bestTrees();
  std::set<int> ids;
  for (const Landmark& l : trees)
    ids.insert(l.id);
  for (Landmark& l : loop.archived)
    if (!ids.count(l.id))
      trees.push_back(std::move(l));
  // The solve works on copies (the records go on growing meanwhile).
  auto smoother = std::make_shared<const TrunkSmoother>(smoother_);
  auto job = [smoother, path = filter->bestHistory(), trees = std::move(trees), merged = p.merged]() {
    return smoother->solve(path, trees, merged);
  };
  if (config_.apply_after <= 0)
  {
    std::promise<SmoothedRun> done;
    done.set_value(job());
    p.result = done.get_future();
    std::unique_ptr<Pending> now = std::move(pending_);
    return apply(filter, stamp, now.get());
  }
  p.result = std::async(std::launch::async, std::move(job));
  return applied;
}

Pose2 LoopClosing::published(const Pose2& filter_estimate) const
{
  return anchor_ * filter_estimate;
}

namespace
{
/** @brief @p l carried by the rigid motion @p t of the map frame. */
Landmark moved(const Landmark& l, const Pose2& t)
{
  Landmark m = l;
  const Eigen::Matrix2d R = Eigen::Rotation2Dd(t.theta).toRotationMatrix();
  m.mean = R * l.mean + Eigen::Vector2d(t.x, t.y);
  m.covariance = R * l.covariance * R.transpose();
  if (std::isfinite(l.view_direction))
    m.view_direction = wrapAngle(l.view_direction + t.theta);
  return m;
}
}  // namespace

LoopEvent LoopClosing::apply(FastSlam* filter, double stamp, Pending* pending)
{
  const SmoothedRun run = pending->result.get();  // waits, when the solve has not ended yet
  LoopEvent event = pending->event;
  event.seconds = run.seconds;
  event.seconds_covariance = run.seconds_covariance;
  event.keyframes = run.keyframes;
  event.identity_chi2 = run.identity_chi2;
  event.identity_bound = run.identity_bound;
  event.dropped = run.identities_dropped;
  if (!pending->loop)
  {
    // The run smoothed up to the update that launched it: the published estimate is the smoothed pose there, carried
    // on by the filter's own motion since.
    if (run.ok && run.poses.size() == pending->records)
    {
      anchor_ = run.poses.back() * pending->estimate.inverse();
      anchor_from_ = run.poses.back();
      anchor_covariance_ = run.has_covariance ? run.last_covariance : Eigen::Matrix3d::Zero();
    }
    return LoopEvent();
  }
  const std::vector<Pose2> path = filter->bestHistory();
  const std::size_t n = pending->records;
  if (run.ok && (run.poses.size() != n || path.size() < n))
  {
    event.kind = LoopEvent::Kind::kRejected;
    event.reason = "the filter's history no longer matches the solved path";
  }
  if (!run.ok || event.kind == LoopEvent::Kind::kRejected)
  {
    event.kind = LoopEvent::Kind::kRejected;
    if (event.reason.empty())
    {
      event.reason = run.reason;
      event.inconsistent = run.inconsistent;
    }
    ++rejected_;
    retry_after_ = stamp + config_.retry_interval;  // the same loop would be found, and refused, again at once
    return event;
  }
  // The smoothed path up to the loop, carried to now by the best particle's own motion since: the rigid motion that
  // takes its pose at the loop onto the smoothed one takes its later poses and the trees it found since.
  const Pose2 t = run.poses.back() * path[n - 1].inverse();
  std::vector<Pose2> smoothed_path = run.poses;
  for (std::size_t k = n; k < path.size(); ++k)
    smoothed_path.push_back(t * path[k]);
  const Pose2 now = t * filter->best().pose;
  event.shift = std::hypot(now.x - filter->best().pose.x, now.y - filter->best().pose.y);
  // The spread the smoother allows, at least the floors (the cloud's own when the marginal is not known).
  Eigen::Matrix3d spread = run.has_covariance ? run.last_covariance : filter->poseCovariance();
  const SmootherConfig& sc = config_.smoother;
  spread(0, 0) = std::max(spread(0, 0), sc.spread_floor_xy * sc.spread_floor_xy);
  spread(1, 1) = std::max(spread(1, 1), sc.spread_floor_xy * sc.spread_floor_xy);
  spread(2, 2) = std::max(spread(2, 2), sc.spread_floor_theta * sc.spread_floor_theta);
  LandmarkMap smoothed;
  std::set<int> solved;
  for (const Landmark& l : run.trees)
  {
    smoothed.add(l);
    solved.insert(l.id);
  }
  for (const auto& m : pending->merged)
    solved.insert(m.first);  // merged into the old tree
  for (const Landmark& l : filter->bestTrees())
    if (!solved.count(l.id))
      smoothed.add(moved(l, t));
  filter->redraw(now, spread, smoothed, smoothed_path);
  anchor_ = Pose2();  // the filter is the smoothed estimate now
  anchor_covariance_.setZero();
  for (const auto& m : pending->merged)
    archive_.erase(m.second);  // merged into a tree just seen: no longer old
  event.kind = LoopEvent::Kind::kClosed;
  ++closed_;
  return event;
}

SmoothedRun LoopClosing::smoothRun(const FastSlam& filter) const
{
  return smoothingJob(filter)();
}

std::function<SmoothedRun()> LoopClosing::smoothingJob(const FastSlam& filter) const
{
  auto smoother = std::make_shared<const TrunkSmoother>(smoother_);
  return [smoother, path = filter.bestHistory(), trees = filter.bestTrees()]() {
    return smoother->solve(path, trees, {});
  };
}

}  // namespace core
}  // namespace rbpf_slam
