#ifndef RBPF_SLAM_CORE_GRID_OCCUPANCY_IMAGE_H
#define RBPF_SLAM_CORE_GRID_OCCUPANCY_IMAGE_H

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace rbpf_slam
{
namespace core
{
/**
 * @brief Pose of a grid in the world frame, as map_server's `origin: [x, y, yaw]`: the world position of
 * the lower-left corner of cell (0, 0) and the rotation of the grid's x axis (columns) about it.
 */
struct MapOrigin
{
  double x = 0.0;    ///< [m]
  double y = 0.0;    ///< [m]
  double yaw = 0.0;  ///< [rad]
};

/**
 * @brief A static occupancy grid (a world for the 2D-lidar simulator), with exact 2D ray casting.
 *
 * Cells are stored row-major with row 0 at the BOTTOM (smallest grid y), as in nav_msgs/OccupancyGrid;
 * a map_server image is flipped when loaded. Cell (col, row) covers the half-open square
 * [col, col + 1) x [row, row + 1) in grid units, so a point on a border belongs to the cell above / to the
 * right of it. Grid coordinates within 1e-9 cells of a border are snapped onto it, so that decimal
 * resolutions (0.05 m) put points like x = 0.15 m exactly on a border despite rounding.
 */
class OccupancyImage
{
public:
  static constexpr std::int8_t kOccupied = 100;
  static constexpr std::int8_t kFree = 0;
  static constexpr std::int8_t kUnknown = -1;

  /** @brief An empty 0 x 0 grid: nothing is occupied, every ray escapes. */
  OccupancyImage() = default;

  /**
   * @brief A grid from raw cells (row-major, row 0 at the bottom).
   * @throws std::invalid_argument if width or height is negative, resolution is not finite and > 0, the
   * origin is not finite, cells.size() != width * height, or a cell is not kOccupied, kFree or kUnknown.
   */
  OccupancyImage(int width, int height, double resolution, const MapOrigin& origin, std::vector<std::int8_t> cells);

  int width() const { return width_; }
  int height() const { return height_; }
  /** @brief [m/cell] */
  double resolution() const { return resolution_; }
  const MapOrigin& origin() const { return origin_; }
  /** @brief Row-major, row 0 at the bottom; values kOccupied, kFree or kUnknown. */
  const std::vector<std::int8_t>& cells() const { return cells_; }
  bool empty() const { return cells_.empty(); }

  /** @brief True when (col, row) is a cell of the grid. */
  bool contains(int col, int row) const { return col >= 0 && row >= 0 && col < width_ && row < height_; }
  /** @brief The value of a cell; kUnknown outside the grid. */
  std::int8_t cell(int col, int row) const { return contains(col, row) ? cells_[index(col, row)] : kUnknown; }
  /** @brief False outside the grid. */
  bool cellOccupied(int col, int row) const { return contains(col, row) && cells_[index(col, row)] == kOccupied; }

  /** @brief The cell containing world point (x, y); false (outputs untouched) outside the grid or if not finite. */
  bool worldToCell(double x, double y, int* col, int* row) const;
  /** @brief World position of the centre of cell (col, row); any integers are accepted. */
  Eigen::Vector2d cellCenter(int col, int row) const;

  /** @brief True when world point (x, y) lies in an occupied cell; outside the grid is not occupied. */
  bool occupied(double x, double y) const;

  /**
   * @brief Distance [m] along the ray from world point (x, y) at world heading @p angle [rad] to where it
   * first enters an occupied cell, by an exact grid traversal (Amanatides-Woo); unknown cells are free.
   *
   * 0 if (x, y) lies in an occupied cell (see occupied()). +infinity if no occupied cell is entered within
   * @p max_range [m] (a hit at exactly max_range counts). The start may be outside the grid. Conventions for
   * the measure-zero cases, chosen to agree with occupied():
   * - a ray exactly along a grid line runs through the cells above / to the right of that line;
   * - a ray starting on a border and moving across it is in the next cell at once (distance 0 if occupied);
   * - a ray passing exactly through a grid vertex (within 1e-9 cells) also touches the two cells beside the
   *   vertex, so that diagonal walls drawn 8-connected (touching only at corners) do not leak.
   * NaN if x, y or angle is not finite or max_range is NaN or negative.
   */
  double castRay(double x, double y, double angle, double max_range) const;

private:
  std::size_t index(int col, int row) const
  {
    return static_cast<std::size_t>(row) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(col);
  }
  /** @brief World point to continuous grid coordinates [cells], snapped onto borders within 1e-9 cells. */
  void worldToGrid(double x, double y, double* gx, double* gy) const;

  int width_ = 0;
  int height_ = 0;
  double resolution_ = 1.0;
  MapOrigin origin_;
  double cos_yaw_ = 1.0;
  double sin_yaw_ = 0.0;
  std::vector<std::int8_t> cells_;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_GRID_OCCUPANCY_IMAGE_H
