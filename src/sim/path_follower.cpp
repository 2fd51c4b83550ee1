#include "rbpf_slam/sim/path_follower.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <cstdint>

#include "rbpf_slam/core/filter/cell_key.h"

namespace rbpf_slam
{
namespace sim
{
using core::Pose2;

namespace
{
constexpr double kMemoryCell = 0.1;   // [m] the obstacle memory keeps one point per cell of the odom frame
constexpr double kExtentCell = 0.2;   // [m] cells in which obstaclesFromCloud measures the height extent
constexpr int kArcsPerSide = 20;      // candidate curvatures on each side of straight ahead
constexpr double kSlowFactor = 1.0 / 3.0;  // of the speed, on an arc that keeps only the footprint clear
constexpr double kApproachSlack = 0.02;    // [m] an arc may come this much nearer to a point already too near
constexpr double kPlanCell = 0.15;         // [m] the way planner's grid
constexpr int kPlanEvery = 5;              // the way is planned again at every 5th command, followed in between
constexpr double kCarrot = 1.0;            // [m] along the planned way: the point steered to
constexpr double kTurnInPlaceBearing = M_PI / 3.0;  // [rad] a carrot farther round than this is turned to in place
constexpr double kNearCost = 3.0;          // a step within clearance of an obstacle point costs this many times more

std::int64_t cellKey(double x, double y, double cell)
{
  const std::int64_t ix = static_cast<std::int64_t>(std::floor(x / cell));
  const std::int64_t iy = static_cast<std::int64_t>(std::floor(y / cell));
  return core::packCell(ix, iy);
}

/**
 * The smallest distance from obstacle point @p p (base_link) to base_link driven along the arc of curvature
 * @p kappa over arc length [0, @p length] from the origin heading +x.
 */
double arcDistance(const Eigen::Vector2d& p, double kappa, double length)
{
  if (std::abs(kappa) < 1e-9)
  {
    const double t = std::max(0.0, std::min(length, p.x()));
    return std::hypot(p.x() - t, p.y());
  }
  // A right turn is a left turn of the mirrored point.
  const double k = std::abs(kappa);
  const double py = kappa > 0.0 ? p.y() : -p.y();
  const double r = 1.0 / k;
  // The arc turns about (0, r); base_link is at angle -pi/2 about it at the start, -pi/2 + k s after s.
  const double qx = p.x(), qy = py - r;
  const double d = std::hypot(qx, qy);
  const double sweep = std::min(k * length, 2.0 * M_PI);
  double e = std::atan2(qy, qx) + M_PI / 2.0;  // the point's angle about the centre, from the start
  e = std::fmod(e + 4.0 * M_PI, 2.0 * M_PI);
  if (e <= sweep)
    return std::abs(d - r);
  const double ex = r * std::sin(sweep), ey = r * (1.0 - std::cos(sweep));
  return std::min(std::hypot(p.x(), py), std::hypot(p.x() - ex, py - ey));
}
}  // namespace

namespace
{
/** The command along the arc of curvature @p kappa at @p speed, slower where it is sharp (|angular| <= max). */
VelocityCommand arcCommand(double kappa, double speed, double max_angular)
{
  VelocityCommand cmd;
  cmd.linear = std::abs(kappa) > 1e-9 ? std::min(speed, max_angular / std::abs(kappa)) : speed;
  cmd.angular = cmd.linear * kappa;
  return cmd;
}
}  // namespace

bool PathFollowerConfig::validate(std::string* error) const
{
  const auto fail = [error](const std::string& what) {
    if (error)
      *error = what;
    return false;
  };
  if (!(robot_radius >= 0.0) || !(clearance >= 0.0) || !(min_clearance >= 0.0) || !(max_departure >= 0.0))
    return fail("robot_radius, clearance, min_clearance and max_departure must be >= 0");
  if (min_clearance > clearance)
    return fail("min_clearance must be <= clearance");
  if (!(horizon > 0.0) || !(max_curvature > 0.0))
    return fail("horizon and max_curvature must be > 0");
  if (!(obstacle_memory >= 0.0) || !(obstacle_range > 0.0))
    return fail("obstacle_memory must be >= 0 and obstacle_range > 0");
  if (!(obstacle_min_height <= obstacle_max_height) || !(obstacle_min_extent >= 0.0))
    return fail("obstacle_min_height must be <= obstacle_max_height and obstacle_min_extent >= 0");
  return true;
}

std::vector<Eigen::Vector2d> obstaclesFromCloud(const std::vector<Eigen::Vector3d>& points,
                                                const PathFollowerConfig& config)
{
  std::vector<Eigen::Vector2d> out;
  const double range2 = config.obstacle_range * config.obstacle_range;
  // The height each cell's points span (ground returns below the band included: a trunk's foot stands on it).
  std::map<std::int64_t, std::pair<double, double>> extent;
  for (const Eigen::Vector3d& p : points)
  {
    if (!p.allFinite() || p.x() * p.x() + p.y() * p.y() > range2 || p.z() > config.obstacle_max_height)
      continue;
    auto it = extent.emplace(cellKey(p.x(), p.y(), kExtentCell), std::make_pair(p.z(), p.z())).first;
    it->second.first = std::min(it->second.first, p.z());
    it->second.second = std::max(it->second.second, p.z());
  }
  for (const Eigen::Vector3d& p : points)
  {
    if (!p.allFinite() || p.x() * p.x() + p.y() * p.y() > range2 || p.z() > config.obstacle_max_height ||
        p.z() < config.obstacle_min_height)
      continue;
    const auto& e = extent.at(cellKey(p.x(), p.y(), kExtentCell));
    if (e.second - e.first >= config.obstacle_min_extent)
      out.emplace_back(p.x(), p.y());
  }
  return out;
}

bool GravityLevel::add(double stamp, const Eigen::Vector3d& f)
{
  constexpr double kG = 9.80665;
  if (!f.allFinite() || !std::isfinite(stamp) || std::abs(f.norm() - kG) > 0.5 * kG)
    return false;
  if (!have_)
    mean_ = f;
  else
  {
    // An exponential average over time_constant_ (a sample that goes back in time restarts nothing: weight 0).
    const double dt = std::max(0.0, stamp - last_stamp_);
    const double w = time_constant_ > 0.0 ? 1.0 - std::exp(-dt / time_constant_) : 1.0;
    mean_ += w * (f - mean_);
  }
  last_stamp_ = std::max(last_stamp_, stamp);
  have_ = true;
  return true;
}

Eigen::Matrix3d GravityLevel::levelling() const
{
  // base_link = Rz(yaw) Ry(pitch) Rx(roll) in a level frame; gravity's reaction seen in base_link is
  // (Ry(pitch) Rx(roll))^T (0, 0, g), which gives roll and pitch.
  const double roll = std::atan2(mean_.y(), mean_.z());
  const double pitch = std::atan2(-mean_.x(), std::hypot(mean_.y(), mean_.z()));
  return (Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

std::vector<Eigen::Vector2d> obstaclesFromScan(const std::vector<float>& ranges, double angle_min,
                                               double angle_increment, double range_min, double range_max,
                                               const Pose2& mount, const PathFollowerConfig& config)
{
  std::vector<Eigen::Vector2d> out;
  for (std::size_t i = 0; i < ranges.size(); ++i)
  {
    const double r = ranges[i];
    if (!std::isfinite(r) || r < range_min || r > range_max)
      continue;
    const double a = angle_min + static_cast<double>(i) * angle_increment;
    Eigen::Vector2d p;
    mount.transformPoint(r * std::cos(a), r * std::sin(a), &p.x(), &p.y());
    if (p.norm() <= config.obstacle_range)
      out.push_back(p);
  }
  return out;
}

PathFollower::PathFollower(std::vector<Eigen::Vector2d> path, const PathFollowerConfig& config)
  : path_(std::move(path)), config_(config)
{
  if (path_.empty())
    path_.emplace_back(0.0, 0.0);
  if (path_.size() == 1)
    path_.push_back(path_.front());
  cumulative_.push_back(0.0);
  for (std::size_t i = 1; i < path_.size(); ++i)
    cumulative_.push_back(cumulative_.back() + (path_[i] - path_[i - 1]).norm());
}

double segmentFraction(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& p)
{
  const Eigen::Vector2d ab = b - a;
  const double len2 = ab.squaredNorm();
  return len2 > 0.0 ? std::max(0.0, std::min(1.0, (p - a).dot(ab) / len2)) : 0.0;
}

Eigen::Vector2d PathFollower::pointAt(double s) const
{
  s = std::max(0.0, std::min(s, cumulative_.back()));
  const auto it = std::upper_bound(cumulative_.begin(), cumulative_.end(), s);
  const std::size_t i = std::min<std::size_t>(path_.size() - 1, std::max<std::ptrdiff_t>(1, it - cumulative_.begin()));
  const double len = cumulative_[i] - cumulative_[i - 1];
  const double u = len > 0.0 ? (s - cumulative_[i - 1]) / len : 0.0;
  return path_[i - 1] + u * (path_[i] - path_[i - 1]);
}

VelocityCommand PathFollower::command(const Pose2& pose)
{
  if (done_)
    return {};
  avoiding_ = false;
  // Closest point, searched forward from the current segment only (a loop crosses itself).
  const Eigen::Vector2d p(pose.x, pose.y);
  double best_d = std::numeric_limits<double>::infinity();
  std::size_t best_seg = segment_;
  double best_s = progress_;
  const double window = progress_ + 2.0 * config_.lookahead + 1.0;
  for (std::size_t i = segment_; i + 1 < path_.size() && cumulative_[i] <= window; ++i)
  {
    const Eigen::Vector2d a = path_[i], ab = path_[i + 1] - path_[i];
    const double u = segmentFraction(a, path_[i + 1], p);
    const double d = (a + u * ab - p).norm();
    if (d < best_d)
    {
      best_d = d;
      best_seg = i;
      best_s = cumulative_[i] + u * ab.norm();
    }
  }
  segment_ = best_seg;
  progress_ = std::max(progress_, best_s);
  // Done near the last waypoint once on the last segment (a closed loop starts at its own end), or at its end.
  const bool last_segment = segment_ + 2 >= path_.size();
  if ((last_segment && (path_.back() - p).norm() < config_.goal_tolerance) || progress_ >= cumulative_.back() - 1e-6)
  {
    done_ = true;
    return {};
  }
  const Eigen::Vector2d target = pointAt(progress_ + config_.lookahead);
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  const double dx = target.x() - pose.x, dy = target.y() - pose.y;
  const double lx = c * dx + s * dy, ly = -s * dx + c * dy;
  const double l2 = std::max(1e-6, lx * lx + ly * ly);
  VelocityCommand cmd;
  cmd.linear = config_.speed;
  cmd.angular = std::max(-config_.max_angular, std::min(config_.max_angular, config_.speed * 2.0 * ly / l2));
  // A look-ahead point behind the robot (after a detour) is turned towards as sharply as allowed: pure pursuit's
  // arc would run straight away from one right behind.
  if (lx < 0.0)
    cmd.angular = ly >= 0.0 ? config_.max_angular : -config_.max_angular;
  return avoid(pose, cmd);
}

double PathFollower::distanceToPath(const Eigen::Vector2d& p, double enough) const
{
  // The segments from the current one to a few look-aheads on (a loop crosses itself; the rest is not the way).
  double best = std::numeric_limits<double>::infinity();
  const double window = progress_ + 2.0 * config_.lookahead + config_.horizon + 1.0;
  for (std::size_t i = segment_; i + 1 < path_.size() && cumulative_[i] <= window; ++i)
  {
    const Eigen::Vector2d a = path_[i], ab = path_[i + 1] - path_[i];
    best = std::min(best, (a + segmentFraction(a, path_[i + 1], p) * ab - p).norm());
    if (best <= enough)
      break;
  }
  return best;
}

void PathFollower::addObstacles(double stamp, const Pose2& pose, const std::vector<Eigen::Vector2d>& points)
{
  if (!config_.avoid_obstacles)
    return;
  const double range2 = config_.obstacle_range * config_.obstacle_range;
  for (auto it = obstacles_.begin(); it != obstacles_.end();)
  {
    const Eigen::Vector2d d = it->second.point - Eigen::Vector2d(pose.x, pose.y);
    if (it->second.stamp < stamp - config_.obstacle_memory || d.squaredNorm() > range2)
      it = obstacles_.erase(it);
    else
      ++it;
  }
  for (const Eigen::Vector2d& p : points)
  {
    if (!p.allFinite() || p.squaredNorm() > range2)
      continue;
    Eigen::Vector2d w;
    pose.transformPoint(p.x(), p.y(), &w.x(), &w.y());
    obstacles_[cellKey(w.x(), w.y(), kMemoryCell)] = Remembered{ w, stamp };
  }
}

std::vector<Eigen::Vector2d> PathFollower::obstacles() const
{
  std::vector<Eigen::Vector2d> out;
  out.reserve(obstacles_.size());
  for (const auto& o : obstacles_)
    out.push_back(o.second.point);
  return out;
}

bool PathFollower::planWay(const Pose2& pose)
{
  way_.clear();
  const double hard = config_.robot_radius + config_.min_clearance;
  const double soft = config_.robot_radius + config_.clearance;
  const double half = config_.obstacle_range + 0.5;
  const int n = 2 * static_cast<int>(std::ceil(half / kPlanCell)) + 1, c = n / 2;
  const Eigen::Vector2d origin(pose.x - c * kPlanCell, pose.y - c * kPlanCell);  // the centre of cell (0, 0)
  const auto centre = [&](int ix, int iy) -> Eigen::Vector2d { return origin + kPlanCell * Eigen::Vector2d(ix, iy); };
  const auto index = [&](int ix, int iy) { return static_cast<std::size_t>(iy) * n + ix; };
  // Each cell's distance to the nearest obstacle point (up to the clearance; beyond: infinity), and whether it is
  // beyond the departure bound.
  std::vector<double> gap(static_cast<std::size_t>(n) * n, std::numeric_limits<double>::infinity());
  std::vector<bool> outside(gap.size(), false);
  const int r_soft = static_cast<int>(std::ceil(soft / kPlanCell));
  for (const auto& o : obstacles_)
  {
    const Eigen::Vector2d q = o.second.point;
    const int qx = static_cast<int>(std::lround((q.x() - origin.x()) / kPlanCell));
    const int qy = static_cast<int>(std::lround((q.y() - origin.y()) / kPlanCell));
    for (int iy = std::max(0, qy - r_soft); iy <= std::min(n - 1, qy + r_soft); ++iy)
      for (int ix = std::max(0, qx - r_soft); ix <= std::min(n - 1, qx + r_soft); ++ix)
      {
        double& g = gap[index(ix, iy)];
        g = std::min(g, (centre(ix, iy) - q).norm());
      }
  }
  if (config_.max_departure > 0.0)
  {
    // Out beyond it already (odometry noise, an escape), the robot may keep its distance but go no farther out.
    const double bound = std::max(config_.max_departure, distanceToPath(Eigen::Vector2d(pose.x, pose.y)));
    for (int iy = 0; iy < n; ++iy)
      for (int ix = 0; ix < n; ++ix)
        outside[index(ix, iy)] = distanceToPath(centre(ix, iy), bound) > bound;
  }
  // Dijkstra from the robot's cell (allowed even when blocked: the robot is there).
  std::vector<double> cost(gap.size(), std::numeric_limits<double>::infinity());
  std::vector<int> from(gap.size(), -1);
  using Entry = std::pair<double, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  cost[index(c, c)] = 0.0;
  open.emplace(0.0, static_cast<int>(index(c, c)));
  while (!open.empty())
  {
    const Entry e = open.top();
    open.pop();
    if (e.first > cost[e.second])
      continue;
    const int x = e.second % n, y = e.second / n;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx)
      {
        const int ix = x + dx, iy = y + dy;
        if ((dx == 0 && dy == 0) || ix < 0 || iy < 0 || ix >= n || iy >= n)
          continue;
        const std::size_t k = index(ix, iy);
        // Closed: beyond the bound, or within the minimum clearance (unless it leads out of it: the robot may be
        // there already).
        if (outside[k] || (gap[k] < hard && !(gap[k] > gap[static_cast<std::size_t>(e.second)])))
          continue;
        const double step = (dx != 0 && dy != 0 ? M_SQRT2 : 1.0) * (gap[k] < soft ? kNearCost : 1.0);
        if (e.first + step < cost[k])
        {
          cost[k] = e.first + step;
          from[k] = e.second;
          open.emplace(cost[k], static_cast<int>(k));
        }
      }
  }
  // Where to: the farthest point of the path ahead (within the grid) that the search reached.
  int target = -1;
  for (double s = progress_ + 2.0 * half; s > progress_ + kCarrot; s -= 0.5 * kPlanCell)
  {
    const Eigen::Vector2d g = pointAt(s);
    const int ix = static_cast<int>(std::lround((g.x() - origin.x()) / kPlanCell));
    const int iy = static_cast<int>(std::lround((g.y() - origin.y()) / kPlanCell));
    if (ix >= 0 && iy >= 0 && ix < n && iy < n && std::isfinite(cost[index(ix, iy)]))
    {
      target = static_cast<int>(index(ix, iy));
      break;
    }
  }
  if (target < 0)
    return false;
  for (int k = target; k >= 0; k = from[k])
    way_.push_back(centre(k % n, k / n));
  std::reverse(way_.begin(), way_.end());
  return way_.size() >= 2;
}

Eigen::Vector2d PathFollower::carrot(const Pose2& pose) const
{
  // kCarrot along the way beyond its point nearest the robot.
  const Eigen::Vector2d p(pose.x, pose.y);
  std::size_t k = 0;
  for (std::size_t i = 1; i < way_.size(); ++i)
    if ((way_[i] - p).squaredNorm() < (way_[k] - p).squaredNorm())
      k = i;
  for (double along = 0.0; k + 1 < way_.size() && along < kCarrot; ++k)
    along += (way_[k + 1] - way_[k]).norm();
  return way_[k];
}

bool PathFollower::arcStays(const Pose2& pose, double kappa, double departure) const
{
  // Where the arc of curvature kappa takes the robot (its middle and its end, over the horizon): within the bound,
  // or within the robot's departure now when it is out already.
  if (config_.max_departure <= 0.0)
    return true;
  const double bound = std::max(config_.max_departure, departure);
  for (double f : { 0.5, 1.0 })
  {
    const double l = f * config_.horizon;
    const double bx = std::abs(kappa) > 1e-9 ? std::sin(kappa * l) / kappa : l;
    const double by = std::abs(kappa) > 1e-9 ? (1.0 - std::cos(kappa * l)) / kappa : 0.0;
    Eigen::Vector2d w;
    pose.transformPoint(bx, by, &w.x(), &w.y());
    if (distanceToPath(w) > bound)
      return false;
  }
  return true;
}

VelocityCommand PathFollower::avoid(const Pose2& pose, const VelocityCommand& pursuit)
{
  avoiding_ = false;
  if (!config_.avoid_obstacles || obstacles_.empty())
  {
    turn_ = 0;
    return pursuit;
  }
  const double soft = config_.robot_radius + config_.clearance, hard = config_.robot_radius + config_.min_clearance;
  // The points within reach of any candidate arc, in base_link, with their distance now.
  const double reach = config_.horizon + soft;
  const Pose2 inv = pose.inverse();
  std::vector<Eigen::Vector2d> near;
  std::vector<double> now;
  for (const auto& o : obstacles_)
  {
    Eigen::Vector2d b;
    inv.transformPoint(o.second.point.x(), o.second.point.y(), &b.x(), &b.y());
    const double d = b.norm();
    if (d <= reach)
    {
      near.push_back(b);
      now.push_back(d);
    }
  }
  const double departure = distanceToPath(Eigen::Vector2d(pose.x, pose.y));
  const auto stays = [&](double kappa) { return arcStays(pose, kappa, departure); };
  // Whether the arc of curvature kappa keeps radius from every point over arc length [0, length]; from a point nearer
  // already, it may come kApproachSlack nearer but never within hard; from one within hard, no nearer at all.
  const auto clear = [&](double kappa, double radius, double length) {
    for (std::size_t i = 0; i < near.size(); ++i)
    {
      const double need =
          now[i] < hard ? now[i] - 1e-9 : std::max(hard, std::min(radius, now[i] - kApproachSlack));
      if (arcDistance(near[i], kappa, length) < need)
        return false;
    }
    return true;
  };
  const double pursuit_kappa = pursuit.angular / pursuit.linear;
  if (clear(pursuit_kappa, soft, config_.horizon) && stays(pursuit_kappa))
  {
    turn_ = 0;
    way_.clear();
    plan_count_ = 0;
    return pursuit;
  }
  avoiding_ = true;
  const auto drive = [&](double kappa, double speed) {
    turn_ = 0;
    return arcCommand(kappa, speed, config_.max_angular);
  };
  // The way round (planWay), planned again every kPlanEvery commands and followed in between.
  if (plan_count_++ % kPlanEvery == 0 || way_.empty())
    planWay(pose);
  if (!way_.empty())
  {
    const Eigen::Vector2d c = carrot(pose);
    Eigen::Vector2d b;
    inv.transformPoint(c.x(), c.y(), &b.x(), &b.y());
    const double bearing = std::atan2(b.y(), b.x());
    if (std::abs(bearing) > kTurnInPlaceBearing)
    {
      // Turned to in place, one way until it is ahead (a way planned again may flip sides: no dithering).
      if (turn_ == 0)
        turn_ = bearing > 0.0 ? 1 : -1;
      VelocityCommand cmd;
      cmd.angular = turn_ * config_.max_angular;
      return cmd;  // a round footprint turning in place touches nothing new
    }
    const double l2 = std::max(1e-6, b.squaredNorm());
    const double kappa = std::max(-config_.max_curvature, std::min(config_.max_curvature, 2.0 * b.y() / l2));
    const double length = std::min(config_.horizon, std::max(kPlanCell, std::sqrt(l2)));
    if (clear(kappa, soft, length))
      return drive(kappa, config_.speed);
    if (clear(kappa, hard, length))
      return drive(kappa, kSlowFactor * config_.speed);
  }
  // Candidates, nearest to pure pursuit's arc first (ties: the straighter, then the left one).
  std::vector<double> candidates;
  for (int i = -kArcsPerSide; i <= kArcsPerSide; ++i)
    candidates.push_back(config_.max_curvature * i / kArcsPerSide);
  std::stable_sort(candidates.begin(), candidates.end(), [&](double a, double b) {
    const double da = std::abs(a - pursuit_kappa), db = std::abs(b - pursuit_kappa);
    if (da != db)
      return da < db;
    if (std::abs(a) != std::abs(b))
      return std::abs(a) < std::abs(b);
    return a > b;
  });
  for (double kappa : candidates)
    if (stays(kappa) && clear(kappa, soft, config_.horizon))
      return drive(kappa, config_.speed);
  for (double kappa : candidates)
    if (stays(kappa) && clear(kappa, hard, config_.horizon))
      return drive(kappa, kSlowFactor * config_.speed);
  if (turn_ == 0)
  {
    // Nothing is clear: turn in place to the side whose arc keeps the footprint clear the longest (ties: pure
    // pursuit's side), and on that way until an arc is clear (no dithering between sides).
    turn_ = pursuit_kappa >= 0.0 ? 1 : -1;
    double best = -1.0;
    for (double kappa : candidates)
    {
      if (std::abs(kappa) < 1e-9)
        continue;
      double free = 0.0;
      while (free < config_.horizon && clear(kappa, hard, free + kMemoryCell))
        free += kMemoryCell;
      if (free > best)
      {
        best = free;
        turn_ = kappa > 0.0 ? 1 : -1;
      }
    }
  }
  VelocityCommand cmd;
  cmd.angular = turn_ * config_.max_angular;
  return cmd;
}

std::vector<Eigen::Vector2d> straightDrive(double length)
{
  return { Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(length, 0.0) };
}

std::vector<Eigen::Vector2d> loopDrive()
{
  const double cx = 15.0, r = 8.5;
  std::vector<Eigen::Vector2d> path{ Eigen::Vector2d(0.0, 0.0) };
  // Start at the circle's near point (angle pi) and go counter-clockwise (south first) 1.5 turns.
  const int n = 240;
  for (int i = 0; i <= n; ++i)
  {
    const double a = M_PI + 3.0 * M_PI * i / n;
    path.emplace_back(cx + r * std::cos(a), r * std::sin(a));
  }
  path.emplace_back(30.0, 0.0);
  return path;
}

}  // namespace sim
}  // namespace rbpf_slam
