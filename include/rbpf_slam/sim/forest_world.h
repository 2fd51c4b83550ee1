#ifndef RBPF_SLAM_SIM_FOREST_WORLD_H
#define RBPF_SLAM_SIM_FOREST_WORLD_H

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/filter/random.h"

namespace rbpf_slam
{
namespace sim
{
/** @brief A tree trunk: a (possibly leaning, tapering) solid cone frustum standing on the ground. */
struct TrunkSpec
{
  double x = 0.0;       ///< [m] centre of the trunk where it meets the ground
  double y = 0.0;       ///< [m]
  double radius = 0.2;  ///< [m] radius at the ground (breast-height radius = radius - taper * 1.3)
  double height = 15.0; ///< [m] along the axis
  double lean_x = 0.0;  ///< [-] axis direction (lean_x, lean_y, 1), normalised; 0.05 = 2.9 deg
  double lean_y = 0.0;  ///< [-]
  double taper = 0.0;   ///< [m/m] radius lost per metre along the axis
};

/** @brief A porous sphere of foliage (tree crown or bush): a ray inside it stops after an
 * exponentially distributed free path with the given mean. */
struct FoliageSpec
{
  Eigen::Vector3d center = Eigen::Vector3d::Zero();  ///< [m]; z relative to the ground below it
  double radius = 1.0;                               ///< [m]
  double mean_free_path = 1.0;                       ///< [m]
};

/** @brief A solid sphere (rock), partly buried; center z relative to the ground below it. */
struct RockSpec
{
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double radius = 0.3;
};

/** @brief A fallen branch: a solid cylinder lying on the ground between two end points (x, y). */
struct BranchSpec
{
  Eigen::Vector2d a = Eigen::Vector2d::Zero();
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  double radius = 0.08;  ///< [m]; the axis lies this far above the ground
};

/**
 * @brief A box standing on the ground (a parked car, a container): its base is a rectangle centred at (x, y),
 * length along the heading yaw, width across it; it rises @p height above the ground at its centre (and reaches
 * as far below it as a trunk, so undulating ground leaves no gap under it).
 */
struct BoxSpec
{
  double x = 0.0, y = 0.0;  ///< [m] centre of the base
  double yaw = 0.0;         ///< [rad] direction of the length
  double length = 4.5;      ///< [m]
  double width = 1.8;       ///< [m]
  double height = 1.5;      ///< [m]
};

/** @brief Horizontal distance from @p p to the box's base rectangle (0 inside or on it). */
double boxDistance(const BoxSpec& box, const Eigen::Vector2d& p);
/** @brief Horizontal distance between the segment a-b and the box's base rectangle (0 where they meet). */
double boxSegmentDistance(const BoxSpec& box, const Eigen::Vector2d& a, const Eigen::Vector2d& b);
/** @brief Whether the base rectangles of two boxes overlap or touch (separating axes). */
bool boxesOverlap(const BoxSpec& a, const BoxSpec& b);
/**
 * @brief Range along the ray origin + t dir (unit dir, not necessarily horizontal) to where it enters the box,
 * whose base is at height @p ground_z; +inf if it misses or starts inside (the slab method).
 */
double intersectBox(const BoxSpec& box, double ground_z, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir);

/**
 * @brief Gently undulating ground: h(x, y) = amplitude / K * sum_k sin(k_k . p + phase_k), so that
 * |h| <= amplitude everywhere. Waves are drawn from a seed: K = 3 directions, wavelengths within
 * [0.7, 1.3] x wavelength.
 */
struct GroundSpec
{
  double amplitude = 0.3;    ///< [m] bound of |h|; 0 gives flat ground at z = 0
  double wavelength = 15.0;  ///< [m] mean wavelength of the undulation
  std::uint64_t seed = 1;
  /// [m] the ground (and with it the world) ends this far outside the stand bounds, as Gazebo's finite
  /// floor plane did: a ray that leaves that box without a hit has no return.
  double margin = 20.0;
};

/** @brief Random clutter added between the trunks (a naive extractor takes it for trunks). */
struct ClutterSpec
{
  int bushes = 0;
  int rocks = 0;
  int branches = 0;
  bool crowns = true;              ///< a foliage crown on each trunk
  double crown_base = 5.0;         ///< [m] lowest foliage above ground
  double clearance = 0.8;          ///< [m] clutter keeps at least this from any trunk surface and box
  std::uint64_t seed = 1;
};

/** @brief Everything the ray caster sees. Coordinates are world (stand) coordinates. */
struct ForestWorld
{
  std::vector<TrunkSpec> trunks;
  std::vector<FoliageSpec> foliage;
  std::vector<RockSpec> rocks;
  std::vector<BranchSpec> branches;
  std::vector<BoxSpec> boxes;
  GroundSpec ground;
  double min_x = 0.0, min_y = 0.0, max_x = 30.0, max_y = 30.0;  ///< [m] stand bounds (for clutter)
};

/**
 * @brief The point of @p trunk's axis @p height metres above its foot (the foot at @p ground_z; the axis
 * leans as the trunk does) in world coordinates, and in @p radius the trunk's radius there (taper).
 */
Eigen::Vector3d trunkAxisAt(const TrunkSpec& trunk, double ground_z, double height, double* radius);

/** @brief Adds crowns, bushes, rocks and branches to @p world as @p spec asks (deterministic). */
void addClutter(const ClutterSpec& spec, ForestWorld* world);

/** @brief Ground height model built from a GroundSpec. */
class Ground
{
public:
  explicit Ground(const GroundSpec& spec = GroundSpec());
  double height(double x, double y) const;
  /** @brief (dh/dx, dh/dy). */
  Eigen::Vector2d gradient(double x, double y) const;
  double amplitude() const { return amplitude_; }
  /** @brief Bound of |grad h| (for safe ray marching). */
  double maxSlope() const { return max_slope_; }
  /** @brief Bound of |d2h/ds2| along the horizontal direction (ux, uy) (scales with its squared length). */
  double curvatureBoundAlong(double ux, double uy) const;
  /** @brief height() and gradient() at once (cheaper than both). */
  double heightAndGradient(double x, double y, Eigen::Vector2d* gradient) const;

private:
  double amplitude_ = 0.0;
  double max_slope_ = 0.0;
  Eigen::Vector2d k_[3];
  double phase_[3] = { 0.0, 0.0, 0.0 };
};

}  // namespace sim
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_SIM_FOREST_WORLD_H
