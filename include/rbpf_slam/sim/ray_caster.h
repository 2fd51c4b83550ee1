#ifndef RBPF_SLAM_SIM_RAY_CASTER_H
#define RBPF_SLAM_SIM_RAY_CASTER_H

#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/sim/forest_world.h"
#include "rbpf_slam/core/filter/random.h"

namespace rbpf_slam
{
namespace sim
{
/** @brief What a ray hit. */
enum class HitKind : std::uint8_t
{
  kNone = 0,
  kGround = 1,
  kTrunk = 2,
  kFoliage = 3,
  kRock = 4,
  kBranch = 5,
  kBox = 6,
  kStub = 7,     ///< a branch on a stem
  kSapling = 8,  ///< an understory stem
};

struct RayHit
{
  double range = std::numeric_limits<double>::infinity();  ///< [m] along the unit direction
  HitKind kind = HitKind::kNone;
  int index = -1;  ///< index into the world's list of that kind
};

/**
 * @brief Casts rays into a ForestWorld with correct occlusion.
 *
 * Objects are bucketed in a uniform 2D grid and visited in ray order (Amanatides-Woo), so a ray
 * costs O(cells crossed + objects near it), not O(objects). Trunks and saplings are exact cone frusta (lean and
 * taper), rocks spheres, fallen branches and the branches on stems capsules, boxes oriented boxes, foliage porous
 * spheres (the ray stops after an exponential free path, drawn from the caller's generator). The ground is found by
 * sphere tracing with the relief's curvature bound along the ray, refined on the bracket of the crossing; a sloping
 * ground's plane is taken out exactly first (the ray is sheared by it, so that the tracing sees the relief alone).
 */
class ForestRayCaster
{
public:
  explicit ForestRayCaster(const ForestWorld& world, double cell_size = 2.0);

  /**
   * @brief The first surface along origin + t * dir, t in (0, max_range].
   * @param dir unit direction (world frame)
   * @param random draws the free paths in foliage
   */
  RayHit cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double max_range, core::Random& random);

  const Ground& ground() const& { return ground_; }
  const ForestWorld& world() const& { return world_; }
  // Not on a temporary caster: the reference would dangle as soon as the full expression ends.
  const Ground& ground() const&& = delete;
  const ForestWorld& world() const&& = delete;

  /** @brief Exact entry distance of a ray into a trunk, +inf if missed (exposed for tests). */
  static double intersectTrunk(const TrunkSpec& trunk, double ground_z, const Eigen::Vector3d& origin,
                               const Eigen::Vector3d& dir);

private:
  struct Shape
  {
    HitKind kind;
    int index;
  };

  /** @brief A shape's horizontal bounding box and height range while the grid is built. */
  struct ShapeBounds
  {
    Shape shape;
    double x0, y0, x1, y1;
    double z0 = -std::numeric_limits<double>::infinity(), z1 = std::numeric_limits<double>::infinity();
  };

  /** @brief One ray while it is cast: the nearest hit so far and the range that bounds the search. */
  struct RayState
  {
    const Eigen::Vector3d& origin;
    const Eigen::Vector3d& dir;
    core::Random& random;
    double best;
    RayHit hit;
  };

  /**
   * @brief Stores each object's placement on the ground (the per-kind caches) and returns the objects' horizontal
   * bounds, trunks first, then foliage, rocks, branches, boxes, saplings and the branches on stems (the order of
   * shapes_).
   */
  std::vector<ShapeBounds> placeShapes();
  /** @brief The bounds of a trunk or sapling @p t standing at @p ground_z; its 2D bounding circle in @p circle. */
  static ShapeBounds stemBounds(const TrunkSpec& t, const Shape& shape, Eigen::Vector3d* circle);
  /** @brief Sets top_z_ from the placed objects. */
  void findTop();
  /** @brief Sizes the grid to hold every bound (one cell at the origin when there are none). */
  void sizeGrid(const std::vector<ShapeBounds>& boxes);
  /** @brief The height range of a placed shape: trunks from their buried base, the others by their size. */
  void setHeightRange(ShapeBounds* bounds) const;
  void insert(const Shape& shape, double min_x, double min_y, double max_x, double max_y);

  /** @brief The range at which the ray leaves the ground's extent (at most @p max_range); <= 0 if it starts outside. */
  double clipToExtent(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double max_range) const;
  /** @brief Within @p best, the range up to which the ray can meet a shape (below top_z_); negative for none. */
  double shapeReach(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double best) const;
  /** @brief A new mailbox stamp for the next ray (clearing the mailbox when the stamp wraps). */
  void nextRayId();
  /** @brief Walks the grid cells under the ray's horizontal projection up to @p t_shapes (Amanatides-Woo). */
  void traverseGrid(double t_shapes, RayState* ray);
  /** @brief Tests the shapes of cell (ci, cj) not yet tested by this ray, for the ray's stretch t_in..t_out. */
  void testCell(int ci, int cj, double t_in, double t_out, RayState* ray);
  double intersectShape(const Shape& shape, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_max,
                        core::Random& random) const;
  double intersectGround(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_max) const;
  /** @brief The first crossing of the ray with the relief alone (the ray already sheared by the ground's plane). */
  double intersectRelief(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_max) const;

  ForestWorld world_;
  Ground ground_;
  std::vector<Eigen::Vector3d> trunk_bound_;   ///< (x, y, r^2) of a circle holding each trunk's footprint
  std::vector<double> trunk_base_z_;           ///< ground height under each trunk
  std::vector<Eigen::Vector3d> foliage_center_; ///< absolute centres
  std::vector<Eigen::Vector3d> rock_center_;
  std::vector<Eigen::Vector3d> branch_a_, branch_b_;
  std::vector<double> box_base_z_;              ///< ground height under each box's centre
  std::vector<Eigen::Vector3d> sapling_bound_;  ///< as trunk_bound_, for the saplings
  std::vector<double> sapling_base_z_;          ///< ground height under each sapling
  std::vector<Eigen::Vector3d> stub_a_, stub_b_; ///< the stems' branches' end points, absolute
  std::vector<Shape> shapes_;
  std::vector<std::pair<double, double>> shape_z_;  ///< height range of each shape

  double extent_min_x_ = 0.0, extent_min_y_ = 0.0, extent_max_x_ = 0.0, extent_max_y_ = 0.0;  ///< ground's box
  double top_z_ = -std::numeric_limits<double>::infinity();  ///< highest point of any shape
  double cell_ = 2.0;
  double origin_x_ = 0.0, origin_y_ = 0.0;
  int nx_ = 0, ny_ = 0;
  std::vector<std::vector<int>> cells_;  ///< shape indices per cell
  std::vector<std::uint32_t> mailbox_;   ///< last ray that tested each shape (tests each once per ray)
  std::uint32_t ray_id_ = 0;
};

}  // namespace sim
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_SIM_RAY_CASTER_H
