#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/sim/forest_world.h"

using rbpf_slam::sim::addClutter;
using rbpf_slam::sim::addUnderstory;
using rbpf_slam::sim::addWhorls;
using rbpf_slam::sim::Interval;
using rbpf_slam::sim::StubSpec;
using rbpf_slam::sim::trunkAxisAt;
using rbpf_slam::sim::UnderstorySpec;
using rbpf_slam::sim::WhorlSpec;
using rbpf_slam::sim::BranchSpec;
using rbpf_slam::sim::ClutterSpec;
using rbpf_slam::sim::FoliageSpec;
using rbpf_slam::sim::ForestWorld;
using rbpf_slam::sim::Ground;
using rbpf_slam::sim::GroundSpec;
using rbpf_slam::sim::RockSpec;
using rbpf_slam::sim::TrackSpec;
using rbpf_slam::sim::trackDistance;
using rbpf_slam::sim::TrunkSpec;

namespace
{
constexpr double kPi = 3.14159265358979323846;

GroundSpec groundSpec(double amplitude, double wavelength, std::uint64_t seed)
{
  GroundSpec spec;
  spec.amplitude = amplitude;
  spec.wavelength = wavelength;
  spec.seed = seed;
  return spec;
}

TrunkSpec trunk(double x, double y, double radius, double lean_x = 0.0, double lean_y = 0.0)
{
  TrunkSpec t;
  t.x = x;
  t.y = y;
  t.radius = radius;
  t.lean_x = lean_x;
  t.lean_y = lean_y;
  return t;
}

/** A sparse 30 x 30 m stand (trunks on a 6 m grid, some leaning) with room for everything asked. */
ForestWorld sparseStand()
{
  ForestWorld world;
  int i = 0;
  for (double x = 3.0; x < 30.0; x += 6.0)
  {
    for (double y = 3.0; y < 30.0; y += 6.0)
    {
      const double lean = (i++ % 3 == 0) ? 0.05 : 0.0;
      world.trunks.push_back(trunk(x, y, 0.1 + 0.02 * (i % 5), lean, -lean));
    }
  }
  return world;
}

ClutterSpec clutterSpec(std::uint64_t seed, int bushes, int rocks, int branches)
{
  ClutterSpec spec;
  spec.seed = seed;
  spec.bushes = bushes;
  spec.rocks = rocks;
  spec.branches = branches;
  return spec;
}

double pointSegmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b)
{
  const Eigen::Vector2d ab = b - a;
  const double t = ab.squaredNorm() > 0.0 ? std::max(0.0, std::min(1.0, (p - a).dot(ab) / ab.squaredNorm())) : 0.0;
  return (p - a - t * ab).norm();
}

/** Distance between two 2D segments, sampled finely (independent of the code under test). */
double segmentDistance(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                       const Eigen::Vector2d& d)
{
  double best = 1e300;
  const int n = 400;
  for (int i = 0; i <= n; ++i)
    best = std::min(best, pointSegmentDistance(a + (b - a) * (double(i) / n), c, d));
  return best;
}

/** Ground clutter as horizontal footprints (segment + radius), with the top height above ground. */
struct Item
{
  Eigen::Vector2d a, b;
  double radius;
  double top;
};

std::vector<Item> groundItems(const ForestWorld& world)
{
  std::vector<Item> items;
  for (const FoliageSpec& f : world.foliage)
  {
    if (f.center.z() - f.radius < 1.5)  // bushes, not crowns
      items.push_back(Item{ f.center.head<2>(), f.center.head<2>(), f.radius, f.center.z() + f.radius });
  }
  for (const RockSpec& r : world.rocks)
    items.push_back(Item{ r.center.head<2>(), r.center.head<2>(), r.radius, r.center.z() + r.radius });
  for (const BranchSpec& b : world.branches)
    items.push_back(Item{ b.a, b.b, b.radius, 2.0 * b.radius });
  return items;
}

/** Smallest gap between any ground item and any trunk surface (the axis leans over the item's height). */
double minTrunkGap(const ForestWorld& world)
{
  double best = 1e300;
  for (const Item& item : groundItems(world))
  {
    for (const TrunkSpec& t : world.trunks)
    {
      const Eigen::Vector2d base(t.x, t.y);
      const Eigen::Vector2d top = base + item.top * Eigen::Vector2d(t.lean_x, t.lean_y);
      best = std::min(best, segmentDistance(item.a, item.b, base, top) - t.radius - item.radius);
    }
  }
  return best;
}

