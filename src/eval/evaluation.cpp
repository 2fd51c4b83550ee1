#include "rbpf_slam/eval/evaluation.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace rbpf_slam
{
namespace eval
{
using core::Pose2;

std::vector<int> optimalAssignment(const std::vector<std::vector<double>>& cost, double forbidden)
{
  // Kuhn-Munkres on a square matrix padded with "forbidden" entries (rows: left items, columns: right).
  const int n_rows = static_cast<int>(cost.size());
  const int n_cols = n_rows ? static_cast<int>(cost[0].size()) : 0;
  const int n = std::max(n_rows, n_cols);
  std::vector<int> result(static_cast<std::size_t>(n_rows), -1);
  if (n == 0)
    return result;
  const auto at = [&](int i, int j) {
    return (i < n_rows && j < n_cols) ? cost[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] : forbidden;
  };
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> u(static_cast<std::size_t>(n + 1), 0.0), v(static_cast<std::size_t>(n + 1), 0.0);
  std::vector<int> p(static_cast<std::size_t>(n + 1), 0), way(static_cast<std::size_t>(n + 1), 0);
  for (int i = 1; i <= n; ++i)
  {
    p[0] = i;
    int j0 = 0;
    std::vector<double> minv(static_cast<std::size_t>(n + 1), inf);
    std::vector<bool> used(static_cast<std::size_t>(n + 1), false);
    do
    {
      used[static_cast<std::size_t>(j0)] = true;
      const int i0 = p[static_cast<std::size_t>(j0)];
      double delta = inf;
      int j1 = 0;
      for (int j = 1; j <= n; ++j)
      {
        if (used[static_cast<std::size_t>(j)])
          continue;
        const double cur = at(i0 - 1, j - 1) - u[static_cast<std::size_t>(i0)] - v[static_cast<std::size_t>(j)];
        if (cur < minv[static_cast<std::size_t>(j)])
        {
          minv[static_cast<std::size_t>(j)] = cur;
          way[static_cast<std::size_t>(j)] = j0;
        }
        if (minv[static_cast<std::size_t>(j)] < delta)
        {
          delta = minv[static_cast<std::size_t>(j)];
          j1 = j;
        }
      }
      for (int j = 0; j <= n; ++j)
      {
        if (used[static_cast<std::size_t>(j)])
        {
          u[static_cast<std::size_t>(p[static_cast<std::size_t>(j)])] += delta;
          v[static_cast<std::size_t>(j)] -= delta;
        }
        else
        {
          minv[static_cast<std::size_t>(j)] -= delta;
        }
      }
      j0 = j1;
    } while (p[static_cast<std::size_t>(j0)] != 0);
    do
    {
      const int j1 = way[static_cast<std::size_t>(j0)];
      p[static_cast<std::size_t>(j0)] = p[static_cast<std::size_t>(j1)];
      j0 = j1;
    } while (j0);
  }
  for (int j = 1; j <= n; ++j)
  {
    const int i = p[static_cast<std::size_t>(j)] - 1;
    if (i >= 0 && i < n_rows && j - 1 < n_cols && at(i, j - 1) < forbidden)
      result[static_cast<std::size_t>(i)] = j - 1;
  }
  return result;
}

MapScore scoreMap(const std::vector<MapPoint>& trees, const std::vector<bool>& tree_seen,
                  const std::vector<MapPoint>& features, double gate, double duplicate_radius)
{
  MapScore s;
  const double forbidden = 1e6;
  std::vector<std::vector<double>> cost(trees.size(), std::vector<double>(features.size(), forbidden));
  for (std::size_t i = 0; i < trees.size(); ++i)
    for (std::size_t j = 0; j < features.size(); ++j)
    {
      const double d = (trees[i].position - features[j].position).norm();
      if (d < gate)
        cost[i][j] = d;
    }
  const std::vector<int> a = optimalAssignment(cost, forbidden);
  std::vector<int> feature_tree(features.size(), -1);
  double sum_d = 0.0, sum_r2 = 0.0;
  for (std::size_t i = 0; i < trees.size(); ++i)
  {
    s.trees_seen += tree_seen[i] ? 1 : 0;
    if (a[i] < 0)
      continue;
    feature_tree[static_cast<std::size_t>(a[i])] = static_cast<int>(i);
    ++s.matched;
    sum_d += (trees[i].position - features[static_cast<std::size_t>(a[i])].position).norm();
    const double dr = features[static_cast<std::size_t>(a[i])].radius - trees[i].radius;
    sum_r2 += dr * dr;
  }
  int matched_seen = 0;
  for (std::size_t i = 0; i < trees.size(); ++i)
    matched_seen += (a[i] >= 0 && tree_seen[i]) ? 1 : 0;
  s.recall = s.trees_seen ? static_cast<double>(matched_seen) / s.trees_seen : 1.0;
  s.mean_distance = s.matched ? sum_d / s.matched : 0.0;
  s.radius_rms = s.matched ? std::sqrt(sum_r2 / s.matched) : 0.0;
  for (std::size_t j = 0; j < features.size(); ++j)
  {
    if (feature_tree[j] >= 0)
      continue;
    // The nearest tree: a duplicate if it is a matched tree within duplicate_radius.
    int nearest = -1;
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < trees.size(); ++i)
    {
      const double d = (trees[i].position - features[j].position).norm();
      if (d < best)
      {
        best = d;
        nearest = static_cast<int>(i);
      }
    }
    if (nearest >= 0 && best < duplicate_radius && a[static_cast<std::size_t>(nearest)] >= 0)
      ++s.duplicates;
    else
      ++s.spurious;
  }
  return s;
}

double absoluteTrajectoryRmse(const std::vector<Pose2>& estimate, const std::vector<Pose2>& truth)
{
  const std::size_t n = std::min(estimate.size(), truth.size());
  if (n == 0)
    return 0.0;
  double sum = 0.0;
  for (std::size_t i = 0; i < n; ++i)
  {
    const double dx = estimate[i].x - truth[i].x, dy = estimate[i].y - truth[i].y;
    sum += dx * dx + dy * dy;
  }
  return std::sqrt(sum / static_cast<double>(n));
}

}  // namespace eval
}  // namespace rbpf_slam
