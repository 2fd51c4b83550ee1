#include "rbpf_slam/core/grid/scan_matcher.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

namespace rbpf_slam
{
namespace core
{

namespace
{
/**
 * @brief Squared distances along each axis [m^2] from the point (fx, fy) (in cells) to the centres of the cells
 * cx - k .. cx + k and cy - k .. cy + k of a window (cell size @p res): ax[d + k], ay[d + k].
 */
inline void axisDistances(int cx, int cy, double fx, double fy, double res, int k, double* ax, double* ay)
{
  for (int d = -k; d <= k; ++d)
  {
    const double ex = (cx + d + 0.5 - fx) * res, ey = (cy + d + 0.5 - fy) * res;
    ax[d + k] = ex * ex;
    ay[d + k] = ey * ey;
  }
}
}  // namespace

std::string ScanMatcherConfig::validate() const
{
  if (kernel < 0 || kernel > kMaxKernel)
    return "rbpf/kernel must be in [0, " + std::to_string(kMaxKernel) + "]";
  if (!(std::isfinite(match_sigma) && match_sigma > 0.0))
    return "rbpf/match_sigma must be > 0";
  if (!(std::isfinite(likelihood_sigma) && likelihood_sigma > 0.0))
    return "rbpf/likelihood_sigma must be > 0";
  if (!(std::isfinite(no_hit_distance) && no_hit_distance >= 0.0))
    return "rbpf/no_hit_distance must be >= 0";
  if (!(std::isfinite(linear_step) && linear_step >= 0.0))
    return "rbpf/linear_step must be >= 0";
  if (!(std::isfinite(angular_step) && angular_step >= 0.0))
    return "rbpf/angular_step must be >= 0";
  if (refinements < 0)
    return "rbpf/refinements must be >= 0";
  if (max_iterations < 0)
    return "rbpf/max_iterations must be >= 0";
  if (beam_step < 1)
    return "rbpf/beam_step must be >= 1";
  if (coarse_kernel < 0 || coarse_kernel > kMaxCoarseKernel)
    return "rbpf/coarse_kernel must be in [0, " + std::to_string(kMaxCoarseKernel) + "]";
  if (!(std::isfinite(coarse_sigma) && coarse_sigma > 0.0))
    return "rbpf/coarse_sigma must be > 0";
  if (coarse_beam_step < 1)
    return "rbpf/coarse_beam_step must be >= 1";
  if (climb_beam_step < 1)
    return "rbpf/climb_beam_step must be >= 1";
  if (coarse_refinements < 0)
    return "rbpf/coarse_refinements must be >= 0";
  if (!(std::isfinite(prior_floor_xy) && prior_floor_xy > 0.0 && std::isfinite(prior_floor_theta) &&
        prior_floor_theta > 0.0))
    return "rbpf/prior_floor_xy and rbpf/prior_floor_theta must be > 0";
  return "";
}

ScanMatcher::ScanMatcher(const ScanMatcherConfig& config) : config_(config)
{
  const int n = static_cast<int>(kExpTableMax * kExpTableScale) + 2;
  exp_table_.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i)
    exp_table_[static_cast<std::size_t>(i)] = std::exp(-static_cast<double>(i) / kExpTableScale);
}

ScanMatcher::Level ScanMatcher::fineLevel() const
{
  return Level{ false, config_.kernel, config_.match_sigma, config_.beam_step, config_.refinements,
                config_.linear_step, config_.angular_step };
}

ScanMatch ScanMatcher::evaluate(const OccupancyGrid& map, const Pose2& pose, const Pose2& sensor,
                                const std::vector<std::pair<double, double>>& end_points) const
{
  Rotated cache;
  return evaluateAt(fineLevel(), map, pose, sensor, end_points, &cache);
}

const std::vector<std::pair<double, double>>& ScanMatcher::rotate(
    const Level& level, double theta, const std::vector<std::pair<double, double>>& end_points, Rotated* cache) const
{
  ++cache->clock;
  Rotated::Slot* oldest = &cache->slots[0];
  for (auto& slot : cache->slots)
  {
    if (slot.theta == theta)
    {
      slot.used = cache->clock;
      return slot.points;
    }
    if (slot.used < oldest->used)
      oldest = &slot;
  }
  Rotated::Slot& slot = *oldest;
  slot.used = cache->clock;
  const double c = std::cos(theta), sn = std::sin(theta);
  slot.theta = theta;
  slot.points.clear();
  for (std::size_t i = 0; i < end_points.size(); i += static_cast<std::size_t>(level.beam_step))
  {
    const auto& e = end_points[i];
    slot.points.emplace_back(c * e.first - sn * e.second, sn * e.first + c * e.second);
  }
  return slot.points;
}

ScanMatch ScanMatcher::evaluateAt(const Level& level, const OccupancyGrid& map, const Pose2& pose,
                                  const Pose2& sensor, const std::vector<std::pair<double, double>>& end_points,
                                  Rotated* cache) const
{
  if (level.coarse)
    return evaluateCoarse(level, map, pose, sensor, end_points, cache);
  ScanMatch m;
  m.pose = pose;
  m.evaluations = 1;
  const Pose2 s = pose * sensor;
  const double res = map.resolution(), inv = 1.0 / res;
  const double inv_match = 1.0 / (2.0 * level.sigma * level.sigma);
  const double inv_like = 1.0 / (2.0 * config_.likelihood_sigma * config_.likelihood_sigma);
  const double no_hit = -config_.no_hit_distance * config_.no_hit_distance * inv_like;
  const int k = level.kernel;
  const int occ = map.rawOccupiedThreshold();
  const auto& rotated = rotate(level, s.theta, end_points, cache);
  for (std::size_t j = 0; j < rotated.size(); ++j)
  {
    const double x = s.x + rotated[j].first;
    const double y = s.y + rotated[j].second;
    const double fx = x * inv, fy = y * inv;
    const int cx = static_cast<int>(std::floor(fx)), cy = static_cast<int>(std::floor(fy));
    double best = std::numeric_limits<double>::infinity();
    // Most windows lie in one tile: look it up once (a missing tile has no occupied cell).
    const int tx = (cx - k) >> OccupancyGrid::kTileBits, ty = (cy - k) >> OccupancyGrid::kTileBits;
    const bool one_tile =
        tx == ((cx + k) >> OccupancyGrid::kTileBits) && ty == ((cy + k) >> OccupancyGrid::kTileBits);
    const OccupancyGrid::Tile* tile = one_tile ? map.tileAt(tx, ty) : nullptr;
    if (one_tile && !tile)
    {
      m.log_likelihood += no_hit;
      continue;
    }
    double ax[2 * kMaxKernel + 1], ay[2 * kMaxKernel + 1];
    axisDistances(cx, cy, fx, fy, res, k, ax, ay);
    if (tile)
    {
      // In one tile the window's cells are rows of the tile's row-major array (branch-free inner loop).
      const OccupancyGrid::Cell* centre = tile->cells.data() + OccupancyGrid::cellIndexInTile(cx, cy);
      for (int dy = -k; dy <= k; ++dy)
      {
        const OccupancyGrid::Cell* row = centre + dy * OccupancyGrid::kTileSize;
        const double yy = ay[dy + k];
        for (int dx = -k; dx <= k; ++dx)
        {
          const double d2 = ax[dx + k] + yy;
          best = (row[dx] > occ && d2 < best) ? d2 : best;
        }
      }
    }
    else
      for (int dy = -k; dy <= k; ++dy)
        for (int dx = -k; dx <= k; ++dx)
        {
          if (map.rawLogOdds(cx + dx, cy + dy) <= occ)
            continue;
          best = std::min(best, ax[dx + k] + ay[dy + k]);
        }
    if (std::isfinite(best))
    {
      m.score += matchKernel(best * inv_match);
      m.log_likelihood += -best * inv_like;
      ++m.matched;
    }
    else
      m.log_likelihood += no_hit;
  }
  return m;
}

ScanMatch ScanMatcher::evaluateCoarse(const Level& level, const OccupancyGrid& map, const Pose2& pose,
                                      const Pose2& sensor,
                                      const std::vector<std::pair<double, double>>& end_points,
                                      Rotated* cache) const
{
  // Score only (the weights come from the fine level): nearest coarse cell with an occupied cell.
  ScanMatch m;
  m.pose = pose;
  m.evaluations = 1;
  const Pose2 s = pose * sensor;
  const double res = map.resolution() * OccupancyGrid::kCoarseSize, inv = 1.0 / res;
  const double inv_match = 1.0 / (2.0 * level.sigma * level.sigma);
  const int k = level.kernel;
  for (const auto& e : rotate(level, s.theta, end_points, cache))
  {
    const double fx = (s.x + e.first) * inv, fy = (s.y + e.second) * inv;
    const int cx = static_cast<int>(std::floor(fx)), cy = static_cast<int>(std::floor(fy));
    double best = std::numeric_limits<double>::infinity();
    const int tx = (cx - k) >> OccupancyGrid::kCoarseTileBits, ty = (cy - k) >> OccupancyGrid::kCoarseTileBits;
    const bool one_tile = tx == ((cx + k) >> OccupancyGrid::kCoarseTileBits) &&
                          ty == ((cy + k) >> OccupancyGrid::kCoarseTileBits);
    const OccupancyGrid::Tile* tile = one_tile ? map.tileAt(tx, ty) : nullptr;
    if (one_tile && !tile)
      continue;
    double ax[2 * kMaxCoarseKernel + 1], ay[2 * kMaxCoarseKernel + 1];
    axisDistances(cx, cy, fx, fy, res, k, ax, ay);
    if (tile)
    {
      const std::uint8_t* centre = tile->coarse.data() + OccupancyGrid::coarseIndex(cx, cy);
      for (int dy = -k; dy <= k; ++dy)
      {
        const std::uint8_t* row = centre + dy * OccupancyGrid::kCoarsePerTile;
        const double yy = ay[dy + k];
        for (int dx = -k; dx <= k; ++dx)
        {
          const double d2 = ax[dx + k] + yy;
          best = (row[dx] != 0 && d2 < best) ? d2 : best;
        }
      }
    }
    else
      for (int dy = -k; dy <= k; ++dy)
        for (int dx = -k; dx <= k; ++dx)
          if (map.coarseCount(cx + dx, cy + dy) != 0)
            best = std::min(best, ax[dx + k] + ay[dy + k]);
    if (std::isfinite(best))
    {
      m.score += matchKernel(best * inv_match);
      ++m.matched;
    }
  }
  return m;
}

ScanMatch ScanMatcher::climb(const Level& level, const OccupancyGrid& map, const Pose2& start, const Pose2& sensor,
                             const std::vector<std::pair<double, double>>& end_points, int* evaluations) const
{
  Rotated cache;
  ScanMatch best = evaluateAt(level, map, start, sensor, end_points, &cache);
  ++*evaluations;
  double lin = level.linear_step, ang = level.angular_step;
  int refinements = 0, iterations = 0;
  int back = -1;  // the move that undoes the last one taken: it scores the pose just left, which scored lower
  while (refinements <= level.refinements && iterations < config_.max_iterations)
  {
    ++iterations;
    const Pose2& p = best.pose;
    const Pose2 moves[6] = { Pose2(p.x + lin, p.y, p.theta), Pose2(p.x - lin, p.y, p.theta),
                             Pose2(p.x, p.y + lin, p.theta), Pose2(p.x, p.y - lin, p.theta),
                             Pose2(p.x, p.y, wrapAngle(p.theta + ang)),
                             Pose2(p.x, p.y, wrapAngle(p.theta - ang)) };
    ScanMatch step = best;
    int taken = -1;
    for (int j = level.turn_only ? 4 : 0; j < 6; ++j)
    {
      if (j == back)
        continue;
      const ScanMatch m = evaluateAt(level, map, moves[j], sensor, end_points, &cache);
      ++*evaluations;
      if (m.score > step.score)
      {
        step = m;
        taken = j;
      }
    }
    if (step.score > best.score)
    {
      best = step;
      back = taken ^ 1;  // moves come in pairs (+, -)
    }
    else
    {
      lin *= 0.5;
      ang *= 0.5;
      ++refinements;
      back = -1;
    }
  }
  return best;
}

Eigen::Matrix3d ScanMatcher::information(const OccupancyGrid& map, const Pose2& pose, const Pose2& sensor,
                                         const std::vector<std::pair<double, double>>& end_points,
                                         int* evaluations) const
{
  Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
  if (end_points.empty())
    return info;
  // Steps: one cell in x and y; the turn that moves an end point at the median range by one cell.
  std::vector<double> ranges;
  ranges.reserve(end_points.size());
  for (const auto& e : end_points)
    ranges.push_back(std::hypot(e.first, e.second));
  std::nth_element(ranges.begin(), ranges.begin() + static_cast<long>(ranges.size() / 2), ranges.end());
  const double res = map.resolution();
  const double h[3] = { res, res, res / std::max(ranges[ranges.size() / 2], 1.0) };
  const Level level = fineLevel();
  Rotated cache;
  const auto score = [&](double dx, double dy, double dt) {
    ++*evaluations;
    return evaluateAt(level, map, Pose2(pose.x + dx, pose.y + dy, wrapAngle(pose.theta + dt)), sensor, end_points,
                      &cache)
        .score;
  };
  const auto at = [&](int i, double s) {
    double d[3] = { 0.0, 0.0, 0.0 };
    d[i] = s * h[i];
    return score(d[0], d[1], d[2]);
  };
  const double centre = score(0.0, 0.0, 0.0);
  --*evaluations;  // the match's own pose was scored by the climb
  for (int i = 0; i < 3; ++i)
    info(i, i) = -(at(i, 1.0) - 2.0 * centre + at(i, -1.0)) / (h[i] * h[i]);
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j)
    {
      const auto corner = [&](double si, double sj) {
        double d[3] = { 0.0, 0.0, 0.0 };
        d[i] = si * h[i];
        d[j] = sj * h[j];
        return score(d[0], d[1], d[2]);
      };
      info(i, j) = info(j, i) =
          -(corner(1, 1) - corner(1, -1) - corner(-1, 1) + corner(-1, -1)) / (4.0 * h[i] * h[j]);
    }
  // The score's curvature at a hit is 1 / match_sigma^2 per end point; the log-likelihood's 1 / likelihood_sigma^2.
  const double to_likelihood =
      (config_.match_sigma * config_.match_sigma) / (config_.likelihood_sigma * config_.likelihood_sigma);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(to_likelihood * info);
  const Eigen::Vector3d values = eig.eigenvalues().cwiseMax(0.0);
  return eig.eigenvectors() * values.asDiagonal() * eig.eigenvectors().transpose();
}