double minItemGap(const ForestWorld& world)
{
  const std::vector<Item> items = groundItems(world);
  double best = 1e300;
  for (std::size_t i = 0; i < items.size(); ++i)
  {
    for (std::size_t j = i + 1; j < items.size(); ++j)
    {
      best = std::min(best, segmentDistance(items[i].a, items[i].b, items[j].a, items[j].b) - items[i].radius -
                                items[j].radius);
    }
  }
  return best;
}

bool sameWorld(const ForestWorld& a, const ForestWorld& b)
{
  if (a.foliage.size() != b.foliage.size() || a.rocks.size() != b.rocks.size() ||
      a.branches.size() != b.branches.size())
    return false;
  for (std::size_t i = 0; i < a.foliage.size(); ++i)
  {
    if (a.foliage[i].center != b.foliage[i].center || a.foliage[i].radius != b.foliage[i].radius ||
        a.foliage[i].mean_free_path != b.foliage[i].mean_free_path)
      return false;
  }
  for (std::size_t i = 0; i < a.rocks.size(); ++i)
  {
    if (a.rocks[i].center != b.rocks[i].center || a.rocks[i].radius != b.rocks[i].radius)
      return false;
  }
  for (std::size_t i = 0; i < a.branches.size(); ++i)
  {
    if (a.branches[i].a != b.branches[i].a || a.branches[i].b != b.branches[i].b ||
        a.branches[i].radius != b.branches[i].radius)
      return false;
  }
  return true;
}
}  // namespace

// --- Ground ---------------------------------------------------------------------------------------

TEST(Ground, HeightBoundedByAmplitude)
{
  for (std::uint64_t seed = 1; seed <= 5; ++seed)
  {
    const Ground ground(groundSpec(0.3, 15.0, seed));
    double max_abs = 0.0;
    for (double x = -40.0; x <= 70.0; x += 0.37)
    {
      for (double y = -40.0; y <= 70.0; y += 0.41)
        max_abs = std::max(max_abs, std::fabs(ground.height(x, y)));
    }
    EXPECT_LE(max_abs, 0.3 + 1e-12) << "seed " << seed;
    EXPECT_GT(max_abs, 0.1) << "seed " << seed << ": the ground should undulate visibly";
  }
}

TEST(Ground, GradientMatchesFiniteDifferences)
{
  const Ground ground(groundSpec(0.3, 15.0, 3));
  const double h = 1e-5;
  for (double x = -5.0; x <= 35.0; x += 1.3)
  {
    for (double y = -5.0; y <= 35.0; y += 1.7)
    {
      const Eigen::Vector2d g = ground.gradient(x, y);
      const double gx = (ground.height(x + h, y) - ground.height(x - h, y)) / (2.0 * h);
      const double gy = (ground.height(x, y + h) - ground.height(x, y - h)) / (2.0 * h);
      ASSERT_NEAR(g.x(), gx, 1e-8) << "at " << x << ", " << y;
      ASSERT_NEAR(g.y(), gy, 1e-8) << "at " << x << ", " << y;
    }
  }
}

TEST(Ground, MaxSlopeBoundsTheGradientAndFollowsTheWavelengths)
{
  const double amplitude = 0.3;
  const double wavelength = 15.0;
  const Ground ground(groundSpec(amplitude, wavelength, 2));
  // maxSlope = amplitude / 3 * sum |k|, each |k| = 2 pi / (f * wavelength) with f in [0.7, 1.3].
  EXPECT_GE(ground.maxSlope(), amplitude * 2.0 * kPi / (1.3 * wavelength));
  EXPECT_LE(ground.maxSlope(), amplitude * 2.0 * kPi / (0.7 * wavelength));
  double max_gradient = 0.0;
  for (double x = 0.0; x <= 60.0; x += 0.25)
  {
    for (double y = 0.0; y <= 60.0; y += 0.25)
      max_gradient = std::max(max_gradient, ground.gradient(x, y).norm());
  }
  EXPECT_LE(max_gradient, ground.maxSlope() + 1e-12);
  EXPECT_DOUBLE_EQ(ground.amplitude(), amplitude);
}

