#include "rbpf_slam/sim/path_follower.h"

#include <algorithm>
#include <cmath>

namespace rbpf_slam
{
namespace core
{
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
  // Closest point, searched forward from the current segment only (a loop crosses itself).
  const Eigen::Vector2d p(pose.x, pose.y);
  double best_d = std::numeric_limits<double>::infinity();
  std::size_t best_seg = segment_;
  double best_s = progress_;
  const double window = progress_ + 2.0 * config_.lookahead + 1.0;
  for (std::size_t i = segment_; i + 1 < path_.size() && cumulative_[i] <= window; ++i)
  {
    const Eigen::Vector2d a = path_[i], ab = path_[i + 1] - path_[i];
    const double len2 = ab.squaredNorm();
    const double u = len2 > 0.0 ? std::max(0.0, std::min(1.0, (p - a).dot(ab) / len2)) : 0.0;
    const double d = (a + u * ab - p).norm();
    if (d < best_d)
    {
      best_d = d;
      best_seg = i;
      best_s = cumulative_[i] + u * std::sqrt(len2);
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

}  // namespace core
}  // namespace rbpf_slam
