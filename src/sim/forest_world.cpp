#include "rbpf_slam/sim/forest_world.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace rbpf_slam
{
namespace sim
{
using core::Random;

namespace
{
constexpr double kPi = 3.14159265358979323846;
constexpr int kWaves = 3;
constexpr double kMinWavelengthFactor = 0.7;
constexpr double kMaxWavelengthFactor = 1.3;

// Crowns: a radius of a quarter of the tree height, as for a pine, bounded so that neither a sapling
// nor a tall tree gets an absurd crown.
constexpr double kCrownRadiusPerHeight = 0.25;
constexpr double kMinCrownRadius = 1.5;
constexpr double kMaxCrownRadius = 4.0;
constexpr double kCrownMeanFreePath = 0.6;

constexpr double kMinBushRadius = 0.3;
constexpr double kMaxBushRadius = 0.8;
constexpr double kBushCenterHeight = 0.7;  // [radius] centre above ground: the bush sits on the ground
constexpr double kBushMeanFreePath = 0.3;

constexpr double kMinRockRadius = 0.15;
constexpr double kMaxRockRadius = 0.5;
constexpr double kRockCenterHeight = 0.3;  // [radius] centre above ground: the rock is partly buried

constexpr double kMinBranchLength = 1.0;
constexpr double kMaxBranchLength = 4.0;
constexpr double kMinBranchRadius = 0.04;
constexpr double kMaxBranchRadius = 0.12;

// Rejection sampling must end in a stand too dense for what is asked: an item is given up after
// kMaxAttempts positions, and the rest of its kind after kMaxConsecutiveFailures items in a row were
// given up (the stand is full, so asking for a million bushes costs no more than asking for a few).
// Giving up is silent: the caller sees it in the sizes of the world's vectors.
constexpr int kMaxAttempts = 200;
constexpr int kMaxConsecutiveFailures = 20;

// Foliage that the caller put into the world before whose lowest point is below this height is a
// ground obstacle (a bush) that new clutter keeps clear of; crowns are above it. A bush made here
// reaches at most (1 + 0.7) * 0.8 = 1.36 m.
constexpr double kGroundLayerTop = 1.5;

/** A horizontal footprint: the set of points within radius of the segment a-b (a circle when a == b). */
struct Footprint
{
  Eigen::Vector2d a;
  Eigen::Vector2d b;
  double radius;
};

double cross(const Eigen::Vector2d& u, const Eigen::Vector2d& v)
{
  return u.x() * v.y() - u.y() * v.x();
}

double pointSegmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b)
{
  const Eigen::Vector2d ab = b - a;
  const double length_sq = ab.squaredNorm();
  const double t = length_sq > 0.0 ? std::max(0.0, std::min(1.0, (p - a).dot(ab) / length_sq)) : 0.0;
  return (p - (a + t * ab)).norm();
}

double segmentDistance(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                       const Eigen::Vector2d& d)
{
  const double d1 = cross(d - c, a - c);
  const double d2 = cross(d - c, b - c);
  const double d3 = cross(b - a, c - a);
  const double d4 = cross(b - a, d - a);
  // Proper crossing; touching and collinear cases give 0 through the end-point distances below.
  if (((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0)))
    return 0.0;
  return std::min(std::min(pointSegmentDistance(a, c, d), pointSegmentDistance(b, c, d)),
                  std::min(pointSegmentDistance(c, a, b), pointSegmentDistance(d, a, b)));
}

/** Free distance between the edges of two footprints (negative when they overlap). */
double gap(const Footprint& f, const Footprint& g)
{
  return segmentDistance(f.a, f.b, g.a, g.b) - f.radius - g.radius;
}

/** Free distance between the edge of footprint @p f and the nearest route of @p track (+inf without routes). */
double trackGap(const TrackSpec& track, const Footprint& f)
{
  double best = std::numeric_limits<double>::infinity();
  for (const std::vector<Eigen::Vector2d>& route : track.routes)
  {
    if (route.size() == 1)
      best = std::min(best, segmentDistance(f.a, f.b, route[0], route[0]));
    for (std::size_t i = 1; i < route.size(); ++i)
      best = std::min(best, segmentDistance(f.a, f.b, route[i - 1], route[i]));
  }
  return best - f.radius;
}

/**
 * What a trunk occupies between the ground and @p top [m above ground]: its axis leans, so over that
 * height it sweeps a segment; the widest radius over the height stands for all of it.
 */
Footprint trunkFootprint(const TrunkSpec& trunk, double top)
{
  const double axis_norm = std::sqrt(1.0 + trunk.lean_x * trunk.lean_x + trunk.lean_y * trunk.lean_y);
  const double z = std::min(top, trunk.height / axis_norm);
  const double radius_at_z = trunk.radius - trunk.taper * z * axis_norm;
  Footprint f;
  f.a = Eigen::Vector2d(trunk.x, trunk.y);
  f.b = Eigen::Vector2d(trunk.x + trunk.lean_x * z, trunk.y + trunk.lean_y * z);
  f.radius = std::max(trunk.radius, radius_at_z);
  return f;
}

/** Places ground clutter by rejection sampling against the trunks, the bounds and what is placed so far. */
class ClutterPlacer
{
public:
  ClutterPlacer(double clearance, std::uint64_t seed, const ForestWorld& world)
    : clearance_(clearance), world_(world), random_(seed)
  {
    for (const FoliageSpec& f : world.foliage)
    {
      if (f.center.z() - f.radius < kGroundLayerTop)
        placed_.push_back(circle(f.center.x(), f.center.y(), f.radius));
    }
    for (const RockSpec& r : world.rocks)
      placed_.push_back(circle(r.center.x(), r.center.y(), r.radius));
    for (const BranchSpec& b : world.branches)
      placed_.push_back(Footprint{ b.a, b.b, b.radius });
  }

  Random& random() { return random_; }

  /**
   * Calls @p draw_position (which draws a footprint) up to kMaxAttempts times until the footprint fits;
   * returns false when the item is given up. @p top is the item's height above ground; with @p off_track the item
   * also keeps the track's clearance from its routes.
   */
  template <typename DrawPosition>
  bool place(double top, DrawPosition draw_position, Footprint* result, bool off_track = true)
  {
    for (int attempt = 0; attempt < kMaxAttempts; ++attempt)
    {
      const Footprint f = draw_position();
      if (fits(f, top) && (!off_track || trackGap(world_.track, f) >= world_.track.clearance))
      {
        placed_.push_back(f);
        *result = f;
        return true;
      }
    }
    return false;
  }

  Eigen::Vector2d uniformPoint()
  {
    const double x = random_.uniform(world_.min_x, world_.max_x);
    const double y = random_.uniform(world_.min_y, world_.max_y);
    return Eigen::Vector2d(x, y);
  }

  static Footprint circle(double x, double y, double radius)
  {
    const Eigen::Vector2d c(x, y);
    return Footprint{ c, c, radius };
  }

private:
  bool inside(const Eigen::Vector2d& p, double radius) const
  {
    return p.x() - radius >= world_.min_x && p.x() + radius <= world_.max_x && p.y() - radius >= world_.min_y &&
           p.y() + radius <= world_.max_y;
  }

  bool fits(const Footprint& f, double top) const
  {
    if (!inside(f.a, f.radius) || !inside(f.b, f.radius))
      return false;
    for (const TrunkSpec& trunk : world_.trunks)
    {
      if (gap(f, trunkFootprint(trunk, top)) < clearance_)
        return false;
    }
    for (const BoxSpec& box : world_.boxes)
    {
      if (boxSegmentDistance(box, f.a, f.b) - f.radius < clearance_)
        return false;
    }
    for (const Footprint& g : placed_)
    {
      if (gap(f, g) < clearance_)
        return false;
    }
    return true;
  }

  double clearance_;
  const ForestWorld& world_;
  Random random_;
  std::vector<Footprint> placed_;
};

void checkTrack(const TrackSpec& track, const std::string& who)
{
  if (!std::isfinite(track.clearance) || track.clearance < 0.0 || !std::isfinite(track.headroom))
    throw std::invalid_argument(who + ": the track's clearance must be finite and >= 0, its headroom finite");
  for (const std::vector<Eigen::Vector2d>& route : track.routes)
    for (const Eigen::Vector2d& p : route)
      if (!p.allFinite())
        throw std::invalid_argument(who + ": the track's routes must be finite");
}

void checkSpec(const ClutterSpec& spec, const ForestWorld* world)
{
  if (!world)
    throw std::invalid_argument("addClutter: world is null");
  if (spec.bushes < 0 || spec.rocks < 0 || spec.branches < 0)
    throw std::invalid_argument("addClutter: bushes, rocks and branches must be >= 0");
  if (!std::isfinite(spec.clearance) || spec.clearance < 0.0)
    throw std::invalid_argument("addClutter: clearance must be finite and >= 0");
  if (!std::isfinite(spec.crown_base))
    throw std::invalid_argument("addClutter: crown_base must be finite");
  if (!(world->min_x < world->max_x) || !(world->min_y < world->max_y))
    throw std::invalid_argument("addClutter: world bounds must have min < max");
  checkTrack(world->track, "addClutter");
}

void addCrowns(const ClutterSpec& spec, ForestWorld* world)
{
  std::vector<FoliageSpec> crowns;
  crowns.reserve(world->trunks.size());
  for (const TrunkSpec& trunk : world->trunks)
  {
    const double axis_norm = std::sqrt(1.0 + trunk.lean_x * trunk.lean_x + trunk.lean_y * trunk.lean_y);
    const double top = trunk.height / axis_norm;
    FoliageSpec crown;
    crown.radius = std::max(kMinCrownRadius, std::min(kMaxCrownRadius, kCrownRadiusPerHeight * trunk.height));
    crown.mean_free_path = kCrownMeanFreePath;
    // A crown must touch its trunk: on a tree shorter than crown_base + radius it is centred on the
    // trunk top and reaches below crown_base.
    const double z = std::min(spec.crown_base + crown.radius, top);
    // Centred above the trunk top, so that a leaning tree carries its crown with it.
    crown.center = Eigen::Vector3d(trunk.x + trunk.lean_x * top, trunk.y + trunk.lean_y * top, z);
    crowns.push_back(crown);
  }
  world->foliage.insert(world->foliage.end(), crowns.begin(), crowns.end());
}
}  // namespace

namespace
{
/**
 * sin(x) to within 1e-9 for any finite x: reduced to [-pi/2, pi/2] and a degree-13 Taylor polynomial.
 * The ground is defined with it (height and gradient alike), so it is exact for the simulator; it is about
 * three times cheaper than std::sin, and the ground is evaluated several times per lidar ray.
 */
inline double groundSin(double x)
{
  constexpr double kTwoPi = 6.283185307179586;
  constexpr double kPiHalf = 1.5707963267948966;
  double r = x - kTwoPi * std::nearbyint(x / kTwoPi);  // [-pi, pi]
  if (r > kPiHalf)
    r = 3.141592653589793 - r;
  else if (r < -kPiHalf)
    r = -3.141592653589793 - r;
  const double r2 = r * r;
  return r * (1.0 + r2 * (-1.0 / 6 + r2 * (1.0 / 120 + r2 * (-1.0 / 5040 + r2 * (1.0 / 362880 + r2 * (-1.0 / 39916800 + r2 * (1.0 / 6227020800)))))));
}

inline double groundCos(double x)
{
  return groundSin(x + 1.5707963267948966);
}
}  // namespace

namespace
{
/** @p p in the box's frame (x along its length), relative to its centre. */
Eigen::Vector2d boxLocal(const BoxSpec& box, const Eigen::Vector2d& p)
{
  const double c = std::cos(box.yaw), s = std::sin(box.yaw);
  const Eigen::Vector2d w = p - Eigen::Vector2d(box.x, box.y);
  return Eigen::Vector2d(c * w.x() + s * w.y(), -s * w.x() + c * w.y());
}

std::vector<Eigen::Vector2d> boxCorners(const BoxSpec& box)
{
  const double c = std::cos(box.yaw), s = std::sin(box.yaw);
  const Eigen::Vector2d u(c, s), v(-s, c), o(box.x, box.y);
  const double hl = 0.5 * box.length, hw = 0.5 * box.width;
  return { o + hl * u + hw * v, o - hl * u + hw * v, o - hl * u - hw * v, o + hl * u - hw * v };
}
}  // namespace

double trackDistance(const TrackSpec& track, const Eigen::Vector2d& center, double radius)
{
  return trackGap(track, Footprint{ center, center, radius });
}

double boxDistance(const BoxSpec& box, const Eigen::Vector2d& p)
{
  const Eigen::Vector2d l = boxLocal(box, p);
  const double dx = std::max(0.0, std::abs(l.x()) - 0.5 * box.length);
  const double dy = std::max(0.0, std::abs(l.y()) - 0.5 * box.width);
  return std::hypot(dx, dy);
}

double boxSegmentDistance(const BoxSpec& box, const Eigen::Vector2d& a, const Eigen::Vector2d& b)
{
  if (boxDistance(box, a) == 0.0 || boxDistance(box, b) == 0.0)
    return 0.0;
  // Both ends outside: the segment meets the rectangle iff it crosses an edge; otherwise the nearest points are an
  // end of the segment or a corner of the rectangle.
  const std::vector<Eigen::Vector2d> corners = boxCorners(box);
  double best = std::min(boxDistance(box, a), boxDistance(box, b));
  for (std::size_t i = 0; i < corners.size(); ++i)
    best = std::min(best, segmentDistance(a, b, corners[i], corners[(i + 1) % corners.size()]));
  return best;
}

bool boxesOverlap(const BoxSpec& a, const BoxSpec& b)
{
  const std::vector<Eigen::Vector2d> ca = boxCorners(a), cb = boxCorners(b);
  for (const BoxSpec* box : { &a, &b })
  {
    for (int k = 0; k < 2; ++k)
    {
      const double angle = box->yaw + k * 0.5 * kPi;
      const Eigen::Vector2d axis(std::cos(angle), std::sin(angle));
      double min_a = axis.dot(ca[0]), max_a = min_a, min_b = axis.dot(cb[0]), max_b = min_b;
      for (int i = 1; i < 4; ++i)
      {
        min_a = std::min(min_a, axis.dot(ca[i]));
        max_a = std::max(max_a, axis.dot(ca[i]));
        min_b = std::min(min_b, axis.dot(cb[i]));
        max_b = std::max(max_b, axis.dot(cb[i]));
      }
      if (max_a < min_b || max_b < min_a)
        return false;
    }
  }
  return true;
}

double intersectBox(const BoxSpec& box, double ground_z, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir)
{
  constexpr double kInf = std::numeric_limits<double>::infinity();
  constexpr double kBuried = 0.5;  // [m] as the trunks: no gap under the box on undulating ground
  const Eigen::Vector2d lo = boxLocal(box, origin.head<2>());
  const double c = std::cos(box.yaw), s = std::sin(box.yaw);
  const double local_o[3] = { lo.x(), lo.y(), origin.z() - ground_z };
  const double local_d[3] = { c * dir.x() + s * dir.y(), -s * dir.x() + c * dir.y(), dir.z() };
  const double low[3] = { -0.5 * box.length, -0.5 * box.width, -kBuried };
  const double high[3] = { 0.5 * box.length, 0.5 * box.width, box.height };
  double t0 = 0.0, t1 = kInf;
  for (int k = 0; k < 3; ++k)
  {
    if (std::abs(local_d[k]) < 1e-12)
    {
      if (local_o[k] < low[k] || local_o[k] > high[k])
        return kInf;
      continue;
    }
    double ta = (low[k] - local_o[k]) / local_d[k], tb = (high[k] - local_o[k]) / local_d[k];
    if (ta > tb)
      std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (t0 > t1)
    return kInf;
  return t0 > 0.0 ? t0 : kInf;
}

Ground::Ground(const GroundSpec& spec)
{
  if (!std::isfinite(spec.amplitude) || spec.amplitude < 0.0)
    throw std::invalid_argument("Ground: amplitude must be finite and >= 0");
  if (!std::isfinite(spec.slope.x()) || !std::isfinite(spec.slope.y()))
    throw std::invalid_argument("Ground: slope must be finite");
  for (int i = 0; i < kWaves; ++i)
    k_[i] = Eigen::Vector2d::Zero();
  // Without a slope the plane is left out of every sum, so that such ground is bit for bit what it was before
  // grounds could slope.
  slope_ = spec.slope;
  sloped_ = slope_.x() != 0.0 || slope_.y() != 0.0;
  max_slope_ = slope_.norm();
  // Flat relief is exactly 0 (no waves drawn), whatever the wavelength says.
  if (spec.amplitude == 0.0)
    return;
  if (!std::isfinite(spec.wavelength) || spec.wavelength <= 0.0)
    throw std::invalid_argument("Ground: wavelength must be finite and > 0");
  amplitude_ = spec.amplitude;
  Random random(spec.seed);
  double sum_k = 0.0;
  for (int i = 0; i < kWaves; ++i)
  {
    const double direction = random.uniform(0.0, 2.0 * kPi);
    const double wavelength = random.uniform(kMinWavelengthFactor, kMaxWavelengthFactor) * spec.wavelength;
    phase_[i] = random.uniform(0.0, 2.0 * kPi);
    const double k = 2.0 * kPi / wavelength;
    k_[i] = Eigen::Vector2d(k * std::cos(direction), k * std::sin(direction));
    sum_k += k;
  }
  // The relief's bound, and the plane's gradient on top (the bound of a sum of gradients).
  max_slope_ = sloped_ ? amplitude_ / kWaves * sum_k + slope_.norm() : amplitude_ / kWaves * sum_k;
}

double Ground::height(double x, double y) const
{
  const double h = relief(x, y);
  return sloped_ ? h + slope_.x() * x + slope_.y() * y : h;
}

double Ground::relief(double x, double y) const
{
  if (amplitude_ == 0.0)
    return 0.0;
  double sum = 0.0;
  for (int i = 0; i < kWaves; ++i)
    sum += groundSin(k_[i].x() * x + k_[i].y() * y + phase_[i]);
  return amplitude_ / kWaves * sum;
}

double Ground::curvatureBoundAlong(double ux, double uy) const
{
  double sum = 0.0;
  for (int i = 0; i < kWaves; ++i)
  {
    const double ku = k_[i].x() * ux + k_[i].y() * uy;
    sum += ku * ku;
  }
  return amplitude_ / kWaves * sum;
}

double Ground::heightAndGradient(double x, double y, Eigen::Vector2d* gradient) const
{
  const double h = reliefAndGradient(x, y, gradient);
  if (!sloped_)
    return h;
  *gradient += slope_;
  return h + slope_.x() * x + slope_.y() * y;
}

double Ground::reliefAndGradient(double x, double y, Eigen::Vector2d* gradient) const
{
  gradient->setZero();
  if (amplitude_ == 0.0)
    return 0.0;
  double sum = 0.0;
  for (int i = 0; i < kWaves; ++i)
  {
    const double arg = k_[i].x() * x + k_[i].y() * y + phase_[i];
    sum += groundSin(arg);
    *gradient += groundCos(arg) * k_[i];
  }
  *gradient *= amplitude_ / kWaves;
  return amplitude_ / kWaves * sum;
}

Eigen::Vector2d Ground::gradient(double x, double y) const
{
  Eigen::Vector2d g = Eigen::Vector2d::Zero();
  if (amplitude_ != 0.0)
  {
    for (int i = 0; i < kWaves; ++i)
      g += groundCos(k_[i].x() * x + k_[i].y() * y + phase_[i]) * k_[i];
    g = amplitude_ / kWaves * g;
  }
  return sloped_ ? Eigen::Vector2d(g + slope_) : g;
}

Eigen::Vector3d trunkAxisAt(const TrunkSpec& t, double ground_z, double height, double* radius)
{
  const Eigen::Vector3d axis = Eigen::Vector3d(t.lean_x, t.lean_y, 1.0).normalized();
  const double s = height / axis.z();  // distance along the axis
  if (radius)
    *radius = std::max(0.0, t.radius - t.taper * s);
  return Eigen::Vector3d(t.x, t.y, ground_z) + s * axis;
}

void addClutter(const ClutterSpec& spec, ForestWorld* world)
{
  checkSpec(spec, world);
  // Ground clutter keeps clear of foliage already in the world, not of the crowns made here.
  ClutterPlacer placer(spec.clearance, spec.seed, *world);
  if (spec.crowns)
    addCrowns(spec, world);
  Random& random = placer.random();

  // Up to `count` objects of one kind: each attempt either places one (true) or finds no room (false);
  // the kind is given up after kMaxConsecutiveFailures attempts in a row find no room.
  const auto placeSeveral = [](int count, const auto& attempt) {
    int failures = 0;
    for (int i = 0; i < count && failures < kMaxConsecutiveFailures; ++i)
      failures = attempt() ? 0 : failures + 1;
  };
  const auto roundFootprint = [&](double radius) {
    return [&placer, radius]() {
      const Eigen::Vector2d p = placer.uniformPoint();
      return ClutterPlacer::circle(p.x(), p.y(), radius);
    };
  };

  // Largest footprints first (as in bin packing), so that in a crowded stand the long branches still
  // find room and the small rocks fill what is left.
  placeSeveral(spec.branches, [&]() {
    const double length = random.uniform(kMinBranchLength, kMaxBranchLength);
    const double radius = random.uniform(kMinBranchRadius, kMaxBranchRadius);
    const auto draw = [&]() {
      const Eigen::Vector2d mid = placer.uniformPoint();
      const double direction = random.uniform(0.0, kPi);  // a segment has no heading: half a turn suffices
      const Eigen::Vector2d half = 0.5 * length * Eigen::Vector2d(std::cos(direction), std::sin(direction));
      return Footprint{ mid - half, mid + half, radius };
    };
    Footprint f;
    if (!placer.place(2.0 * radius, draw, &f, false))  // fallen wood may lie across a track: it is driven over
      return false;
    BranchSpec branch;
    branch.a = f.a;
    branch.b = f.b;
    branch.radius = radius;
    world->branches.push_back(branch);
    return true;
  });

  placeSeveral(spec.bushes, [&]() {
    const double radius = random.uniform(kMinBushRadius, kMaxBushRadius);
    Footprint f;
    if (!placer.place((1.0 + kBushCenterHeight) * radius, roundFootprint(radius), &f))
      return false;
    FoliageSpec bush;
    bush.center = Eigen::Vector3d(f.a.x(), f.a.y(), kBushCenterHeight * radius);
    bush.radius = radius;
    bush.mean_free_path = kBushMeanFreePath;
    world->foliage.push_back(bush);
    return true;
  });

  placeSeveral(spec.rocks, [&]() {
    const double radius = random.uniform(kMinRockRadius, kMaxRockRadius);
    Footprint f;
    if (!placer.place((1.0 + kRockCenterHeight) * radius, roundFootprint(radius), &f))
      return false;
    RockSpec rock;
    rock.center = Eigen::Vector3d(f.a.x(), f.a.y(), kRockCenterHeight * radius);
    rock.radius = radius;
    world->rocks.push_back(rock);
    return true;
  });
}

namespace
{
// Branches leave the stem between a little below and a little above the horizontal; a live branch's tuft sits at
// its tip. Foliage of the understory is as dense as a bush's.
constexpr double kMinBranchElevation = -20.0 * kPi / 180.0;
constexpr double kMaxBranchElevation = 20.0 * kPi / 180.0;
constexpr double kWhorlAzimuthJitter = 0.4;  // [rad] around the even spacing of a whorl's branches
constexpr double kTuftMeanFreePath = 0.3;
constexpr double kUnderstoryMeanFreePath = 0.3;
constexpr double kBreastHeight = 1.3;               // [m] where a sapling's diameter is given
constexpr double kMaxSaplingLean = 4.0 * kPi / 180.0;
constexpr double kMinCrownSphere = 0.15;            // [m] the smallest foliage sphere of a sapling's crown
constexpr int kMaxCrownSpheres = 6;

void checkInterval(const Interval& v, const char* what, double min, bool inclusive)
{
  const bool low_ok = inclusive ? v.lo >= min : v.lo > min;
  if (!std::isfinite(v.lo) || !std::isfinite(v.hi) || !low_ok || v.lo > v.hi)
    throw std::invalid_argument(std::string(what) + ": need " + (inclusive ? "" : "0 < ") + "lo <= hi" +
                                (inclusive ? ", lo >= 0" : "") + ", both finite");
}

void checkShare(double v, const char* what)
{
  if (!(v >= 0.0 && v <= 1.0))
    throw std::invalid_argument(std::string(what) + " must be within [0, 1]");
}

void checkSpec(const WhorlSpec& spec, const ForestWorld* world)
{
  if (!world)
    throw std::invalid_argument("addWhorls: world is null");
  checkTrack(world->track, "addWhorls");
  checkInterval(spec.heights, "addWhorls: heights", 0.0, true);
  checkInterval(spec.spacing, "addWhorls: spacing", 0.0, false);
  checkInterval(spec.dead_length, "addWhorls: dead_length", 0.0, true);
  checkInterval(spec.live_length, "addWhorls: live_length", 0.0, true);
  checkInterval(spec.thickness, "addWhorls: thickness", 0.0, false);
  checkInterval(spec.tuft_radius, "addWhorls: tuft_radius", 0.0, false);
  checkShare(spec.fill, "addWhorls: fill");
  checkShare(spec.live, "addWhorls: live");
  if (spec.min_per_whorl < 1 || spec.min_per_whorl > spec.max_per_whorl || spec.max_per_whorl > 32)
    throw std::invalid_argument("addWhorls: need 1 <= min_per_whorl <= max_per_whorl <= 32");
}

void checkSpec(const UnderstorySpec& spec, const ForestWorld* world)
{
  if (!world)
    throw std::invalid_argument("addUnderstory: world is null");
  if (spec.saplings < 0 || spec.shrubs < 0)
    throw std::invalid_argument("addUnderstory: saplings and shrubs must be >= 0");
  checkInterval(spec.sapling_dbh, "addUnderstory: sapling_dbh", 0.0, false);
  checkInterval(spec.sapling_height, "addUnderstory: sapling_height", kBreastHeight, false);
  checkInterval(spec.sapling_crown_base, "addUnderstory: sapling_crown_base", 0.0, true);
  checkInterval(spec.sapling_crown_radius, "addUnderstory: sapling_crown_radius", 0.0, false);
  checkInterval(spec.shrub_radius, "addUnderstory: shrub_radius", 0.0, false);
  checkInterval(spec.shrub_top, "addUnderstory: shrub_top", 0.0, false);
  if (!std::isfinite(spec.clearance) || spec.clearance < 0.0)
    throw std::invalid_argument("addUnderstory: clearance must be finite and >= 0");
  if (!(world->min_x < world->max_x) || !(world->min_y < world->max_y))
    throw std::invalid_argument("addUnderstory: world bounds must have min < max");
  checkTrack(world->track, "addUnderstory");
}

double draw(Random* random, const Interval& v)
{
  return random->uniform(v.lo, v.hi);
}

/** Foliage whose centre is @p p, p.z above the ground at @p foot: its centre height made relative to the ground
 * below it, as FoliageSpec has it. */
FoliageSpec foliageAt(const Ground& ground, const Eigen::Vector2d& foot, const Eigen::Vector3d& p, double radius,
                      double mean_free_path)
{
  FoliageSpec f;
  f.center = Eigen::Vector3d(p.x(), p.y(), p.z() + ground.height(foot.x(), foot.y()) - ground.height(p.x(), p.y()));
  f.radius = radius;
  f.mean_free_path = mean_free_path;
  return f;
}

/**
 * Whether a branch on a stem reaches into the track: some of it (from the bark, @p to_bark from its point on the
 * axis, to its tip, and its tuft of radius @p tuft) is lower than the track's headroom and within its clearance of a
 * route. Such a branch is not grown (the machines that keep the track open break it off).
 */
bool intoTrack(const TrackSpec& track, const StubSpec& stub, const Eigen::Vector2d& to_bark, double tuft)
{
  if (track.routes.empty())
    return false;
  const double reach = std::max(stub.radius, tuft);
  if (std::min(stub.a.z(), stub.b.z()) - reach >= track.headroom)
    return false;
  const Eigen::Vector2d bark = stub.a.head<2>() + to_bark;
  return trackGap(track, Footprint{ bark, stub.b.head<2>(), reach }) < track.clearance;
}

/** One whorl at @p height above the foot of @p trunk: its branches, and the tufts of the live ones. */
void addWhorl(const WhorlSpec& spec, const TrunkSpec& trunk, double height, const Ground& ground, Random* random,
              ForestWorld* world)
{
  const int count = spec.min_per_whorl +
                    static_cast<int>(random->uniformIndex(static_cast<std::uint64_t>(spec.max_per_whorl -
                                                                                     spec.min_per_whorl + 1)));
  const double azimuth0 = random->uniform(0.0, 2.0 * kPi);
  double stem_radius = 0.0;
  const Eigen::Vector3d on_axis = trunkAxisAt(trunk, 0.0, height, &stem_radius);
  const Eigen::Vector2d foot(trunk.x, trunk.y);
  for (int i = 0; i < count; ++i)
  {
    const double azimuth =
        azimuth0 + 2.0 * kPi * i / count + random->uniform(-kWhorlAzimuthJitter, kWhorlAzimuthJitter);
    const double elevation = random->uniform(kMinBranchElevation, kMaxBranchElevation);
    const bool live = random->uniform() < spec.live;
    const double length = draw(random, live ? spec.live_length : spec.dead_length);
    const Eigen::Vector3d dir(std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                              std::sin(elevation));
    StubSpec stub;
    stub.a = on_axis;
    stub.b = on_axis + (stem_radius + length) * dir;
    stub.foot = foot;
    stub.radius = 0.5 * draw(random, spec.thickness);
    stub.live = live;
    const double tuft = live ? draw(random, spec.tuft_radius) : 0.0;
    // Drawn in full either way, so that a track changes no other branch.
    if (intoTrack(world->track, stub, stem_radius * dir.head<2>(), tuft))
      continue;
    world->stubs.push_back(stub);
    if (live)
      world->foliage.push_back(foliageAt(ground, foot, stub.b, tuft, kTuftMeanFreePath));
  }
}

/** A sapling's crown: foliage spheres stacked up its axis from the crown base to its top, narrowing as a cone. */
void addSaplingCrown(const TrunkSpec& stem, double base, double radius, const Ground& ground, ForestWorld* world)
{
  const double axis_norm = std::sqrt(1.0 + stem.lean_x * stem.lean_x + stem.lean_y * stem.lean_y);
  const double top = stem.height / axis_norm;
  const Eigen::Vector2d foot(stem.x, stem.y);
  double bottom = base;  // of the next sphere, above the ground at the foot
  for (int k = 0; k < kMaxCrownSpheres && top - bottom > 2.0 * 0.05; ++k)
  {
    const double r = std::min(std::max(kMinCrownSphere, radius * (top - bottom) / (top - base)), 0.5 * (top - bottom));
    const Eigen::Vector3d center = trunkAxisAt(stem, 0.0, bottom + r, nullptr);
    world->foliage.push_back(foliageAt(ground, foot, center, r, kUnderstoryMeanFreePath));
    bottom += r;  // the next sphere starts at this one's centre
  }
}
}  // namespace

void addWhorls(const WhorlSpec& spec, ForestWorld* world)
{
  checkSpec(spec, world);
  const Ground ground(world->ground);
  Random random(spec.seed);
  for (const TrunkSpec& trunk : world->trunks)
  {
    const double axis_norm = std::sqrt(1.0 + trunk.lean_x * trunk.lean_x + trunk.lean_y * trunk.lean_y);
    const double top = trunk.height / axis_norm;
    for (double h = spec.heights.lo + random.uniform(0.0, spec.spacing.lo); h <= spec.heights.hi && h < top;
         h += draw(&random, spec.spacing))
    {
      double radius = 0.0;
      trunkAxisAt(trunk, 0.0, h, &radius);
      // A whorl bears branches only where the stem still has a radius (a thin trunk ends in a point).
      if (random.uniform() < spec.fill && radius > 0.0)
        addWhorl(spec, trunk, h, ground, &random, world);
    }
  }
}

void addUnderstory(const UnderstorySpec& spec, ForestWorld* world)
{
  checkSpec(spec, world);
  const Ground ground(world->ground);
  ClutterPlacer placer(spec.clearance, spec.seed, *world);
  Random& random = placer.random();
  const auto placeSeveral = [](int count, const auto& attempt) {
    int failures = 0;
    for (int i = 0; i < count && failures < kMaxConsecutiveFailures; ++i)
      failures = attempt() ? 0 : failures + 1;
  };
  const auto roundFootprint = [&placer](double radius) {
    return [&placer, radius]() {
      const Eigen::Vector2d p = placer.uniformPoint();
      return ClutterPlacer::circle(p.x(), p.y(), radius);
    };
  };

  placeSeveral(spec.saplings, [&]() {
    const double dbh = draw(&random, spec.sapling_dbh);
    const double height = draw(&random, spec.sapling_height);
    const double base = std::min(draw(&random, spec.sapling_crown_base), height - 0.2);
    const double crown = draw(&random, spec.sapling_crown_radius);
    const double lean = random.uniform(0.0, std::tan(kMaxSaplingLean));
    const double lean_direction = random.uniform(0.0, 2.0 * kPi);
    // What the sapling occupies: its crown's widest radius about its axis, from the foot to the top.
    const Eigen::Vector2d to_top = lean * height * Eigen::Vector2d(std::cos(lean_direction), std::sin(lean_direction));
    const auto leaning = [&placer, &to_top, crown]() {
      const Eigen::Vector2d p = placer.uniformPoint();
      return Footprint{ p, p + to_top, crown };
    };
    Footprint f;
    if (!placer.place(height, leaning, &f))
      return false;
    TrunkSpec stem;
    stem.x = f.a.x();
    stem.y = f.a.y();
    stem.lean_x = lean * std::cos(lean_direction);
    stem.lean_y = lean * std::sin(lean_direction);
    const double axis_norm = std::sqrt(1.0 + lean * lean);
    stem.height = height * axis_norm;  // along the axis, so that the top is `height` above the ground
    // A cone: radius r0 at the ground, 0 at the top, dbh / 2 at breast height (1.3 m up, 1.3 * axis_norm along it).
    stem.radius = 0.5 * dbh * stem.height / (stem.height - kBreastHeight * axis_norm);
    stem.taper = stem.radius / stem.height;
    world->saplings.push_back(stem);
    addSaplingCrown(stem, std::max(0.0, base), crown, ground, world);
    return true;
  });

  placeSeveral(spec.shrubs, [&]() {
    const double radius = draw(&random, spec.shrub_radius);
    const double top = draw(&random, spec.shrub_top);
    Footprint f;
    if (!placer.place(top, roundFootprint(radius), &f))
      return false;
    FoliageSpec shrub;
    shrub.center = Eigen::Vector3d(f.a.x(), f.a.y(), top - radius);
    shrub.radius = radius;
    shrub.mean_free_path = kUnderstoryMeanFreePath;
    world->foliage.push_back(shrub);
    return true;
  });
}

}  // namespace sim
}  // namespace rbpf_slam
