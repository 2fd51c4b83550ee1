#include "rbpf_slam/core/extraction/ground_model.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

namespace rbpf_slam
{
namespace core
{
namespace
{
constexpr std::int64_t kMaxDenseCells = std::int64_t(1) << 20;  // [cells] larger sweeps use the hash maps

std::int64_t cellIndex(double v, double cell)
{
  return static_cast<std::int64_t>(std::floor(v / cell));
}
}  // namespace

GroundModel::GroundModel(double cell, double sensor_height, double max_slope, double relief, double radius)
  : cell_(cell), sensor_height_(sensor_height), max_slope_(max_slope), relief_(relief), radius_(radius)
{
}

bool GroundModel::groundPlane(Eigen::Vector2d* slope) const
{
  if (plane_ && slope)
    *slope = slope_;
  return plane_;
}

void GroundModel::fitPlane()
{
  plane_ = sensor_height_ > 0.0 && relief_ > 0.0;
  slope_.setZero();
  if (!plane_)
    return;
  // Each cell's lowest point at the cell's centre, relative to the ground under the sensor (the prior).
  std::vector<Eigen::Vector3d> low;
  const auto add = [&](std::int64_t ix, std::int64_t iy, float z) {
    const double x = (static_cast<double>(ix) + 0.5) * cell_, y = (static_cast<double>(iy) + 0.5) * cell_;
    if (std::isfinite(z) && std::hypot(x, y) <= radius_)
      low.emplace_back(x, y, static_cast<double>(z) + sensor_height_);
  };
  if (dense_)
  {
    for (std::int64_t iy = 0; iy < ny_; ++iy)
      for (std::int64_t ix = 0; ix < nx_; ++ix)
        add(ix0_ + ix, iy0_ + iy, lowest_grid_[static_cast<std::size_t>(iy * nx_ + ix)]);
  }
  else
  {
    for (const auto& kv : lowest_)
      add(static_cast<std::int32_t>(static_cast<std::uint64_t>(kv.first) >> 32),
          static_cast<std::int32_t>(static_cast<std::uint64_t>(kv.first) & 0xffffffffULL), kv.second);
  }
  // The plane through the ground under the sensor that most seen cells lie on (within the relief), found over a
  // grid of slopes up to max_slope: a cell whose lowest point lies more than the relief below a plane rules it out
  // (ground seen beneath it), one above it shows a stem or a shrub and says nothing. The slope's prior costs a
  // slope of max_slope as much as four cells, so a bush's top alone does not tilt it. Then least squares over the
  // best plane's cells.
  const auto score = [&](const Eigen::Vector2d& s) {
    double n = -4.0 * s.squaredNorm() / std::max(max_slope_ * max_slope_, 1e-12);
    for (const auto& p : low)
    {
      const double e = p.z() - s.dot(p.head<2>());
      if (std::abs(e) <= relief_)
        n += 1.0;
      else if (e < -relief_)
        n -= 2.0;
    }
    return n;
  };
  double best = score(slope_);
  const int steps = 10;
  const double step = max_slope_ / steps;
  for (int i = -steps; i <= steps && step > 0.0; ++i)
    for (int k = -steps; k <= steps; ++k)
    {
      const Eigen::Vector2d s(i * step, k * step);
      if (s.norm() > max_slope_ + 1e-12 || (i == 0 && k == 0))
        continue;
      const double n = score(s);
      if (n > best)
      {
        best = n;
        slope_ = s;
      }
    }
  const double prior = (relief_ * relief_) / std::max(max_slope_ * max_slope_, 1e-12);
  Eigen::Matrix2d a = prior * Eigen::Matrix2d::Identity();
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  for (const auto& p : low)
    if (std::abs(p.z() - slope_.dot(p.head<2>())) <= relief_)
    {
      a += p.head<2>() * p.head<2>().transpose();
      b += p.head<2>() * p.z();
    }
  slope_ = a.ldlt().solve(b);
  if (slope_.norm() > max_slope_)
    slope_ *= max_slope_ / std::max(slope_.norm(), 1e-12);
}

void GroundModel::build(const std::vector<Eigen::Vector3d>& points)
{
  lowest_.clear();
  ground_.clear();
  point_cell_.resize(2 * points.size());
  std::int64_t min_ix = 0, max_ix = -1, min_iy = 0, max_iy = -1;
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    const std::int64_t ix = cellIndex(points[i].x(), cell_), iy = cellIndex(points[i].y(), cell_);
    point_cell_[2 * i] = ix;
    point_cell_[2 * i + 1] = iy;
    if (i == 0 || ix < min_ix)
      min_ix = ix;
    if (i == 0 || ix > max_ix)
      max_ix = ix;
    if (i == 0 || iy < min_iy)
      min_iy = iy;
    if (i == 0 || iy > max_iy)
      max_iy = iy;
  }
  // One cell of margin, so that the neighbours of every point's cell are in the grid. Differences in double: the
  // indices of far-off points would overflow a product of integers.
  ix0_ = min_ix - 1;
  iy0_ = min_iy - 1;
  const double cells = (static_cast<double>(max_ix) - static_cast<double>(min_ix) + 3.0) *
                       (static_cast<double>(max_iy) - static_cast<double>(min_iy) + 3.0);
  dense_ = !points.empty() && cells <= static_cast<double>(kMaxDenseCells);
  if (dense_)
  {
    nx_ = max_ix - min_ix + 3;
    ny_ = max_iy - min_iy + 3;
    lowest_grid_.assign(static_cast<std::size_t>(nx_ * ny_), std::numeric_limits<float>::infinity());
    ground_grid_.assign(static_cast<std::size_t>(nx_ * ny_), std::numeric_limits<float>::quiet_NaN());
    for (std::size_t i = 0; i < points.size(); ++i)
    {
      float& lowest = lowest_grid_[static_cast<std::size_t>((point_cell_[2 * i + 1] - iy0_) * nx_ +
                                                            (point_cell_[2 * i] - ix0_))];
      lowest = std::min(lowest, static_cast<float>(points[i].z()));
    }
    fitPlane();
    return;
  }
  lowest_.reserve(points.size() / 4 + 16);
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    const std::int64_t k = packCell(point_cell_[2 * i], point_cell_[2 * i + 1]);
    auto it = lowest_.find(k);
    if (it == lowest_.end())
      lowest_.emplace(k, static_cast<float>(points[i].z()));
    else if (points[i].z() < it->second)
      it->second = static_cast<float>(points[i].z());
  }
  ground_.reserve(lowest_.size());
  fitPlane();
}

