#ifndef RBPF_SLAM_CORE_EXTRACTION_GROUND_MODEL_H
#define RBPF_SLAM_CORE_EXTRACTION_GROUND_MODEL_H

#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

namespace rbpf_slam
{
namespace core
{
/**
 * @brief Ground height under a sweep, from its lowest points: the lowest point of each grid cell, the lowest
 * over the 3 × 3 cells around a position, capped by what the slope allows from the ground under the sensor
 * when the sensor's height is known (a cell of bush tops or a crown then does not lift the ground).
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
   */
  GroundModel(double cell, double sensor_height, double max_slope);

  /** @brief The lowest point of every cell the points fall in; remembers each point's cell for heightUnder(). */
  void build(const std::vector<Eigen::Vector3d>& points);

  /** @brief Ground height [m] at (x, y); +infinity where no cell around has points and no cap applies. */
  double heightAt(double x, double y);

  /** @brief heightAt(x, y) for the @p i-th point given to build(), at (x, y), without finding its cell again. */
  double heightUnder(std::size_t i, double x, double y);

private:
  double heightOfCell(std::int64_t ix, std::int64_t iy, double x, double y);

  double cell_;
  double sensor_height_;
  double max_slope_;
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
 * @brief One hash key for a 2D cell: ix in the high word, iy's low 32 bits in the low word.
 *
 * Shifted as unsigned, since cells left of or behind the sensor have negative indices and a left shift of a
 * negative value is undefined.
 */
std::int64_t packCell(std::int64_t ix, std::int64_t iy);

/**
 * @brief The points whose height above the local ground lies in [min_height, max_height] [m], in their order, as
 * single precision. @p ground was built from these @p points.
 */
std::vector<Eigen::Vector3f> selectHeightBand(const std::vector<Eigen::Vector3d>& points, GroundModel* ground,
                                              double min_height, double max_height);

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_EXTRACTION_GROUND_MODEL_H
