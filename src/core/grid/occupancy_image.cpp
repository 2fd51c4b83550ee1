#include "rbpf_slam/core/grid/occupancy_image.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace rbpf_slam
{
namespace core
{
namespace
{
// Decimal resolutions make border points land a few ulps off the border; 1e-9 cells is far above that
// rounding and far below anything a map or a lidar can resolve.
constexpr double kSnap = 1e-9;
// cos(pi / 2) is 6e-17, not 0: without snapping, an "axis-parallel" ray started on a grid line would drift
// into the neighbouring cell depending on the sign of that rounding error.
constexpr double kAxisSnap = 1e-12;
// Two crossing times this close [cells] are one crossing through a grid vertex.
constexpr double kTie = 1e-9;

double snapToBorder(double g)
{
  const double r = std::round(g);
  return std::abs(g - r) <= kSnap ? r : g;
}

std::string describeCell(std::size_t i, int width, int value)
{
  return "cell " + std::to_string(i) + " (col " + std::to_string(static_cast<int>(i % width)) + ", row " +
         std::to_string(static_cast<int>(i / width)) + ") has value " + std::to_string(value);
}
}  // namespace

constexpr std::int8_t OccupancyImage::kOccupied;
constexpr std::int8_t OccupancyImage::kFree;
constexpr std::int8_t OccupancyImage::kUnknown;

OccupancyImage::OccupancyImage(int width, int height, double resolution, const MapOrigin& origin,
                               std::vector<std::int8_t> cells)
  : width_(width), height_(height), resolution_(resolution), origin_(origin), cells_(std::move(cells))
{
  if (width < 0 || height < 0)
    throw std::invalid_argument("OccupancyImage: negative size " + std::to_string(width) + " x " +
                                std::to_string(height));
  if (!std::isfinite(resolution) || resolution <= 0.0)
    throw std::invalid_argument("OccupancyImage: resolution must be finite and > 0 (got " +
                                std::to_string(resolution) + ")");
  if (!std::isfinite(origin.x) || !std::isfinite(origin.y) || !std::isfinite(origin.yaw))
    throw std::invalid_argument("OccupancyImage: origin must be finite");
  const std::size_t expected = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (cells_.size() != expected)
    throw std::invalid_argument("OccupancyImage: " + std::to_string(cells_.size()) + " cells for a " +
                                std::to_string(width) + " x " + std::to_string(height) + " grid (expected " +
                                std::to_string(expected) + ")");
  for (std::size_t i = 0; i < cells_.size(); ++i)
  {
    const std::int8_t v = cells_[i];
    if (v != kOccupied && v != kFree && v != kUnknown)
      throw std::invalid_argument("OccupancyImage: " + describeCell(i, width, v) + "; expected 100, 0 or -1");
  }
  cos_yaw_ = std::cos(origin.yaw);
  sin_yaw_ = std::sin(origin.yaw);
}

void OccupancyImage::worldToGrid(double x, double y, double* gx, double* gy) const
{
  const double dx = x - origin_.x;
  const double dy = y - origin_.y;
  *gx = snapToBorder((cos_yaw_ * dx + sin_yaw_ * dy) / resolution_);
  *gy = snapToBorder((-sin_yaw_ * dx + cos_yaw_ * dy) / resolution_);
}

bool OccupancyImage::worldToCell(double x, double y, int* col, int* row) const
{
  double gx = 0.0, gy = 0.0;
  worldToGrid(x, y, &gx, &gy);
  // Written so that NaN fails; the range check comes before the cast, which would overflow otherwise.
  if (!(gx >= 0.0 && gx < width_ && gy >= 0.0 && gy < height_))
    return false;
  *col = static_cast<int>(std::floor(gx));
  *row = static_cast<int>(std::floor(gy));
  return true;
}

Eigen::Vector2d OccupancyImage::cellCenter(int col, int row) const
{
  const double gx = (col + 0.5) * resolution_;
  const double gy = (row + 0.5) * resolution_;
  return Eigen::Vector2d(origin_.x + cos_yaw_ * gx - sin_yaw_ * gy, origin_.y + sin_yaw_ * gx + cos_yaw_ * gy);
}

bool OccupancyImage::occupied(double x, double y) const
{
  int col = 0, row = 0;
  return worldToCell(x, y, &col, &row) && cellOccupied(col, row);
}

double OccupancyImage::castRay(double x, double y, double angle, double max_range) const
{
  const double inf = std::numeric_limits<double>::infinity();
  if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(angle) || !(max_range >= 0.0))
    return std::numeric_limits<double>::quiet_NaN();
  if (cells_.empty())
    return inf;
  if (occupied(x, y))
    return 0.0;

  // Everything below is in grid units (cells), so t is a distance in cells along a unit direction.
  double px = 0.0, py = 0.0;
  worldToGrid(x, y, &px, &py);
  double dx = std::cos(angle - origin_.yaw);
  double dy = std::sin(angle - origin_.yaw);
  if (std::abs(dx) < kAxisSnap)
  {
    dx = 0.0;
    dy = dy > 0.0 ? 1.0 : -1.0;
  }
  else if (std::abs(dy) < kAxisSnap)
  {
    dy = 0.0;
    dx = dx > 0.0 ? 1.0 : -1.0;
  }
  const double max_t = max_range / resolution_;

  // Clip the ray to the grid's box [0, width] x [0, height] so that a start far outside costs nothing and
  // the traversal below never leaves the grid except through its far side.
  double t_enter = 0.0;
  double t_exit = inf;
  int enter_axis = -1;  // the axis whose box side the ray enters through when it starts outside
  const auto clip = [&](double p, double d, int size, int axis) {
    if (d == 0.0)
      return p >= 0.0 && p < size;  // half-open: a ray along the far side line is outside the grid
    double t_lo = (0.0 - p) / d;
    double t_hi = (size - p) / d;
    if (t_lo > t_hi)
      std::swap(t_lo, t_hi);
    if (t_lo > t_enter)
    {
      t_enter = t_lo;
      enter_axis = axis;
    }
    t_exit = std::min(t_exit, t_hi);
    return true;
  };
  if (!clip(px, dx, width_, 0) || !clip(py, dy, height_, 1))
    return inf;
  if (t_enter >= t_exit || t_enter > max_t)
    return inf;  // misses the grid, only touches its outline, or reaches it beyond max_range

  // First cell and time of the next border crossing per axis. Crossing times are recomputed from the start
  // point for every border instead of accumulated, so long rays carry no drift.
  const auto first_cell = [&](double p, double d, int size, int axis, int* cell, int* step) {
    if (d == 0.0)
    {
      *cell = static_cast<int>(std::floor(p));
      *step = 0;
      return;
    }
    *step = d > 0.0 ? 1 : -1;
    if (axis == enter_axis)
    {
      *cell = d > 0.0 ? 0 : size - 1;
      return;
    }
    const double q = t_enter > 0.0 ? p + t_enter * d : p;
    // On a border, the ray is in the cell it moves into; clamped because q may round just outside the box.
    const double c = d > 0.0 ? std::floor(q) : std::ceil(q) - 1.0;
    *cell = static_cast<int>(std::max(0.0, std::min(size - 1.0, c)));
  };
  const auto next_crossing = [&](double p, double d, int cell, int step) {
    return step == 0 ? inf : (cell + (step > 0 ? 1 : 0) - p) / d;
  };

  int cx = 0, cy = 0, sx = 0, sy = 0;
  first_cell(px, dx, width_, 0, &cx, &sx);
  first_cell(py, dy, height_, 1, &cy, &sy);
  double tx = next_crossing(px, dx, cx, sx);
  double ty = next_crossing(py, dy, cy, sy);
  double t = t_enter;

  for (;;)
  {
    if (cellOccupied(cx, cy))
      return t * resolution_;
    const double t_next = std::min(tx, ty);
    if (t_next > max_t)
      return inf;
    const bool cross_x = tx - t_next <= kTie;
    const bool cross_y = ty - t_next <= kTie;
    if (cross_x && cross_y)
    {
      // Through a vertex: the two cells beside it are touched too (see the header).
      if (cellOccupied(cx + sx, cy) || cellOccupied(cx, cy + sy))
        return t_next * resolution_;
    }
    if (cross_x)
    {
      cx += sx;
      tx = next_crossing(px, dx, cx, sx);
    }
    if (cross_y)
    {
      cy += sy;
      ty = next_crossing(py, dy, cy, sy);
    }
    t = t_next;
    if (!contains(cx, cy))
      return inf;
  }
}

}  // namespace core
}  // namespace rbpf_slam