TEST(Ground, SameSeedSameGround)
{
  const Ground a(groundSpec(0.3, 15.0, 7));
  const Ground b(groundSpec(0.3, 15.0, 7));
  const Ground c(groundSpec(0.3, 15.0, 8));
  int differs = 0;
  for (double x = 0.0; x <= 30.0; x += 2.5)
  {
    for (double y = 0.0; y <= 30.0; y += 2.5)
    {
      ASSERT_EQ(a.height(x, y), b.height(x, y));
      ASSERT_EQ(a.gradient(x, y), b.gradient(x, y));
      differs += a.height(x, y) != c.height(x, y);
    }
  }
  EXPECT_EQ(a.maxSlope(), b.maxSlope());
  EXPECT_GT(differs, 100);
}

TEST(Ground, FlatWhenAmplitudeIsZero)
{
  const Ground ground(groundSpec(0.0, 15.0, 4));
  for (double x = -10.0; x <= 40.0; x += 3.3)
  {
    for (double y = -10.0; y <= 40.0; y += 3.1)
    {
      ASSERT_EQ(ground.height(x, y), 0.0);
      ASSERT_EQ(ground.gradient(x, y), Eigen::Vector2d::Zero());
    }
  }
  EXPECT_EQ(ground.maxSlope(), 0.0);
  EXPECT_EQ(ground.amplitude(), 0.0);
}

TEST(Ground, RejectsInvalidSpecs)
{
  EXPECT_THROW(Ground(groundSpec(-0.1, 15.0, 1)), std::invalid_argument);
  EXPECT_THROW(Ground(groundSpec(std::nan(""), 15.0, 1)), std::invalid_argument);
  EXPECT_THROW(Ground(groundSpec(0.3, 0.0, 1)), std::invalid_argument);
  EXPECT_NO_THROW(Ground(groundSpec(0.0, 0.0, 1)));  // flat: the wavelength does not matter
}

TEST(Ground, ASlopeAddsAPlaneToTheRelief)
{
  GroundSpec spec = groundSpec(0.3, 15.0, 3);
  const Ground level(spec);
  spec.slope = Eigen::Vector2d(0.10, -0.04);
  const Ground sloped(spec);
  const double h = 1e-5;
  for (double x = -5.0; x <= 35.0; x += 2.3)
  {
    for (double y = -5.0; y <= 35.0; y += 2.9)
    {
      ASSERT_NEAR(sloped.height(x, y), level.height(x, y) + 0.10 * x - 0.04 * y, 1e-12);
      ASSERT_EQ(sloped.relief(x, y), level.height(x, y));
      const Eigen::Vector2d g = sloped.gradient(x, y);
      ASSERT_NEAR(g.x(), (sloped.height(x + h, y) - sloped.height(x - h, y)) / (2.0 * h), 1e-8);
      ASSERT_NEAR(g.y(), (sloped.height(x, y + h) - sloped.height(x, y - h)) / (2.0 * h), 1e-8);
      Eigen::Vector2d g2;
      ASSERT_EQ(sloped.heightAndGradient(x, y, &g2), sloped.height(x, y));
      ASSERT_NEAR((g2 - g).norm(), 0.0, 1e-12);
    }
  }
  // The bound of the gradient holds the plane's too; the amplitude stays the relief's.
  EXPECT_NEAR(sloped.maxSlope(), level.maxSlope() + std::hypot(0.10, 0.04), 1e-12);
  EXPECT_EQ(sloped.amplitude(), 0.3);
  // A plane alone.
  GroundSpec plane = groundSpec(0.0, 15.0, 1);
  plane.slope = Eigen::Vector2d(0.0, 0.2);
  EXPECT_EQ(Ground(plane).height(3.0, 5.0), 1.0);
  EXPECT_EQ(Ground(plane).maxSlope(), 0.2);
  plane.slope = Eigen::Vector2d(std::nan(""), 0.0);
  EXPECT_THROW(Ground{ plane }, std::invalid_argument);
}

TEST(Ground, WithoutASlopeTheHeightIsTheRelief)
{
  // Bit for bit: ground without a slope is what it was before grounds could slope.
  const Ground ground(groundSpec(0.3, 15.0, 1));
  for (double x = -5.0; x <= 35.0; x += 1.9)
  {
    for (double y = -5.0; y <= 35.0; y += 2.1)
    {
      ASSERT_EQ(ground.height(x, y), ground.relief(x, y));
      Eigen::Vector2d a, b;
      ASSERT_EQ(ground.heightAndGradient(x, y, &a), ground.reliefAndGradient(x, y, &b));
      ASSERT_EQ(a, b);
      ASSERT_EQ(a, ground.gradient(x, y));
    }
  }
}

// --- Whorls and understory ------------------------------------------------------------------------

