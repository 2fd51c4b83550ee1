#include "rbpf_slam/core/ground_model.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace rbpf_slam
{
namespace core
{
std::int64_t packCell(std::int64_t ix, std::int64_t iy)
{
  return static_cast<std::int64_t>((static_cast<std::uint64_t>(ix) << 32) ^
                                   (static_cast<std::uint64_t>(iy) & 0xffffffffULL));
}

GroundModel::GroundModel(double cell, double sensor_height, double max_slope)
  : cell_(cell), sensor_height_(sensor_height), max_slope_(max_slope)
{
}

std::int64_t GroundModel::key(double x, double y) const
{
  return packCell(static_cast<std::int64_t>(std::floor(x / cell_)), static_cast<std::int64_t>(std::floor(y / cell_)));
}

void GroundModel::build(const std::vector<Eigen::Vector3d>& points)
{
  lowest_.clear();
  ground_.clear();
  lowest_.reserve(points.size() / 4 + 16);
  for (const auto& p : points)
  {
    const std::int64_t k = key(p.x(), p.y());
    auto it = lowest_.find(k);
    if (it == lowest_.end())
      lowest_.emplace(k, static_cast<float>(p.z()));
    else if (p.z() < it->second)
      it->second = static_cast<float>(p.z());
  }
  ground_.reserve(lowest_.size());
}

double GroundModel::heightAt(double x, double y)
{
  const std::int64_t k = key(x, y);
  auto it = ground_.find(k);
  if (it != ground_.end())
    return static_cast<double>(it->second);
  double g = std::numeric_limits<double>::infinity();
  for (int dx = -1; dx <= 1; ++dx)
    for (int dy = -1; dy <= 1; ++dy)
    {
      auto n = lowest_.find(key(x + dx * cell_, y + dy * cell_));
      if (n != lowest_.end())
        g = std::min(g, static_cast<double>(n->second));
    }
  if (sensor_height_ > 0.0)
  {
    const double cap = -sensor_height_ + max_slope_ * std::hypot(x, y);
    g = std::min(g, cap);
  }
  ground_.emplace(k, static_cast<float>(g));
  return g;
}

std::vector<Eigen::Vector3f> selectHeightBand(const std::vector<Eigen::Vector3d>& points, GroundModel* ground,
                                              double min_height, double max_height)
{
  std::vector<Eigen::Vector3f> band;
  for (const auto& p : points)
  {
    const double h = p.z() - ground->heightAt(p.x(), p.y());
    if (h >= min_height && h <= max_height)
      band.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
  }
  return band;
}

}  // namespace core
}  // namespace rbpf_slam
