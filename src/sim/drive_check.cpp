#include "rbpf_slam/sim/drive_check.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>

namespace rbpf_slam
{
namespace sim
{
namespace
{
constexpr double kSampleStep = 0.05;  // [m] along the drive, where boxes are checked
constexpr double kCell = 0.1;         // [m] the grid of the corridor check

/** The point of segment [a, b] nearest @p p. */
Eigen::Vector2d nearestOnSegment(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& p)
{
  return a + segmentFraction(a, b, p) * (b - a);
}

template <typename... Args>
std::string format(const char* fmt, Args... args)
{
  char buf[400];
  std::snprintf(buf, sizeof(buf), fmt, args...);
  return buf;
}

/** A shape the planner steers round, as the lidar sees it in the planner's height band: the points within @p radius
 * of segment [a, b] (a circle when a == b). */
struct Blocker
{
  Eigen::Vector2d a, b;
  double radius;
  bool clutter;  ///< not a trunk (the robot may start near it, as the planner lets it leave it)
};

/** Segment [a, b] (3D) clipped to heights [lo, hi]; false when no part of it lies there. */
bool clipToHeights(Eigen::Vector3d a, Eigen::Vector3d b, double lo, double hi, Eigen::Vector2d* ca, Eigen::Vector2d* cb)
{
  if (a.z() > b.z())
    std::swap(a, b);
  if (b.z() < lo || a.z() > hi)
    return false;
  const double dz = b.z() - a.z();
  const auto at = [&](double z) -> Eigen::Vector3d { return dz > 1e-12 ? a + (b - a) * ((z - a.z()) / dz) : a; };
  *ca = at(std::max(lo, a.z())).head<2>();
  *cb = at(std::min(hi, b.z())).head<2>();
  return true;
}

/**
 * What the planner steers round: the trunks (at the ground) and the clutter whose shape rises into its obstacle band
 * [@p lo, @p hi] above the ground: the saplings' stems (their axes through the band, radius at its foot), bushes and
 * crowns (foliage spheres cut by the band), rocks, fallen branches thick enough to reach it, the branches on the stems.
 */
std::vector<Blocker> blockersInBand(const ForestWorld& world, double lo, double hi)
{
  std::vector<Blocker> out;
  for (const TrunkSpec& t : world.trunks)
    out.push_back({ Eigen::Vector2d(t.x, t.y), Eigen::Vector2d(t.x, t.y), t.radius, false });
  for (const TrunkSpec& t : world.saplings)
  {
    double r_lo = 0.0;
    const Eigen::Vector3d a = trunkAxisAt(t, 0.0, std::max(0.0, lo), &r_lo);
    const Eigen::Vector3d b = trunkAxisAt(t, 0.0, std::max(0.0, std::min(hi, t.height)), nullptr);
    if (t.height >= lo)
      out.push_back({ a.head<2>(), b.head<2>(), r_lo, true });
  }
  const auto spheres = [&](const Eigen::Vector3d& c, double radius) {
    const double dz = c.z() < lo ? lo - c.z() : (c.z() > hi ? c.z() - hi : 0.0);
    if (dz < radius)
      out.push_back({ c.head<2>(), c.head<2>(), std::sqrt(radius * radius - dz * dz), true });
  };
  for (const FoliageSpec& f : world.foliage)
    spheres(f.center, f.radius);
  for (const RockSpec& r : world.rocks)
    spheres(r.center, r.radius);
  for (const BranchSpec& b : world.branches)
  {
    const double dz = std::max(0.0, lo - b.radius);  // the axis lies b.radius above the ground
    if (dz < b.radius)
      out.push_back({ b.a, b.b, std::sqrt(b.radius * b.radius - dz * dz), true });
  }
  for (const StubSpec& s : world.stubs)
  {
    Eigen::Vector2d a, b;
    if (clipToHeights(s.a, s.b, lo - s.radius, hi + s.radius, &a, &b))
      out.push_back({ a, b, s.radius, true });
  }
  return out;
}

/** The drive's points must keep @p side + @p margin from every trunk surface and box (no planner to go round). */
bool checkClearance(const ForestWorld& world, const std::vector<Eigen::Vector2d>& path, double side, double margin,
                    std::string* error)
{
  const double need = side + margin;
  for (std::size_t i = 0; i < world.trunks.size(); ++i)
  {
    const TrunkSpec& t = world.trunks[i];
    const double gap = distanceToPolyline(path, t.x, t.y) - t.radius;
    if (gap < need)
    {
      *error = format("it passes %.2f m from the surface of trunk %zu at (%.2f, %.2f) in the world, and without "
                      "obstacle avoidance the robot needs %.2f m there",
                      gap, i, t.x, t.y, need);
      return false;
    }
  }
  for (std::size_t i = 0; i < world.boxes.size(); ++i)
  {
    const BoxSpec& b = world.boxes[i];
    for (std::size_t k = 0; k + 1 < path.size(); ++k)
    {
      const Eigen::Vector2d a = path[k], ab = path[k + 1] - path[k];
      const int n = std::max(1, static_cast<int>(std::ceil(ab.norm() / kSampleStep)));
      for (int j = 0; j <= n; ++j)
      {
        const double gap = boxDistance(b, a + ab * (static_cast<double>(j) / n));
        if (gap < need)
        {
          *error = format("it passes %.2f m from box %zu at (%.2f, %.2f) in the world, and without obstacle "
                          "avoidance the robot needs %.2f m there",
                          gap, i, b.x, b.y, need);
          return false;
        }
      }
    }
  }
  return true;
}

/**
 * With the planner: the places within @p band of the drive where base_link keeps @p need from every trunk surface,
 * box and piece of clutter in @p blockers, searched from the drive's start (a grid of kCell); every point of the
 * drive must have one of them within @p band that the search reached. A necessary condition only: the planner does
 * not see the world beforehand.
 */
bool checkCorridor(const ForestWorld& world, const std::vector<Blocker>& blockers,
                   const std::vector<Eigen::Vector2d>& path, double need, double band, std::string* error)
{
  Eigen::Vector2d lo = path.front(), hi = path.front();
  for (const Eigen::Vector2d& p : path)
  {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  lo -= Eigen::Vector2d::Constant(band + kCell);
  hi += Eigen::Vector2d::Constant(band + kCell);
  const int nx = static_cast<int>(std::ceil((hi.x() - lo.x()) / kCell)) + 1;
  const int ny = static_cast<int>(std::ceil((hi.y() - lo.y()) / kCell)) + 1;
  if (static_cast<double>(nx) * ny > 5e7)
  {
    *error = "it spans too large an area to check (more than 50 million cells of 0.1 m)";
    return false;
  }
  const auto centre = [&](int ix, int iy) { return Eigen::Vector2d(lo.x() + ix * kCell, lo.y() + iy * kCell); };
  const auto cellOf = [&](const Eigen::Vector2d& p, int* ix, int* iy) {
    *ix = static_cast<int>(std::lround((p.x() - lo.x()) / kCell));
    *iy = static_cast<int>(std::lround((p.y() - lo.y()) / kCell));
  };
  // 0: outside the band, 1: free, 2: blocked, 3: reached.
  std::vector<std::uint8_t> grid(static_cast<std::size_t>(nx) * ny, 0);
  const auto at = [&](int ix, int iy) -> std::uint8_t& { return grid[static_cast<std::size_t>(iy) * nx + ix]; };
  const auto cover = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b, double radius,
                         const std::function<void(int, int, const Eigen::Vector2d&)>& visit) {
    int x0, y0, x1, y1;
    const Eigen::Vector2d from = a.cwiseMin(b) - Eigen::Vector2d::Constant(radius);
    const Eigen::Vector2d to = a.cwiseMax(b) + Eigen::Vector2d::Constant(radius);
    cellOf(from, &x0, &y0);
    cellOf(to, &x1, &y1);
    for (int iy = std::max(0, y0); iy <= std::min(ny - 1, y1); ++iy)
      for (int ix = std::max(0, x0); ix <= std::min(nx - 1, x1); ++ix)
        visit(ix, iy, centre(ix, iy));
  };
  for (std::size_t k = 0; k + 1 < path.size(); ++k)
    cover(path[k], path[k + 1], band, [&](int ix, int iy, const Eigen::Vector2d& c) {
      if (at(ix, iy) == 0 && (nearestOnSegment(path[k], path[k + 1], c) - c).norm() <= band)
        at(ix, iy) = 1;
    });
  // Clutter blocks a cell when the cell's centre lies nearer than need less half the cell's diagonal: a gap the grid
  // cannot resolve is left open (the check may pass what cannot be followed, never refuse what can; a bush's rim is
  // seen sparsely, rays pass through it). Nor does it close the robot's footprint at the start: the planner lets the
  // robot leave clutter it starts beside.
  const double slack = 0.5 * M_SQRT2 * kCell;
  for (const Blocker& k : blockers)
  {
    const double reach = k.radius + need - (k.clutter ? slack : 0.0);
    cover(k.a, k.b, reach, [&](int ix, int iy, const Eigen::Vector2d& c) {
      if ((nearestOnSegment(k.a, k.b, c) - c).norm() < reach && !(k.clutter && (c - path.front()).norm() <= need))
        at(ix, iy) = 2;
    });
  }
  for (const BoxSpec& b : world.boxes)
  {
    const Eigen::Vector2d centre_b(b.x, b.y);
    cover(centre_b, centre_b, 0.5 * std::hypot(b.length, b.width) + need,
          [&](int ix, int iy, const Eigen::Vector2d& c) {
            if (boxDistance(b, c) < need)
              at(ix, iy) = 2;
          });
  }
  int sx, sy;
  cellOf(path.front(), &sx, &sy);
  if (at(sx, sy) != 1)
  {
    *error = format("it starts at (%.2f, %.2f) in the world, nearer than %.2f m (the robot from base_link to a "
                    "trunk or a box) to a trunk or a box",
                    path.front().x(), path.front().y(), need);
    return false;
  }
  std::vector<std::pair<int, int>> queue{ { sx, sy } };
  at(sx, sy) = 3;
  for (std::size_t q = 0; q < queue.size(); ++q)
  {
    const int x = queue[q].first, y = queue[q].second;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx)
      {
        const int ix = x + dx, iy = y + dy;
        if (ix >= 0 && iy >= 0 && ix < nx && iy < ny && at(ix, iy) == 1)
        {
          at(ix, iy) = 3;
          queue.emplace_back(ix, iy);
        }
      }
  }
  // Every point of the drive (each kCell along it) must have a reached place within the band.
  const int reach = static_cast<int>(std::ceil(band / kCell));
  for (std::size_t k = 0; k + 1 < path.size(); ++k)
  {
    const Eigen::Vector2d a = path[k], ab = path[k + 1] - path[k];
    const int n = std::max(1, static_cast<int>(std::ceil(ab.norm() / kCell)));
    for (int j = 0; j <= n; ++j)
    {
      const Eigen::Vector2d p = a + ab * (static_cast<double>(j) / n);
      int px, py;
      cellOf(p, &px, &py);
      bool found = false;
      for (int iy = std::max(0, py - reach); iy <= std::min(ny - 1, py + reach) && !found; ++iy)
        for (int ix = std::max(0, px - reach); ix <= std::min(nx - 1, px + reach) && !found; ++ix)
          found = at(ix, iy) == 3 && (centre(ix, iy) - p).norm() <= band;
      if (!found)
      {
        *error = format("its point (%.2f, %.2f) in the world cannot be reached: trunks, boxes and the clutter the "
                        "planner steers round (bushes, rocks, low branches) leave no way there within %.1f m of the "
                        "drive that the robot (%.2f m from base_link to any of them) fits through",
                        p.x(), p.y(), band, need);
        return false;
      }
    }
  }
  return true;
}
}  // namespace

double distanceToPolyline(const std::vector<Eigen::Vector2d>& path, double x, double y)
{
  const Eigen::Vector2d p(x, y);
  if (path.empty())
    return std::numeric_limits<double>::infinity();
  if (path.size() == 1)
    return (path.front() - p).norm();
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < path.size(); ++i)
    best = std::min(best, (nearestOnSegment(path[i], path[i + 1], p) - p).norm());
  return best;
}