TEST(Whorls, BranchesLeaveTheStemsWithinTheirRanges)
{
  ForestWorld world = sparseStand();
  world.ground.slope = Eigen::Vector2d(0.1, 0.0);
  WhorlSpec spec;
  spec.seed = 3;
  addWhorls(spec, &world);
  ASSERT_FALSE(world.stubs.empty());
  // 25 trunks, whorls from 1 to 6 m every 0.5-1 m, 70 % of them with 1-4 branches: about 25 * 7 * 0.7 * 2.5.
  EXPECT_GT(world.stubs.size(), 150u);
  EXPECT_LT(world.stubs.size(), 500u);
  std::size_t live = 0;
  for (const StubSpec& stub : world.stubs)
  {
    // On the axis of one of the trunks, at a whorl's height above its foot.
    const TrunkSpec* stem = nullptr;
    for (const TrunkSpec& t : world.trunks)
      if (stub.foot == Eigen::Vector2d(t.x, t.y))
        stem = &t;
    ASSERT_NE(stem, nullptr);
    const double height = stub.a.z();
    EXPECT_GE(height, spec.heights.lo);
    EXPECT_LE(height, spec.heights.hi);
    double radius = 0.0;
    const Eigen::Vector3d axis = trunkAxisAt(*stem, 0.0, height, &radius);
    EXPECT_NEAR((axis - stub.a).norm(), 0.0, 1e-9);
    // Its length beyond the stem's surface, its thickness and its direction (+-20 degrees of level).
    const Eigen::Vector3d along = stub.b - stub.a;
    const Interval length = stub.live ? spec.live_length : spec.dead_length;
    EXPECT_GE(along.norm() - radius, length.lo - 1e-9);
    EXPECT_LE(along.norm() - radius, length.hi + 1e-9);
    EXPECT_GE(2.0 * stub.radius, spec.thickness.lo);
    EXPECT_LE(2.0 * stub.radius, spec.thickness.hi);
    EXPECT_LE(std::fabs(along.z()) / along.norm(), std::sin(20.0 * kPi / 180.0) + 1e-9);
    live += stub.live ? 1 : 0;
  }
  // 30 % are live, each with a tuft at its tip (the crowns come from addClutter, not here).
  EXPECT_GT(live, world.stubs.size() / 5);
  EXPECT_LT(live, world.stubs.size() * 2 / 5);
  EXPECT_EQ(world.foliage.size(), live);
}

TEST(Whorls, DeterministicBySeedAndNoneWithoutFill)
{
  ForestWorld a = sparseStand(), b = sparseStand(), c = sparseStand(), none = sparseStand();
  WhorlSpec spec;
  addWhorls(spec, &a);
  addWhorls(spec, &b);
  spec.seed = 2;
  addWhorls(spec, &c);
  ASSERT_EQ(a.stubs.size(), b.stubs.size());
  for (std::size_t i = 0; i < a.stubs.size(); ++i)
    ASSERT_EQ(a.stubs[i].b, b.stubs[i].b);
  EXPECT_TRUE(a.stubs.size() != c.stubs.size() || a.stubs[0].b != c.stubs[0].b);
  spec.fill = 0.0;
  addWhorls(spec, &none);
  EXPECT_TRUE(none.stubs.empty());
  spec.fill = 1.5;
  EXPECT_THROW(addWhorls(spec, &none), std::invalid_argument);
  spec.fill = 0.5;
  spec.min_per_whorl = 3;
  spec.max_per_whorl = 2;
  EXPECT_THROW(addWhorls(spec, &none), std::invalid_argument);
}

