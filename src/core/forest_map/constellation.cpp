#include "rbpf_slam/core/forest_map/constellation.h"

#include <algorithm>
#include <unordered_map>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <limits>
#include <utility>

#include "rbpf_slam/core/filter/cell_key.h"

namespace rbpf_slam
{
namespace core
{
namespace
{
long long key(long cx, long cy)
{
  return packCell(cx, cy);
}

double wrap(double a)
{
  return std::atan2(std::sin(a), std::cos(a));
}

/** @brief The rigid transform that maps the points @p from onto @p to in the least-squares sense (2D Kabsch). */
Pose2 fitRigid(const std::vector<Eigen::Vector2d>& from, const std::vector<Eigen::Vector2d>& to)
{
  Eigen::Vector2d mf = Eigen::Vector2d::Zero(), mt = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < from.size(); ++i)
  {
    mf += from[i];
    mt += to[i];
  }
  mf /= static_cast<double>(from.size());
  mt /= static_cast<double>(to.size());
  double sxx = 0.0, sxy = 0.0;
  for (std::size_t i = 0; i < from.size(); ++i)
  {
    const Eigen::Vector2d a = from[i] - mf, b = to[i] - mt;
    sxx += a.x() * b.x() + a.y() * b.y();
    sxy += a.x() * b.y() - a.y() * b.x();
  }
  const double th = std::atan2(sxy, sxx);
  const double c = std::cos(th), s = std::sin(th);
  const Eigen::Vector2d t = mt - Eigen::Vector2d(c * mf.x() - s * mf.y(), s * mf.x() + c * mf.y());
  return Pose2(t.x(), t.y(), th);
}

Eigen::Vector2d apply(const Pose2& t, const Eigen::Vector2d& p)
{
  double x = 0.0, y = 0.0;
  t.transformPoint(p.x(), p.y(), &x, &y);
  return Eigen::Vector2d(x, y);
}
}  // namespace

TrunkPoint trunkPoint(const Landmark& tree)
{
  TrunkPoint t;
  t.center = tree.mean;
  t.radius = tree.radius;
  t.radius_sigma = std::sqrt(std::max(0.0, tree.radius_variance));
  return t;
}

namespace
{
/** @brief The area of the trees' bounding box [m^2] (at least 1). */
double boundingArea(const std::vector<TrunkPoint>& trees)
{
  if (trees.empty())
    return 1.0;
  Eigen::Vector2d lo = trees.front().center, hi = lo;
  for (const TrunkPoint& t : trees)
  {
    lo = lo.cwiseMin(t.center);
    hi = hi.cwiseMax(t.center);
  }
  return std::max(1.0, (hi.x() - lo.x()) * (hi.y() - lo.y()));
}
}  // namespace

ConstellationMatcher::ConstellationMatcher(const std::vector<Landmark>& map, const ConstellationConfig& config)
  : config_(config), cell_(std::max(0.1, config.inlier_gate))
{
  for (const Landmark& l : map)
  {
    if (l.provisional || !std::isfinite(l.mean.x()) || !std::isfinite(l.mean.y()))
      continue;
    trees_.push_back(trunkPoint(l));
  }
  // The pairs through a grid of the pairs' reach: linear in the trees (times their neighbours), not quadratic.
  const double reach = config_.max_pair_length + config_.pair_tolerance;
  const double pair_cell = std::max(1.0, reach);
  std::unordered_map<long long, std::vector<int>> coarse;
  const auto coarseOf = [&](const Eigen::Vector2d& p, long* cx, long* cy) {
    *cx = static_cast<long>(std::floor(p.x() / pair_cell));
    *cy = static_cast<long>(std::floor(p.y() / pair_cell));
  };
  for (std::size_t a = 0; a < trees_.size(); ++a)
  {
    long cx = 0, cy = 0;
    coarseOf(trees_[a].center, &cx, &cy);
    coarse[key(cx, cy)].push_back(static_cast<int>(a));
  }
  // The trees b > a of a pair with tree a (within the pair lengths), through the coarse grid: visit(b, length).
  const double shortest = config_.min_pair_length - config_.pair_tolerance;
  const auto forEachPartner = [&](std::size_t a, const auto& visit) {
    long cx = 0, cy = 0;
    coarseOf(trees_[a].center, &cx, &cy);
    for (long dx = -1; dx <= 1; ++dx)
      for (long dy = -1; dy <= 1; ++dy)
      {
        const auto it = coarse.find(key(cx + dx, cy + dy));
        if (it == coarse.end())
          continue;
        for (const int b : it->second)
        {
          if (b <= static_cast<int>(a))
            continue;
          const double d = (trees_[a].center - trees_[static_cast<std::size_t>(b)].center).norm();
          if (d >= shortest && d <= reach)
            visit(b, d);
        }
      }
  };
  // Counted first, nothing stored: a map with too many pairs is refused in about a second, not minutes.
  long count = 0;
  for (std::size_t a = 0; a < trees_.size() && count <= config_.max_pairs; ++a)
    forEachPartner(a, [&](int, double) { ++count; });
  if (count > config_.max_pairs)
  {
    char text[400];
    std::snprintf(text, sizeof(text),
                  "the map's %zu trees make more than %ld pairs within %.0f m of each other (the index of the search "
                  "for the pose in the map would take more than %.0f MB): on average %.1f trees per square metre, "
                  "denser than a forest (5000 stems a hectare are 0.5); refused",
                  trees_.size(), config_.max_pairs, reach, config_.max_pairs * sizeof(Pair) / 1e6,
                  trees_.size() / std::max(1e-9, boundingArea(trees_)));
    throw std::invalid_argument(text);
  }
  std::vector<std::pair<int, double>> near;
  for (std::size_t a = 0; a < trees_.size(); ++a)
  {
    long cx = 0, cy = 0;
    cellOf(trees_[a].center, &cx, &cy);
    grid_.emplace_back(key(cx, cy), static_cast<int>(a));
    near.clear();
    forEachPartner(a, [&](int b, double d) { near.emplace_back(b, d); });
    std::sort(near.begin(), near.end());  // the pairs in the order of the trees, whatever the cells
    for (const auto& bd : near)
      pairs_.push_back({ bd.second, static_cast<int>(a), bd.first });
  }
  std::sort(grid_.begin(), grid_.end());
  std::sort(pairs_.begin(), pairs_.end(), [](const Pair& x, const Pair& y) { return x.length < y.length; });
}

void ConstellationMatcher::cellOf(const Eigen::Vector2d& p, long* cx, long* cy) const
{
  *cx = static_cast<long>(std::floor(p.x() / cell_));
  *cy = static_cast<long>(std::floor(p.y() / cell_));
}

bool ConstellationMatcher::radiiAgree(const TrunkPoint& s, int tree) const
{
  const TrunkPoint& t = trees_[static_cast<std::size_t>(tree)];
  const double sigma = std::hypot(s.radius_sigma, t.radius_sigma);
  return std::abs(s.radius - t.radius) <= config_.radius_sigmas * sigma + config_.radius_floor;
}

double ConstellationMatcher::logLikelihood(const std::vector<TrunkPoint>& seen, const Pose2& t) const
{
  std::vector<std::pair<int, int>> matches;
  const int n = score(seen, seen.size(), t, &matches);
  const double gate_sigmas = 3.0;  // the gate lies at 3 sigma
  const double sigma = config_.inlier_gate / gate_sigmas;
  double sum = 0.0;
  for (const auto& m : matches)
    sum += (trees_[static_cast<std::size_t>(m.second)].center - apply(t, seen[static_cast<std::size_t>(m.first)].center))
               .squaredNorm();
  const double unexplained = static_cast<double>(seen.size()) - n;
  return -0.5 * (sum / (sigma * sigma) + unexplained * gate_sigmas * gate_sigmas);
}

int ConstellationMatcher::score(const std::vector<TrunkPoint>& all, std::size_t count, const Pose2& t,
                                std::vector<std::pair<int, int>>* matches) const
{
  const std::size_t n_seen = std::min(count, all.size());
  // Each seen trunk takes the nearest free map tree within the gate whose radius agrees (greedy, in seen order:
  // the seen trunks are apart by more than a gate, so conflicts are rare and resolved by distance).
  std::vector<std::pair<double, std::pair<int, int>>> cand;
  const double gate2 = config_.inlier_gate * config_.inlier_gate;
  for (std::size_t i = 0; i < n_seen; ++i)
  {
    const Eigen::Vector2d p = apply(t, all[i].center);
    long cx = 0, cy = 0;
    cellOf(p, &cx, &cy);
    double best = gate2;
    int best_tree = -1;
    for (long dx = -1; dx <= 1; ++dx)
      for (long dy = -1; dy <= 1; ++dy)
      {
        const long long k = key(cx + dx, cy + dy);
        auto it = std::lower_bound(grid_.begin(), grid_.end(), std::make_pair(k, -1));
        for (; it != grid_.end() && it->first == k; ++it)
        {
          const double d2 = (trees_[static_cast<std::size_t>(it->second)].center - p).squaredNorm();
          if (d2 <= best && radiiAgree(all[i], it->second))
          {
            best = d2;
            best_tree = it->second;
          }
        }
      }
    if (best_tree >= 0)
      cand.push_back({ best, { static_cast<int>(i), best_tree } });
  }
  std::sort(cand.begin(), cand.end());
  std::vector<char> taken(trees_.size(), 0);
  int n = 0;
  if (matches)
    matches->clear();
  for (const auto& c : cand)
  {
    if (taken[static_cast<std::size_t>(c.second.second)])
      continue;
    taken[static_cast<std::size_t>(c.second.second)] = 1;
    ++n;
    if (matches)
      matches->push_back(c.second);
  }
  return n;
}

ConstellationResult ConstellationMatcher::match(const std::vector<TrunkPoint>& seen) const
{
  ConstellationResult result;
  if (trees_.size() < 2 || seen.size() < 2)
  {
    result.reason = "too few trunks (" + std::to_string(seen.size()) + " seen, " + std::to_string(trees_.size()) +
                    " in the map)";
    return result;
  }
  struct Scored
  {
    Pose2 t;
    int inliers;
  };
  std::vector<Scored> scored;
  // The pairs and the first scores come from the first max_pair_trunks seen trunks (the nearest).
  const std::size_t head = std::min(seen.size(), static_cast<std::size_t>(std::max(2, config_.max_pair_trunks)));
  for (std::size_t i = 0; i < head; ++i)
    for (std::size_t j = i + 1; j < head; ++j)
    {
      const Eigen::Vector2d dij = seen[j].center - seen[i].center;
      const double d = dij.norm();
      if (d < config_.min_pair_length || d > config_.max_pair_length)
        continue;
      const auto lo = std::lower_bound(pairs_.begin(), pairs_.end(), d - config_.pair_tolerance,
                                       [](const Pair& p, double v) { return p.length < v; });
      for (auto it = lo; it != pairs_.end() && it->length <= d + config_.pair_tolerance; ++it)
      {
        if (result.candidates >= config_.max_candidates)
        {
          result.bounded = true;  // the work bound: the search ends here with what it scored
          break;
        }
        for (int flip = 0; flip < 2; ++flip)
        {
          const int a = flip ? it->b : it->a, b = flip ? it->a : it->b;
          if (!radiiAgree(seen[i], a) || !radiiAgree(seen[j], b))
            continue;
          const Eigen::Vector2d& ma = trees_[static_cast<std::size_t>(a)].center;
          const Eigen::Vector2d dab = trees_[static_cast<std::size_t>(b)].center - ma;
          const double th = wrap(std::atan2(dab.y(), dab.x()) - std::atan2(dij.y(), dij.x()));
          const double c = std::cos(th), s = std::sin(th);
          // The pair's midpoints coincide: the least-squares transform of the two correspondences.
          const Eigen::Vector2d mid_seen = 0.5 * (seen[i].center + seen[j].center);
          const Eigen::Vector2d mid_map = ma + 0.5 * dab;
          const Eigen::Vector2d tr =
              mid_map - Eigen::Vector2d(c * mid_seen.x() - s * mid_seen.y(), s * mid_seen.x() + c * mid_seen.y());
          const Pose2 t(tr.x(), tr.y(), th);
          ++result.candidates;
          const int n = score(seen, head, t, nullptr);
          if (n >= 3)
            scored.push_back({ t, n });
        }
      }
    }
  std::stable_sort(scored.begin(), scored.end(), [](const Scored& x, const Scored& y) { return x.inliers > y.inliers; });
  // Refit the best distinct transforms on their inliers.
  std::vector<std::pair<int, int>> m;
  for (const Scored& s : scored)
  {
    if (static_cast<int>(result.hypotheses.size()) >= config_.max_hypotheses)
      break;
    const auto near = [&](const PoseHypothesis& h) {
      return std::hypot(h.transform.x - s.t.x, h.transform.y - s.t.y) < config_.distinct_distance &&
             std::abs(wrap(h.transform.theta - s.t.theta)) < config_.distinct_angle;
    };
    if (std::any_of(result.hypotheses.begin(), result.hypotheses.end(), near))
      continue;
    Pose2 t = s.t;
    int n = score(seen, seen.size(), t, &m);
    for (int iter = 0; iter < 3 && n >= 2; ++iter)
    {
      std::vector<Eigen::Vector2d> from, to;
      for (const auto& k : m)
      {
        from.push_back(seen[static_cast<std::size_t>(k.first)].center);
        to.push_back(trees_[static_cast<std::size_t>(k.second)].center);
      }
      t = fitRigid(from, to);
      n = score(seen, seen.size(), t, &m);
    }
    PoseHypothesis h;
    h.transform = t;
    h.inliers = n;
    double sum = 0.0;
    for (const auto& k : m)
      sum += (apply(t, seen[static_cast<std::size_t>(k.first)].center) -
              trees_[static_cast<std::size_t>(k.second)].center).squaredNorm();
    h.rms = m.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(m.size()));
    if (std::any_of(result.hypotheses.begin(), result.hypotheses.end(), near))
      continue;
    result.hypotheses.push_back(h);
  }
  std::stable_sort(result.hypotheses.begin(), result.hypotheses.end(), [](const PoseHypothesis& x, const PoseHypothesis& y) {
    return x.inliers != y.inliers ? x.inliers > y.inliers : x.rms < y.rms;
  });
  if (result.hypotheses.empty())
  {
    result.reason = "no transform explains 3 or more of the " + std::to_string(seen.size()) + " trunks seen";
    return result;
  }
  const PoseHypothesis& best = result.hypotheses.front();
  const int need = std::max(config_.min_inliers,
                            static_cast<int>(std::ceil(config_.min_inlier_share * static_cast<double>(seen.size()))));
  if (best.inliers < need)
  {
    result.reason = "the best transform explains " + std::to_string(best.inliers) + " of " +
                    std::to_string(seen.size()) + " trunks seen (" + std::to_string(need) + " needed)";
    return result;
  }
  if (result.hypotheses.size() > 1 &&
      result.hypotheses[1].inliers > config_.ambiguity_share * static_cast<double>(best.inliers))
  {
    result.reason = "ambiguous: a second transform explains " + std::to_string(result.hypotheses[1].inliers) +
                    " trunks where the best explains " + std::to_string(best.inliers);
    return result;
  }
  result.accepted = true;
  return result;
}

}  // namespace core
}  // namespace rbpf_slam
