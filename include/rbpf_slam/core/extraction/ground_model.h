#ifndef RBPF_SLAM_CORE_EXTRACTION_GROUND_MODEL_H
#define RBPF_SLAM_CORE_EXTRACTION_GROUND_MODEL_H

#include <cstdint>
#include <limits>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/filter/cell_key.h"

namespace rbpf_slam
{
namespace core
{
/**
 * @brief Ground height under a sweep, from its lowest points: the lowest point of each grid cell, the lowest
 * over the 3 × 3 cells around a position, capped by what the slope allows from the ground under the sensor
 * when the sensor's height is known (a cell of bush tops or a crown then does not lift the ground).
 *
 * With the sensor's height known and a relief given, the ground the sensor sees also gives a plane through the
 * ground under the sensor (the mount height is its prior where the sensor sees no ground): a position whose lowest
 * point lies more than the relief above that plane, or that has no point around it, shows a stem, a shrub or
 * nothing, and takes the plane's height. A 16-ring lidar 1.8 m up sees no ground within about 7 m; without the
 * plane the lowest return of a stem there (1 m up) would be its ground.
 *
 * Heights are in the cloud's levelled frame (sensor at the origin, z up). Reusable across sweeps: build()
 * replaces the previous sweep's model.
 */
class GroundModel
{
public:
  /**
   * @param cell [m] side of the grid cells
   * @param sensor_height [m] sensor above the ground under it; 0 = unknown (no cap)
   * @param max_slope [-] the ground rises at most this much per metre away from the sensor
   * @param relief [m] the seen ground departs at most this much from a plane; 0 = no plane (the cap alone)
   * @param radius [m] the plane is fitted to the ground seen within this distance of the sensor
   */
  GroundModel(double cell, double sensor_height, double max_slope, double relief = 0.0,
              double radius = std::numeric_limits<double>::infinity());

  /** @brief The lowest point of every cell the points fall in; remembers each point's cell for heightUnder(). */
  void build(const std::vector<Eigen::Vector3d>& points);

  /**
   * @brief The plane of the seen ground, z = slope.x x + slope.y y - sensor_height, when build() fitted one
   * (sensor height and relief given; with no ground seen it is level). false otherwise.
   */
  bool groundPlane(Eigen::Vector2d* slope) const;

  /** @brief Ground height [m] at (x, y); +infinity where no cell around has points and no cap applies. */
  double heightAt(double x, double y);

  /** @brief heightAt(x, y) for the @p i-th point given to build(), at (x, y), without finding its cell again. */
  double heightUnder(std::size_t i, double x, double y);

private:
  double heightOfCell(std::int64_t ix, std::int64_t iy, double x, double y);
  void fitPlane();

  double cell_;
  double sensor_height_;
  double max_slope_;
  double relief_;
  double radius_;
  bool plane_ = false;                                ///< a plane was fitted (sensor height and relief given)
  Eigen::Vector2d slope_ = Eigen::Vector2d::Zero();   ///< its rise per metre along x and y
  // A dense grid over the points' cells with a margin of one cell: the lowest z per cell (+inf where empty) and
  // heightAt() per cell as asked (NaN until then). Sweeps spread over more cells than a real lidar sees use the
  // hash maps instead.
  std::int64_t ix0_ = 0, iy0_ = 0, nx_ = 0, ny_ = 0;
  bool dense_ = false;
  std::vector<float> lowest_grid_;
  std::vector<float> ground_grid_;
  std::vector<std::int64_t> point_cell_;  ///< per point of build(): ix, iy
  std::unordered_map<std::int64_t, float> lowest_;
  std::unordered_map<std::int64_t, float> ground_;
};

/**
 * @brief The points whose height above the local ground lies in [min_height, max_height] [m], in their order, as
 * single precision. @p ground was built from these @p points.
 */
std::vector<Eigen::Vector3f> selectHeightBand(const std::vector<Eigen::Vector3d>& points, GroundModel* ground,
                                              double min_height, double max_height);

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_EXTRACTION_GROUND_MODEL_H