TEST(Understory, SaplingsAndShrubsWithinTheirRanges)
{
  ForestWorld world = sparseStand();
  world.ground.amplitude = 0.0;
  UnderstorySpec spec;
  spec.saplings = 20;
  spec.shrubs = 30;
  spec.seed = 4;
  addUnderstory(spec, &world);
  ASSERT_EQ(world.saplings.size(), 20u);
  EXPECT_TRUE(world.stubs.empty());
  EXPECT_EQ(world.trunks.size(), 25u);  // no trees of the stand among them
  for (const TrunkSpec& s : world.saplings)
  {
    double breast_radius = 0.0, top_radius = 1.0;
    trunkAxisAt(s, 0.0, 1.3, &breast_radius);
    const double axis_norm = std::sqrt(1.0 + s.lean_x * s.lean_x + s.lean_y * s.lean_y);
    trunkAxisAt(s, 0.0, s.height / axis_norm, &top_radius);
    EXPECT_GE(2.0 * breast_radius, spec.sapling_dbh.lo - 1e-12);
    EXPECT_LE(2.0 * breast_radius, spec.sapling_dbh.hi + 1e-12);
    EXPECT_NEAR(top_radius, 0.0, 1e-12);  // a cone
    EXPECT_GE(s.height / axis_norm, spec.sapling_height.lo - 1e-9);
    EXPECT_LE(s.height / axis_norm, spec.sapling_height.hi + 1e-9);
    EXPECT_LE(std::hypot(s.lean_x, s.lean_y), std::tan(4.0 * kPi / 180.0) + 1e-12);
    for (const TrunkSpec& t : world.trunks)
      EXPECT_GE(std::hypot(s.x - t.x, s.y - t.y) - t.radius, spec.clearance);
  }
  // Every sapling has a crown of 1-6 spheres below its top; the shrubs are single spheres.
  std::size_t shrubs = 0, crown_spheres = 0;
  for (const FoliageSpec& f : world.foliage)
  {
    EXPECT_LE(f.center.z() + f.radius, spec.sapling_height.hi + 1e-9);
    bool on_a_sapling = false;
    for (const TrunkSpec& s : world.saplings)
      on_a_sapling = on_a_sapling || std::hypot(f.center.x() - s.x, f.center.y() - s.y) < 0.3;
    if (on_a_sapling)
    {
      ++crown_spheres;
      EXPECT_GE(f.center.z() - f.radius, spec.sapling_crown_base.lo - 1e-9);
      EXPECT_LE(f.radius, spec.sapling_crown_radius.hi + 1e-9);
      continue;
    }
    ++shrubs;
    EXPECT_GE(f.radius, spec.shrub_radius.lo);
    EXPECT_LE(f.radius, spec.shrub_radius.hi);
    EXPECT_GE(f.center.z() + f.radius, spec.shrub_top.lo - 1e-9);
    EXPECT_LE(f.center.z() + f.radius, spec.shrub_top.hi + 1e-9);
  }
  EXPECT_EQ(shrubs, 30u);
  EXPECT_GE(crown_spheres, 20u);
  EXPECT_LE(crown_spheres, 120u);
}

/**
 * How near the nearest route of @p routes (polylines) comes to the disc of @p radius about @p c, or to the segment
 * a-b widened by @p radius: sampled finely, independent of the code under test.
 */
double routeGap(const std::vector<std::vector<Eigen::Vector2d>>& routes, const Eigen::Vector2d& a,
                const Eigen::Vector2d& b, double radius)
{
  double best = 1e300;
  for (const auto& route : routes)
    for (std::size_t i = 1; i < route.size(); ++i)
      best = std::min(best, segmentDistance(a, b, route[i - 1], route[i]));
  return best - radius;
}

/** What the follower would steer round that comes within @p clearance of @p routes; the worst gap in @p worst. */
int itemsOnTheTrack(const ForestWorld& world, const std::vector<std::vector<Eigen::Vector2d>>& routes,
                    double clearance, double headroom, double* worst)
{
  int on = 0;
  *worst = 1e300;
  const auto check = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b, double radius) {
    const double gap = routeGap(routes, a, b, radius);
    *worst = std::min(*worst, gap);
    on += gap < clearance - 1e-6 ? 1 : 0;
  };
  // Foliage low enough to be in the way (bushes, shrubs, sapling crowns, tufts; the ground is flat here).
  for (const FoliageSpec& f : world.foliage)
    if (f.center.z() - f.radius < headroom)
      check(f.center.head<2>(), f.center.head<2>(), f.radius);
  for (const RockSpec& r : world.rocks)
    check(r.center.head<2>(), r.center.head<2>(), r.radius);
  for (const TrunkSpec& s : world.saplings)
  {
    const double axis_norm = std::sqrt(1.0 + s.lean_x * s.lean_x + s.lean_y * s.lean_y);
    const Eigen::Vector3d top = trunkAxisAt(s, 0.0, s.height / axis_norm, nullptr);
    check(Eigen::Vector2d(s.x, s.y), top.head<2>(), s.radius);
  }
  // A branch on a stem from its tip to where it leaves the bark (at most the stem's ground radius from the axis).
  for (const StubSpec& b : world.stubs)
  {
    if (std::min(b.a.z(), b.b.z()) - b.radius >= headroom)
      continue;
    const Eigen::Vector2d dir = (b.b - b.a).head<2>().normalized();
    const TrunkSpec* stem = nullptr;
    for (const TrunkSpec& t : world.trunks)
      if (b.foot == Eigen::Vector2d(t.x, t.y))
        stem = &t;
    check(b.a.head<2>() + stem->radius * dir, b.b.head<2>(), b.radius);
  }
  return on;
}

