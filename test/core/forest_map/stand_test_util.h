// A random stand of surveyed trees for the gtests of the searches in a tree map (constellation, relocalizer).
#ifndef RBPF_SLAM_TEST_CORE_STAND_TEST_UTIL_H
#define RBPF_SLAM_TEST_CORE_STAND_TEST_UTIL_H

#include <random>
#include <vector>

#include "rbpf_slam/core/fastslam/landmark_map.h"

namespace rbpf_slam
{
namespace test
{
/** @p n confirmed trees (radius 0.08-0.35 m, 3 cm sigma) in a @p size x @p size m square, at least 1.5 m apart. */
inline std::vector<core::Landmark> randomStand(int n, double size, unsigned seed)
{
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(0.0, size), rad(0.08, 0.35);
  std::vector<core::Landmark> trees;
  while (static_cast<int>(trees.size()) < n)
  {
    core::Landmark l;
    l.mean = Eigen::Vector2d(pos(rng), pos(rng));
    bool clear = true;
    for (const core::Landmark& o : trees)
      clear = clear && (o.mean - l.mean).norm() > 1.5;
    if (!clear)
      continue;
    l.radius = rad(rng);
    l.radius_variance = 0.01 * 0.01;
    l.covariance = 0.03 * 0.03 * Eigen::Matrix2d::Identity();
    l.provisional = false;
    l.id = static_cast<int>(trees.size());
    trees.push_back(l);
  }
  return trees;
}

}  // namespace test
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_TEST_CORE_STAND_TEST_UTIL_H
