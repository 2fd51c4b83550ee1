#ifndef RBPF_SLAM_TEST_CORE_GRID_TEST_WORLD_H
#define RBPF_SLAM_TEST_CORE_GRID_TEST_WORLD_H

// A synthetic room, a simulated 181-beam scanner and a loop through the room, shared by the grid SLAM tests.

#include <cmath>
#include <limits>
#include <vector>

#include "rbpf_slam/core/grid/occupancy_grid.h"
#include "rbpf_slam/core/filter/pose2.h"
#include "rbpf_slam/core/filter/random.h"

namespace grid_test_world
{
using rbpf_slam::core::Pose2;
using rbpf_slam::core::Random;
using rbpf_slam::core::ScanData;

struct Segment
{
  double x0, y0, x1, y1;
};

// An asymmetric room (10 x 8 m) with a box and a pillar, so that no two poses see the same scan.
inline const std::vector<Segment>& room()
{
  static const std::vector<Segment> walls = {
    { -4, -3, 6, -3 }, { 6, -3, 6, 5 },   { 6, 5, -4, 5 },     { -4, 5, -4, -3 },   // outer walls
    { 1, 1, 2.5, 1 },  { 2.5, 1, 2.5, 2 }, { 2.5, 2, 1, 2 },   { 1, 2, 1, 1 },      // box
    { -2.5, -1.5, -2.2, -1.5 }, { -2.2, -1.5, -2.2, -1.2 }, { -2.2, -1.2, -2.5, -1.2 }, { -2.5, -1.2, -2.5, -1.5 },
    { 4, 3.5, 6, 2.5 },  // a slanted corner
  };
  return walls;
}

inline double castRay(double x, double y, double a)
{
  const double dx = std::cos(a), dy = std::sin(a);
  double best = std::numeric_limits<double>::infinity();
  for (const auto& s : room())
  {
    const double ex = s.x1 - s.x0, ey = s.y1 - s.y0;
    const double den = dx * ey - dy * ex;
    if (std::abs(den) < 1e-12)
      continue;
    const double t = ((s.x0 - x) * ey - (s.y0 - y) * ex) / den;
    const double u = ((s.x0 - x) * dy - (s.y0 - y) * dx) / den;
    if (t > 0 && u >= 0 && u <= 1)
      best = std::min(best, t);
  }
  return best;
}

// A 181-beam scan over 180 degrees from @p sensor: each beam's range from @p cast(x, y, angle) (+Inf: no return),
// beyond @p range_max no return, with 1 cm of noise when @p noise is given.
template <typename Caster>
ScanData castScan(const Pose2& sensor, Caster cast, double range_max, Random* noise = nullptr)
{
  ScanData scan;
  scan.angle_min = -M_PI / 2;
  scan.angle_increment = M_PI / 180;
  scan.range_min = 0.02;
  scan.range_max = range_max;
  for (int i = 0; i <= 180; ++i)
  {
    double r = cast(sensor.x, sensor.y, sensor.theta + scan.angle_min + i * scan.angle_increment);
    if (noise && std::isfinite(r))
      r += noise->gaussian(0.01);
    scan.ranges.push_back(r <= range_max ? static_cast<float>(r) : std::numeric_limits<float>::infinity());
  }
  return scan;
}

// The room seen from @p sensor (every wall within the scanner's 30 m).
inline ScanData simulateScan(const Pose2& sensor, Random* noise = nullptr)
{
  return castScan(sensor, castRay, 30.0, noise);
}

// A drive through the room: 0.05 m steps along a loop around the box.
inline std::vector<Pose2> truePath()
{
  std::vector<Pose2> path;
  const std::vector<Pose2> corners = { Pose2(-1, -1.5, 0), Pose2(4, -1.5, 0), Pose2(4, 3.5, 0), Pose2(-1.5, 3.5, 0),
                                       Pose2(-1.5, -1.0, 0) };
  for (std::size_t k = 0; k + 1 < corners.size(); ++k)
  {
    const Pose2 a = corners[k], b = corners[k + 1];
    const double heading = std::atan2(b.y - a.y, b.x - a.x);
    const int steps = static_cast<int>(std::hypot(b.x - a.x, b.y - a.y) / 0.05);
    for (int i = 0; i < steps; ++i)
      path.emplace_back(a.x + (b.x - a.x) * i / steps, a.y + (b.y - a.y) * i / steps, heading);
  }
  return path;
}
}  // namespace grid_test_world

#endif  // RBPF_SLAM_TEST_CORE_GRID_TEST_WORLD_H