TEST(Track, UnderstoryBushesRocksAndLowBranchesKeepOffTheRoutes)
{
  // Two routes between the rows and columns of the sparse stand (trunks 3 m from each): along y = 12, and a bend.
  const std::vector<std::vector<Eigen::Vector2d>> routes = {
    { Eigen::Vector2d(0.0, 12.0), Eigen::Vector2d(30.0, 12.0) },
    { Eigen::Vector2d(18.0, 0.0), Eigen::Vector2d(18.0, 24.0), Eigen::Vector2d(30.0, 24.0) }
  };
  UnderstorySpec understory;
  understory.saplings = 25;
  understory.shrubs = 35;
  understory.seed = 5;
  WhorlSpec whorls;
  const auto make = [&](bool with_track) {
    ForestWorld world = sparseStand();
    world.ground.amplitude = 0.0;
    if (with_track)
    {
      world.track.routes = routes;
      world.track.clearance = 1.5;
      world.track.headroom = 3.0;
    }
    addClutter(clutterSpec(2, 12, 6, 10), &world);
    addUnderstory(understory, &world);
    addWhorls(whorls, &world);
    return world;
  };
  const ForestWorld open = make(false), tracked = make(true);
  double worst = 0.0;
  // Without a track the same seeds put some of it on the routes (so that the check below can fail).
  EXPECT_GT(itemsOnTheTrack(open, routes, 1.5, 3.0, &worst), 5);
  EXPECT_LT(worst, 0.0);
  EXPECT_EQ(itemsOnTheTrack(tracked, routes, 1.5, 3.0, &worst), 0);
  EXPECT_GE(worst, 1.5 - 1e-6);
  // Everything asked for is there, off the track: the understory, the bushes and rocks, the fallen wood (which may
  // cross a route).
  EXPECT_EQ(tracked.saplings.size(), 25u);
  EXPECT_EQ(tracked.rocks.size(), 6u);
  EXPECT_EQ(tracked.branches.size(), 10u);
  EXPECT_EQ(open.saplings.size(), 25u);
  // The branches that would reach into the track are the only ones left out: the others are as without it.
  EXPECT_LT(tracked.stubs.size(), open.stubs.size());
  std::size_t kept = 0;
  for (const StubSpec& b : open.stubs)
    for (const StubSpec& c : tracked.stubs)
      kept += b.a == c.a && b.b == c.b ? 1 : 0;
  EXPECT_EQ(kept, tracked.stubs.size());
  // The library's own distance agrees with the sampled one.
  const Eigen::Vector2d p(5.0, 14.0);
  EXPECT_NEAR(trackDistance(tracked.track, p, 0.5), 1.5, 1e-12);
  EXPECT_EQ(trackDistance(TrackSpec(), p, 0.5), std::numeric_limits<double>::infinity());
}

TEST(Track, NoRoutesChangeNothing)
{
  ForestWorld a = sparseStand(), b = sparseStand();
  b.track.clearance = 5.0;  // without routes the clearance keeps nothing off
  for (ForestWorld* w : { &a, &b })
  {
    addClutter(clutterSpec(3, 10, 5, 5), w);
    UnderstorySpec spec;
    spec.saplings = 10;
    spec.shrubs = 10;
    addUnderstory(spec, w);
    addWhorls(WhorlSpec(), w);
  }
  ASSERT_EQ(a.foliage.size(), b.foliage.size());
  for (std::size_t i = 0; i < a.foliage.size(); ++i)
    EXPECT_EQ(a.foliage[i].center, b.foliage[i].center);
  EXPECT_EQ(a.stubs.size(), b.stubs.size());
  b.track.clearance = -1.0;
  EXPECT_THROW(addUnderstory(UnderstorySpec(), &b), std::invalid_argument);
  EXPECT_THROW(addWhorls(WhorlSpec(), &b), std::invalid_argument);
  EXPECT_THROW(addClutter(ClutterSpec(), &b), std::invalid_argument);
}

