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
 * @brief A branch on a stem: a solid cylinder with round ends (a capsule) from a point on the stem's axis to its tip,
 * so that it leaves the stem's surface. Heights are relative to the ground at the stem's foot, so that the branch
 * moves with its stem whatever the ground does under its tip.
 */
struct StubSpec
{
  Eigen::Vector3d a = Eigen::Vector3d::Zero();     ///< [m] on the stem's axis (x, y in the world)
  Eigen::Vector3d b = Eigen::Vector3d::Zero();     ///< [m] the tip
  Eigen::Vector2d foot = Eigen::Vector2d::Zero();  ///< [m] the stem's foot, whose ground the heights start from
  double radius = 0.01;                            ///< [m]
  bool live = false;  ///< a live branch carries a foliage tuft at its tip (in ForestWorld::foliage)
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
 * @brief Gently undulating ground, on a plane when it slopes: h(x, y) = amplitude / K * sum_k sin(k_k . p + phase_k)
 * + slope . p, the undulation (the relief) bounded by |amplitude|. Waves are drawn from a seed: K = 3 directions,
 * wavelengths within [0.7, 1.3] x wavelength.
 */
struct GroundSpec
{
  double amplitude = 0.3;    ///< [m] bound of the undulation's |h|; 0 gives flat ground (a plane with the slope)
  double wavelength = 15.0;  ///< [m] mean wavelength of the undulation
  std::uint64_t seed = 1;
  /// [-] gradient of a plane added to the undulation, h += slope.x * x + slope.y * y (0.10 = 10 % rising along x;
  /// the plane passes through the world's origin)
  Eigen::Vector2d slope = Eigen::Vector2d::Zero();
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

/** @brief A closed interval [lo, hi] from which a value is drawn uniformly. */
struct Interval
{
  double lo = 0.0;
  double hi = 0.0;
};

/**
 * @brief Branch whorls on every trunk (addWhorls): from the lowest whorl up, every spacing metres, a whorl bears
 * branches with probability fill, per_whorl of them around the stem; a branch is dead (a bare stub) or live (longer,
 * with a foliage tuft at its tip).
 */
struct WhorlSpec
{
  Interval heights{ 1.0, 6.0 };       ///< [m] above the ground at the foot: the first whorl within spacing.lo of lo
  Interval spacing{ 0.5, 1.0 };       ///< [m] between whorls, drawn per whorl
  double fill = 0.7;                  ///< [-] share of whorls that bear branches
  int min_per_whorl = 1;              ///< branches of a whorl that bears them, drawn uniformly
  int max_per_whorl = 4;
  double live = 0.3;                  ///< [-] share of the branches that are live
  Interval dead_length{ 0.2, 1.0 };   ///< [m] beyond the stem's surface
  Interval live_length{ 0.5, 1.5 };   ///< [m] beyond the stem's surface
  Interval thickness{ 0.01, 0.04 };   ///< [m] a branch's diameter
  Interval tuft_radius{ 0.15, 0.4 };  ///< [m] the foliage sphere at a live branch's tip
  std::uint64_t seed = 1;
};

/**
 * @brief The understory (addUnderstory): saplings (thin tapering stems with a bushy crown from low down) and shrubs
 * (foliage spheres on the ground). Neither is a tree of the stand: they go to ForestWorld::saplings and
 * ForestWorld::foliage, never to its trunks.
 */
struct UnderstorySpec
{
  int saplings = 0;
  Interval sapling_dbh{ 0.01, 0.05 };         ///< [m] stem diameter at 1.3 m above the ground
  Interval sapling_height{ 1.5, 4.0 };        ///< [m] above the ground; lo > 1.3
  Interval sapling_crown_base{ 0.5, 2.0 };    ///< [m] lowest foliage above the ground
  Interval sapling_crown_radius{ 0.3, 0.8 };  ///< [m] widest foliage, at the crown's base
  int shrubs = 0;
  Interval shrub_radius{ 0.3, 1.0 };  ///< [m]
  Interval shrub_top{ 0.5, 2.0 };     ///< [m] highest foliage above the ground
  double clearance = 0.3;             ///< [m] from trunk surfaces, boxes, clutter and each other
  std::uint64_t seed = 1;
};

/**
 * @brief A track through the stand: the routes a robot drives (polylines in world coordinates), kept clear of what the
 * path follower would steer around: bushes and rocks (addClutter), saplings and shrubs (addUnderstory) and the
 * branches on the stems lower than the headroom (addWhorls). Fallen branches lie below the follower's obstacle band
 * and may cross it; trunks stand where their tree list puts them. The sensors do not see the track.
 */
struct TrackSpec
{
  std::vector<std::vector<Eigen::Vector2d>> routes;  ///< [m] world coordinates; none: no track
  double clearance = 2.0;                            ///< [m] from every route to the footprint of each item
  double headroom = 3.0;  ///< [m] above the ground: a stem's branch wholly above it may reach over the track
};

/** @brief Horizontal distance from the circle of @p radius about @p center to the nearest route (+inf without). */
double trackDistance(const TrackSpec& track, const Eigen::Vector2d& center, double radius);

/** @brief Everything the ray caster sees. Coordinates are world (stand) coordinates. */
struct ForestWorld
{
  std::vector<TrunkSpec> trunks;
  std::vector<FoliageSpec> foliage;
  std::vector<RockSpec> rocks;
  std::vector<BranchSpec> branches;
  std::vector<BoxSpec> boxes;
  std::vector<StubSpec> stubs;        ///< branches on the trunks (their live tufts are in foliage)
  std::vector<TrunkSpec> saplings;    ///< understory stems (their crowns are in foliage); not trees of the stand
  GroundSpec ground;
  double min_x = 0.0, min_y = 0.0, max_x = 30.0, max_y = 30.0;  ///< [m] stand bounds (for clutter)
  TrackSpec track;  ///< routes that clutter and understory keep off (not seen by the sensors)
};

/**
 * @brief The point of @p trunk's axis @p height metres above its foot (the foot at @p ground_z; the axis
 * leans as the trunk does) in world coordinates, and in @p radius the trunk's radius there (taper).
 */
Eigen::Vector3d trunkAxisAt(const TrunkSpec& trunk, double ground_z, double height, double* radius);

/**
 * @brief Adds crowns, bushes, rocks and branches to @p world as @p spec asks (deterministic). Bushes and rocks keep
 * world->track.clearance from the routes of world->track (fallen branches may cross them).
 */
void addClutter(const ClutterSpec& spec, ForestWorld* world);

/**
 * @brief Adds branch whorls to every trunk of @p world as @p spec asks (deterministic for spec.seed): StubSpecs,
 * and a foliage tuft at the tip of each live branch. Whorls stop below a trunk's top. A branch (with its tuft) that
 * would come within world->track.clearance of a route of world->track lower than its headroom is left out; the
 * others are drawn as without a track.
 * @throws std::invalid_argument for a spec out of range (intervals with lo > hi, negative sizes, shares outside
 * [0, 1], spacing.lo <= 0)
 */
void addWhorls(const WhorlSpec& spec, ForestWorld* world);

/**
 * @brief Adds saplings and shrubs to @p world as @p spec asks (deterministic for spec.seed), placed at random inside
 * the stand bounds, at least spec.clearance from trunk surfaces, boxes, ground clutter (bushes, rocks, fallen
 * branches) and each other, and at least world->track.clearance from the routes of world->track; an item that does
 * not fit after a bounded number of tries is left out, as in addClutter.
 * A sapling is a cone-shaped stem (its radius reaches 0 at its top) leaning up to 4 degrees, with a conical crown of
 * stacked foliage spheres from its crown base to its top; a shrub is one foliage sphere whose top is drawn from
 * spec.shrub_top (a low, wide shrub is partly below the ground).
 * @throws std::invalid_argument for a spec out of range
 */
void addUnderstory(const UnderstorySpec& spec, ForestWorld* world);

/** @brief Ground height model built from a GroundSpec. */
class Ground
{
public:
  explicit Ground(const GroundSpec& spec = GroundSpec());
  double height(double x, double y) const;
  /** @brief (dh/dx, dh/dy). */
  Eigen::Vector2d gradient(double x, double y) const;
  /** @brief Bound of the relief's |h| (the undulation without the plane). */
  double amplitude() const { return amplitude_; }
  /** @brief Bound of |grad h|, the relief's and the plane's together (for safe ray marching). */
  double maxSlope() const { return max_slope_; }
  /** @brief Bound of |d2h/ds2| along the horizontal direction (ux, uy) (scales with its squared length). */
  double curvatureBoundAlong(double ux, double uy) const;
  /** @brief height() and gradient() at once (cheaper than both). */
  double heightAndGradient(double x, double y, Eigen::Vector2d* gradient) const;
  /** @brief The plane's gradient (zero for ground without a slope). */
  const Eigen::Vector2d& slope() const { return slope_; }
  /** @brief The relief: the height without the plane (height() - slope . p). */
  double relief(double x, double y) const;
  /** @brief relief() and its gradient at once. */
  double reliefAndGradient(double x, double y, Eigen::Vector2d* gradient) const;

private:
  double amplitude_ = 0.0;
  double max_slope_ = 0.0;
  Eigen::Vector2d slope_ = Eigen::Vector2d::Zero();
  bool sloped_ = false;
  Eigen::Vector2d k_[3];
  double phase_[3] = { 0.0, 0.0, 0.0 };
};

}  // namespace sim
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_SIM_FOREST_WORLD_H