bool checkDrive(const ForestWorld& world, const ScenarioConfig& config, std::string* error)
{
  const auto fail = [error](const std::string& why) {
    if (error)
      *error = why;
    return false;
  };
  const std::vector<Eigen::Vector2d>& drive = config.drive;
  bool moves = false;
  for (const Eigen::Vector2d& p : drive)
  {
    if (!p.allFinite())
      return fail("a waypoint is not a finite number");
    moves = moves || (p - drive.front()).norm() > 1e-6;
  }
  if (!moves)
    return fail("it has fewer than two distinct waypoints");
  // The drive in the world, laid from the start pose.
  std::vector<Eigen::Vector2d> path;
  for (const Eigen::Vector2d& p : drive)
  {
    Eigen::Vector2d w;
    config.sim.start.transformPoint(p.x(), p.y(), &w.x(), &w.y());
    path.push_back(w);
  }
  const double m = world.ground.margin;
  for (const Eigen::Vector2d& p : path)
    if (p.x() < world.min_x - m || p.x() > world.max_x + m || p.y() < world.min_y - m || p.y() > world.max_y + m)
      return fail(format("it leaves the ground at (%.1f, %.1f) in the world, which ends %.0f m outside the stand "
                         "[%.1f, %.1f] x [%.1f, %.1f]",
                         p.x(), p.y(), m, world.min_x, world.max_x, world.min_y, world.max_y));
  const RobotConfig& robot = config.sim.robot;
  const bool car = robot.model == RobotModel::kAckermann;
  const double side = car ? 0.5 * robot.width : robot.footprint_radius;
  const PathFollowerConfig& f = config.follower;
  if (!f.avoid_obstacles || f.max_departure <= 0.0)
    return checkClearance(world, path, side, f.avoid_obstacles ? f.min_clearance : 0.0, error);
  // What the planner sees: the 3D lidar's points in its height band, or else the 2D scanner's plane (with neither it
  // sees nothing and only trunks and boxes are checked).
  const SimulatorConfig& sc = config.sim;
  std::vector<Blocker> blockers;
  if (sc.lidar3d.enabled)
    blockers = blockersInBand(world, f.obstacle_min_height, f.obstacle_max_height);
  else if (sc.lidar2d.enabled)
    blockers = blockersInBand(world, sc.lidar2d.mount.z, sc.lidar2d.mount.z);
  else
    for (const TrunkSpec& t : world.trunks)
      blockers.push_back({ Eigen::Vector2d(t.x, t.y), Eigen::Vector2d(t.x, t.y), t.radius, false });
  return checkCorridor(world, blockers, path, side + f.min_clearance, f.max_departure, error);
}

}  // namespace sim
}  // namespace rbpf_slam