TEST(Understory, RejectsInvalidSpecs)
{
  ForestWorld world = sparseStand();
  UnderstorySpec spec;
  spec.sapling_height = Interval{ 1.0, 3.0 };  // a sapling has no diameter at breast height below 1.3 m
  EXPECT_THROW(addUnderstory(spec, &world), std::invalid_argument);
  spec = UnderstorySpec();
  spec.shrub_radius = Interval{ 0.8, 0.3 };
  EXPECT_THROW(addUnderstory(spec, &world), std::invalid_argument);
  spec = UnderstorySpec();
  spec.saplings = -1;
  EXPECT_THROW(addUnderstory(spec, &world), std::invalid_argument);
  EXPECT_THROW(addUnderstory(UnderstorySpec(), nullptr), std::invalid_argument);
}

// --- Clutter --------------------------------------------------------------------------------------

TEST(Clutter, DeterministicBySeed)
{
  ForestWorld a = sparseStand();
  ForestWorld b = sparseStand();
  ForestWorld c = sparseStand();
  addClutter(clutterSpec(5, 12, 6, 10), &a);
  addClutter(clutterSpec(5, 12, 6, 10), &b);
  addClutter(clutterSpec(6, 12, 6, 10), &c);
  EXPECT_TRUE(sameWorld(a, b));
  EXPECT_FALSE(sameWorld(a, c));
}

TEST(Clutter, PlacesWhatIsAskedWithinRanges)
{
  ForestWorld world = sparseStand();
  addClutter(clutterSpec(2, 12, 6, 10), &world);
  ASSERT_EQ(world.foliage.size(), world.trunks.size() + 12);
  ASSERT_EQ(world.rocks.size(), 6u);
  ASSERT_EQ(world.branches.size(), 10u);
  for (std::size_t i = world.trunks.size(); i < world.foliage.size(); ++i)
  {
    const FoliageSpec& bush = world.foliage[i];
    EXPECT_GE(bush.radius, 0.3);
    EXPECT_LE(bush.radius, 0.8);
    EXPECT_NEAR(bush.center.z(), 0.7 * bush.radius, 1e-12);
    EXPECT_DOUBLE_EQ(bush.mean_free_path, 0.3);
  }
  for (const RockSpec& rock : world.rocks)
  {
    EXPECT_GE(rock.radius, 0.15);
    EXPECT_LE(rock.radius, 0.5);
    EXPECT_NEAR(rock.center.z(), 0.3 * rock.radius, 1e-12);
  }
  for (const BranchSpec& branch : world.branches)
  {
    EXPECT_GE((branch.b - branch.a).norm(), 1.0 - 1e-9);
    EXPECT_LE((branch.b - branch.a).norm(), 4.0 + 1e-9);
    EXPECT_GE(branch.radius, 0.04);
    EXPECT_LE(branch.radius, 0.12);
  }
  for (const Item& item : groundItems(world))
  {
    for (const Eigen::Vector2d& p : { item.a, item.b })
    {
      EXPECT_GE(p.x() - item.radius, world.min_x);
      EXPECT_LE(p.x() + item.radius, world.max_x);
      EXPECT_GE(p.y() - item.radius, world.min_y);
      EXPECT_LE(p.y() + item.radius, world.max_y);
    }
  }
}

TEST(Clutter, KeepsClearanceFromTrunksAndEachOther)
{
  for (std::uint64_t seed = 1; seed <= 4; ++seed)
  {
    ForestWorld world = sparseStand();
    ClutterSpec spec = clutterSpec(seed, 15, 8, 12);
    spec.clearance = 0.8;
    addClutter(spec, &world);
    ASSERT_GT(groundItems(world).size(), 20u);
    // The sampled reference distance can only overestimate, so a tiny tolerance suffices.
    EXPECT_GE(minTrunkGap(world), spec.clearance - 1e-9) << "seed " << seed;
    EXPECT_GE(minItemGap(world), spec.clearance - 1e-9) << "seed " << seed;
  }
}

TEST(Clutter, KeepsClearanceFromClutterAlreadyInTheWorld)
{
  ForestWorld world = sparseStand();
  addClutter(clutterSpec(1, 6, 3, 5), &world);
  ClutterSpec more = clutterSpec(2, 6, 3, 5);
  more.crowns = false;
  addClutter(more, &world);
  EXPECT_EQ(groundItems(world).size(), 28u);
  EXPECT_GE(minItemGap(world), more.clearance - 1e-9);
}