ScanMatch ScanMatcher::match(const OccupancyGrid& map, const Pose2& start, const Pose2& sensor,
                             const std::vector<std::pair<double, double>>& end_points, int widen, bool turn_only) const
{
  int evaluations = 0;
  Pose2 from = start;
  Level fine = fineLevel();
  fine.turn_only = turn_only;
  widen = std::max(0, std::min(widen, kMaxWiden));
  // A wider start: the first level's steps doubled widen times, and as many more halvings, so the last step
  // (and the fine level's start) stays the same.
  const double wide = std::ldexp(1.0, widen);
  if (config_.coarse_kernel > 0)
  {
    const Level coarse{ true,
                        config_.coarse_kernel,
                        config_.coarse_sigma,
                        config_.coarse_beam_step,
                        config_.coarse_refinements + widen,
                        config_.linear_step * wide,
                        config_.angular_step * wide,
                        turn_only };
    from = climb(coarse, map, start, sensor, end_points, &evaluations).pose;
    // The fine climb starts with the coarse one's last step size.
    const double last = std::ldexp(1.0, -config_.coarse_refinements);
    fine.linear_step *= last;
    fine.angular_step *= last;
  }
  else
  {
    fine.linear_step *= wide;
    fine.angular_step *= wide;
    fine.refinements += widen;
  }
  ScanMatch best;
  if (config_.climb_beam_step > 1)
  {
    // Climb on every climb_beam_step-th end point; score the end pose on all of them (the weight's figures).
    Level sparse = fine;
    sparse.beam_step *= config_.climb_beam_step;
    const Pose2 end = climb(sparse, map, from, sensor, end_points, &evaluations).pose;
    Rotated cache;
    best = evaluateAt(fine, map, end, sensor, end_points, &cache);
    ++evaluations;
  }
  else
    best = climb(fine, map, from, sensor, end_points, &evaluations);
  best.evaluations = evaluations;
  return best;
}

}  // namespace core
}  // namespace rbpf_slam