double GroundModel::heightAt(double x, double y)
{
  return heightOfCell(cellIndex(x, cell_), cellIndex(y, cell_), x, y);
}

double GroundModel::heightUnder(std::size_t i, double x, double y)
{
  return heightOfCell(point_cell_[2 * i], point_cell_[2 * i + 1], x, y);
}

double GroundModel::heightOfCell(std::int64_t ix, std::int64_t iy, double x, double y)
{
  const bool in_grid = dense_ && ix >= ix0_ && ix < ix0_ + nx_ && iy >= iy0_ && iy < iy0_ + ny_;
  float* cached = nullptr;
  if (in_grid)
  {
    cached = &ground_grid_[static_cast<std::size_t>((iy - iy0_) * nx_ + (ix - ix0_))];
    if (!std::isnan(*cached))
      return static_cast<double>(*cached);
  }
  else if (!dense_)
  {
    auto it = ground_.find(packCell(ix, iy));
    if (it != ground_.end())
      return static_cast<double>(it->second);
  }
  // The neighbours' cells are found from the position moved by a cell, as the grid was indexed by position.
  double g = std::numeric_limits<double>::infinity();
  for (int dx = -1; dx <= 1; ++dx)
    for (int dy = -1; dy <= 1; ++dy)
    {
      const std::int64_t nx = cellIndex(x + dx * cell_, cell_), ny = cellIndex(y + dy * cell_, cell_);
      if (dense_)
      {
        if (nx >= ix0_ && nx < ix0_ + nx_ && ny >= iy0_ && ny < iy0_ + ny_)
          g = std::min(g, static_cast<double>(lowest_grid_[static_cast<std::size_t>((ny - iy0_) * nx_ + (nx - ix0_))]));
      }
      else
      {
        auto n = lowest_.find(packCell(nx, ny));
        if (n != lowest_.end())
          g = std::min(g, static_cast<double>(n->second));
      }
    }
  if (sensor_height_ > 0.0)
  {
    const double cap = -sensor_height_ + max_slope_ * std::hypot(x, y);
    g = std::min(g, cap);
  }
  if (plane_)
  {
    // No ground seen here, or only a stem's or a shrub's lowest return: the plane of the ground seen elsewhere.
    const double plane = slope_.x() * x + slope_.y() * y - sensor_height_;
    if (!(g <= plane + relief_))
      g = plane;
  }
  if (cached)
    *cached = static_cast<float>(g);
  else if (!dense_)
    ground_.emplace(packCell(ix, iy), static_cast<float>(g));
  return g;
}

std::vector<Eigen::Vector3f> selectHeightBand(const std::vector<Eigen::Vector3d>& points, GroundModel* ground,
                                              double min_height, double max_height)
{
  std::vector<Eigen::Vector3f> band;
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    const Eigen::Vector3d& p = points[i];
    const double h = p.z() - ground->heightUnder(i, p.x(), p.y());
    if (h >= min_height && h <= max_height)
      band.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
  }
  return band;
}

}  // namespace core
}  // namespace rbpf_slam