TEST(Clutter, CrownsSitOnTheirTrunks)
{
  ForestWorld world;
  world.trunks.push_back(trunk(10.0, 10.0, 0.2));
  world.trunks.push_back(trunk(20.0, 20.0, 0.2, 0.05, -0.02));  // leaning
  world.trunks.push_back(trunk(5.0, 25.0, 0.2));
  world.trunks.back().height = 30.0;  // crown radius clipped to 4 m
  world.trunks.push_back(trunk(25.0, 5.0, 0.1));
  world.trunks.back().height = 5.0;  // shorter than crown_base + radius: crown centred on the top
  ClutterSpec spec = clutterSpec(1, 0, 0, 0);
  spec.crown_base = 5.0;
  addClutter(spec, &world);
  ASSERT_EQ(world.foliage.size(), 4u);
  EXPECT_TRUE(world.rocks.empty());
  EXPECT_TRUE(world.branches.empty());

  const FoliageSpec& upright = world.foliage[0];
  EXPECT_DOUBLE_EQ(upright.radius, 3.75);  // 0.25 * 15 m
  EXPECT_DOUBLE_EQ(upright.center.x(), 10.0);
  EXPECT_DOUBLE_EQ(upright.center.y(), 10.0);
  EXPECT_DOUBLE_EQ(upright.center.z() - upright.radius, 5.0);
  EXPECT_DOUBLE_EQ(upright.mean_free_path, 0.6);

  const TrunkSpec& t = world.trunks[1];
  const double top = t.height / std::sqrt(1.0 + t.lean_x * t.lean_x + t.lean_y * t.lean_y);
  const FoliageSpec& leaning = world.foliage[1];
  EXPECT_NEAR(leaning.center.x(), t.x + t.lean_x * top, 1e-12);
  EXPECT_NEAR(leaning.center.y(), t.y + t.lean_y * top, 1e-12);
  EXPECT_NEAR(leaning.center.z() - leaning.radius, 5.0, 1e-12);

  EXPECT_DOUBLE_EQ(world.foliage[2].radius, 4.0);
  EXPECT_DOUBLE_EQ(world.foliage[3].radius, 1.5);
  EXPECT_DOUBLE_EQ(world.foliage[3].center.z(), 5.0);

  ForestWorld bare;
  bare.trunks = world.trunks;
  spec.crowns = false;
  addClutter(spec, &bare);
  EXPECT_TRUE(bare.foliage.empty());
}

TEST(Clutter, GivesUpInAStandTooDenseForIt)
{
  // Trunks every 1 m: with 0.8 m clearance nothing fits anywhere. Asking for a million items must
  // still return at once (each kind is given up after a bounded number of failed items).
  ForestWorld world;
  for (double x = 0.5; x < 30.0; x += 1.0)
  {
    for (double y = 0.5; y < 30.0; y += 1.0)
      world.trunks.push_back(trunk(x, y, 0.15));
  }
  ClutterSpec spec = clutterSpec(1, 1000000, 1000000, 1000000);
  spec.crowns = false;
  addClutter(spec, &world);
  EXPECT_TRUE(world.foliage.empty());
  EXPECT_TRUE(world.rocks.empty());
  EXPECT_TRUE(world.branches.empty());
}

TEST(Clutter, FillsACrowdedStandPartlyAndStillKeepsClearance)
{
  // A small open stand: far more is asked than fits; what is placed keeps its clearance.
  ForestWorld world;
  world.min_x = 0.0;
  world.min_y = 0.0;
  world.max_x = 8.0;
  world.max_y = 8.0;
  world.trunks.push_back(trunk(4.0, 4.0, 0.3));
  ClutterSpec spec = clutterSpec(3, 500, 500, 500);
  spec.crowns = false;
  addClutter(spec, &world);
  const std::size_t placed = groundItems(world).size();
  EXPECT_GT(placed, 3u);
  EXPECT_LT(placed, 100u);
  EXPECT_GE(minTrunkGap(world), spec.clearance - 1e-9);
  EXPECT_GE(minItemGap(world), spec.clearance - 1e-9);
}

TEST(Clutter, RejectsInvalidSpecs)
{
  ForestWorld world = sparseStand();
  EXPECT_THROW(addClutter(clutterSpec(1, -1, 0, 0), &world), std::invalid_argument);
  ClutterSpec spec;
  spec.clearance = -0.1;
  EXPECT_THROW(addClutter(spec, &world), std::invalid_argument);
  EXPECT_THROW(addClutter(ClutterSpec(), nullptr), std::invalid_argument);
  world.max_x = world.min_x;
  EXPECT_THROW(addClutter(ClutterSpec(), &world), std::invalid_argument);
}
