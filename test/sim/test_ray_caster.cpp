#include <cmath>
#include <limits>
#include <type_traits>
#include <utility>

#include <gtest/gtest.h>

#include "rbpf_slam/sim/ray_caster.h"

using namespace rbpf_slam::core;
using namespace rbpf_slam::sim;

namespace
{
ForestWorld flatWorld()
{
  ForestWorld w;
  w.ground.amplitude = 0.0;
  return w;
}

TrunkSpec trunk(double x, double y, double r)
{
  TrunkSpec t;
  t.x = x;
  t.y = y;
  t.radius = r;
  return t;
}

template <typename T, typename = void>
struct GroundReadable : std::false_type
{
};
template <typename T>
struct GroundReadable<T, std::void_t<decltype(std::declval<T>().ground()), decltype(std::declval<T>().world())>>
  : std::true_type
{
};
}  // namespace

TEST(RayCaster, GroundAndWorldAreNotReadFromATemporary)
{
  // The accessors return references into the caster: on a temporary they would dangle.
  EXPECT_TRUE((GroundReadable<const ForestRayCaster&>::value));
  EXPECT_TRUE((GroundReadable<ForestRayCaster&>::value));
  EXPECT_FALSE((GroundReadable<ForestRayCaster>::value));
  EXPECT_FALSE((GroundReadable<const ForestRayCaster>::value));
}

TEST(RayCaster, RangeToATrunkAtAKnownPose)
{
  ForestWorld w = flatWorld();
  w.trunks.push_back(trunk(10.0, 0.0, 0.2));
  ForestRayCaster caster(w);
  Random random(1);
  const RayHit hit = caster.cast({ 0.0, 0.0, 1.0 }, { 1.0, 0.0, 0.0 }, 100.0, random);
  EXPECT_EQ(hit.kind, HitKind::kTrunk);
  EXPECT_EQ(hit.index, 0);
  EXPECT_NEAR(hit.range, 9.8, 1e-9);
  // Off-centre: the chord geometry of a circle, ray at lateral offset 0.1.
  const RayHit side = caster.cast({ 0.0, 0.1, 1.0 }, { 1.0, 0.0, 0.0 }, 100.0, random);
  EXPECT_NEAR(side.range, 10.0 - std::sqrt(0.2 * 0.2 - 0.1 * 0.1), 1e-9);
  // Just missing it.
  EXPECT_EQ(caster.cast({ 0.0, 0.2001, 1.0 }, { 1.0, 0.0, 0.0 }, 100.0, random).kind, HitKind::kNone);
}

TEST(RayCaster, NearerTrunkOccludesTheFarOne)
{
  ForestWorld w = flatWorld();
  w.trunks.push_back(trunk(10.0, 0.0, 0.2));  // far one first: order in the list must not matter
  w.trunks.push_back(trunk(5.0, 0.05, 0.3));
  ForestRayCaster caster(w);
  Random random(1);
  const RayHit hit = caster.cast({ 0.0, 0.0, 1.0 }, { 1.0, 0.0, 0.0 }, 100.0, random);
  EXPECT_EQ(hit.index, 1);
  EXPECT_NEAR(hit.range, 5.0 - std::sqrt(0.09 - 0.0025), 1e-9);
  // From the other side the far one is nearer.
  const RayHit back = caster.cast({ 20.0, 0.0, 1.0 }, { -1.0, 0.0, 0.0 }, 100.0, random);
  EXPECT_EQ(back.index, 0);
  EXPECT_NEAR(back.range, 9.8, 1e-9);
}

TEST(RayCaster, LeaningAndTaperedTrunks)
{
  ForestWorld w = flatWorld();
  TrunkSpec tapered = trunk(10.0, 0.0, 0.2);
  tapered.taper = 0.02;
  w.trunks.push_back(tapered);
  ForestRayCaster caster(w);
  Random random(1);
  // Radius at height 1 is 0.18.
  EXPECT_NEAR(caster.cast({ 0.0, 0.0, 1.0 }, { 1.0, 0.0, 0.0 }, 100.0, random).range, 9.82, 1e-9);

  // Leaning towards +x by 0.1: the axis is at x = 10 + 0.1 z; a horizontal section is an ellipse
  // with semi-axis r * sqrt(1 + 0.1^2) along x.
  TrunkSpec lean = trunk(10.0, 0.0, 0.2);
  lean.lean_x = 0.1;
  const double t = ForestRayCaster::intersectTrunk(lean, 0.0, { 0.0, 0.0, 1.0 }, { 1.0, 0.0, 0.0 });
  EXPECT_NEAR(t, 10.1 - 0.2 * std::sqrt(1.01), 1e-9);
  // A trunk ends at its height.
  EXPECT_EQ(ForestRayCaster::intersectTrunk(trunk(10.0, 0.0, 0.2), 0.0, { 0.0, 0.0, 16.0 }, { 1.0, 0.0, 0.0 }),
            std::numeric_limits<double>::infinity());
}

TEST(RayCaster, FlatAndUndulatingGround)
{
  ForestWorld w = flatWorld();
  ForestRayCaster flat(w);
  Random random(1);
  const double el = -15.0 * M_PI / 180.0;
  const Eigen::Vector3d dir(std::cos(el), 0.0, std::sin(el));
  const RayHit hit = flat.cast({ 0.0, 0.0, 1.8 }, dir, 100.0, random);
  EXPECT_EQ(hit.kind, HitKind::kGround);
  EXPECT_NEAR(hit.range, 1.8 / std::sin(15.0 * M_PI / 180.0), 1e-6);
  EXPECT_EQ(flat.cast({ 0.0, 0.0, 1.8 }, { 0.0, 0.0, 1.0 }, 100.0, random).kind, HitKind::kNone);

  ForestWorld hilly;
  hilly.ground.amplitude = 0.3;
  hilly.ground.wavelength = 10.0;
  hilly.ground.margin = 1000.0;  // grazing rays meet the ground up to 180 m away
  ForestRayCaster caster(hilly);
  Random r(3);
  int ground_hits = 0;
  for (int i = 0; i < 500; ++i)
  {
    const double az = r.uniform(-M_PI, M_PI), e = r.uniform(-0.3, -0.01);
    const Eigen::Vector3d o(r.uniform(0.0, 30.0), r.uniform(0.0, 30.0), 0.0);
    const Eigen::Vector3d origin(o.x(), o.y(), caster.ground().height(o.x(), o.y()) + 1.8);
    const Eigen::Vector3d d(std::cos(e) * std::cos(az), std::cos(e) * std::sin(az), std::sin(e));
    const RayHit h = caster.cast(origin, d, 200.0, r);
    if (h.kind != HitKind::kGround)
      continue;
    ++ground_hits;
    const Eigen::Vector3d p = origin + h.range * d;
    ASSERT_NEAR(p.z(), caster.ground().height(p.x(), p.y()), 1e-3);
    // No earlier crossing: every point before the hit is above the ground.
    for (double t = 0.0; t < h.range - 0.01; t += 0.05)
    {
      const Eigen::Vector3d q = origin + t * d;
      ASSERT_GT(q.z(), caster.ground().height(q.x(), q.y()) - 1e-9) << "ray " << i << " crosses at t=" << t;
    }
  }
  EXPECT_GT(ground_hits, 450);
}

TEST(RayCaster, SlopingGroundIsHitWhereThePlaneAndTheRayMeet)
{
  // A plane rising 10 % along x: z = 0.1 x. A ray 15 degrees down from 1.8 m meets it at 1.8 / (sin e + 0.1 cos e)
  // uphill and 1.8 / (sin e - 0.1 cos e) downhill.
  ForestWorld w = flatWorld();
  w.ground.slope = Eigen::Vector2d(0.10, 0.0);
  w.ground.margin = 100.0;
  ForestRayCaster caster(w);
  Random random(1);
  const double e = 15.0 * M_PI / 180.0;
  const RayHit up = caster.cast({ 0.0, 0.0, 1.8 }, { std::cos(e), 0.0, -std::sin(e) }, 100.0, random);
  ASSERT_EQ(up.kind, HitKind::kGround);
  EXPECT_NEAR(up.range, 1.8 / (std::sin(e) + 0.1 * std::cos(e)), 1e-6);
  const RayHit down = caster.cast({ 0.0, 0.0, 1.8 }, { -std::cos(e), 0.0, -std::sin(e) }, 100.0, random);
  ASSERT_EQ(down.kind, HitKind::kGround);
  EXPECT_NEAR(down.range, 1.8 / (std::sin(e) - 0.1 * std::cos(e)), 1e-6);
  // Across the slope the plane is level: as on flat ground.
  EXPECT_NEAR(caster.cast({ 0.0, 0.0, 1.8 }, { 0.0, std::cos(e), -std::sin(e) }, 100.0, random).range,
              1.8 / std::sin(e), 1e-6);
  // A horizontal ray uphill meets the rising ground, 18 m ahead; downhill it never does.
  EXPECT_NEAR(caster.cast({ 0.0, 0.0, 1.8 }, { 1.0, 0.0, 0.0 }, 100.0, random).range, 18.0, 1e-6);
  EXPECT_EQ(caster.cast({ 0.0, 0.0, 1.8 }, { -1.0, 0.0, 0.0 }, 100.0, random).kind, HitKind::kNone);
}

TEST(RayCaster, SlopingUndulatingGroundHasNoEarlierCrossing)
{
  // The relief's bounds hold on the sheared ray whatever the slope: every hit lies on the ground and no point of the
  // ray before it is below the ground, also for rays climbing the slope.
  ForestWorld hilly;
  hilly.ground.amplitude = 0.5;
  hilly.ground.wavelength = 10.0;
  hilly.ground.slope = Eigen::Vector2d(0.10, -0.05);
  hilly.ground.margin = 1000.0;
  ForestRayCaster caster(hilly);
  Random r(4);
  int ground_hits = 0;
  for (int i = 0; i < 500; ++i)
  {
    const double az = r.uniform(-M_PI, M_PI), e = r.uniform(-0.3, 0.05);
    const Eigen::Vector3d o(r.uniform(0.0, 30.0), r.uniform(0.0, 30.0), 0.0);
    const Eigen::Vector3d origin(o.x(), o.y(), caster.ground().height(o.x(), o.y()) + 1.8);
    const Eigen::Vector3d d(std::cos(e) * std::cos(az), std::cos(e) * std::sin(az), std::sin(e));
    const RayHit h = caster.cast(origin, d, 200.0, r);
    if (h.kind != HitKind::kGround)
      continue;
    ++ground_hits;
    const Eigen::Vector3d p = origin + h.range * d;
    ASSERT_NEAR(p.z(), caster.ground().height(p.x(), p.y()), 1e-3) << "ray " << i;
    for (double t = 0.0; t < h.range - 0.01; t += 0.05)
    {
      const Eigen::Vector3d q = origin + t * d;
      ASSERT_GT(q.z(), caster.ground().height(q.x(), q.y()) - 1e-9) << "ray " << i << " crosses at t=" << t;
    }
  }
  EXPECT_GT(ground_hits, 400);
}

TEST(RayCaster, ARayHitsABranchStubOnAStem)
{
  // A stem at the origin with a horizontal dead branch of radius 2 cm along +x at 1.5 m, reaching 0.8 m from the
  // axis; the ground slopes, and the branch's heights count from the ground at the stem's foot.
  ForestWorld w = flatWorld();
  w.ground.slope = Eigen::Vector2d(0.0, 0.10);
  w.trunks.push_back(trunk(0.0, 2.0, 0.15));
  StubSpec stub;
  stub.foot = Eigen::Vector2d(0.0, 2.0);
  stub.a = Eigen::Vector3d(0.0, 2.0, 1.5);
  stub.b = Eigen::Vector3d(0.8, 2.0, 1.5);
  stub.radius = 0.02;
  w.stubs.push_back(stub);
  ForestRayCaster caster(w);
  Random random(1);
  const double z = 0.2 + 1.5;  // the ground at the foot is 0.1 * 2 = 0.2 m up
  // From the side, across the branch 0.5 m out from the axis: the branch's surface 2 cm before its axis.
  const RayHit hit = caster.cast({ 0.5, -3.0, z }, { 0.0, 1.0, 0.0 }, 100.0, random);
  EXPECT_EQ(hit.kind, HitKind::kStub);
  EXPECT_EQ(hit.index, 0);
  EXPECT_NEAR(hit.range, 5.0 - 0.02, 1e-9);
  // From below, at its tip's round end.
  const RayHit below = caster.cast({ 0.8, 2.0, 0.5 }, { 0.0, 0.0, 1.0 }, 100.0, random);
  EXPECT_EQ(below.kind, HitKind::kStub);
  EXPECT_NEAR(below.range, z - 0.02 - 0.5, 1e-9);
  // Beside it, 3 cm off its axis: the ray passes and meets nothing within 10 m (the rising ground 20 m on).
  EXPECT_EQ(caster.cast({ 0.5, -3.0, z + 0.03 }, { 0.0, 1.0, 0.0 }, 10.0, random).kind, HitKind::kNone);
  // Along it, from outside: the tip first (before the stem).
  const RayHit along = caster.cast({ 3.0, 2.0, z }, { -1.0, 0.0, 0.0 }, 100.0, random);
  EXPECT_EQ(along.kind, HitKind::kStub);
  EXPECT_NEAR(along.range, 3.0 - 0.8 - 0.02, 1e-9);
}

TEST(RayCaster, ARayHitsASaplingStem)
{
  // A cone-shaped sapling (radius 3 cm at the ground, 0 at 3 m) 6 m ahead: at 1 m up its radius is 2 cm.
  ForestWorld w = flatWorld();
  TrunkSpec sapling = trunk(6.0, 0.0, 0.03);
  sapling.height = 3.0;
  sapling.taper = 0.01;
  w.saplings.push_back(sapling);
  w.trunks.push_back(trunk(12.0, 0.0, 0.2));  // behind it
  ForestRayCaster caster(w);
  Random random(1);
  const RayHit hit = caster.cast({ 0.0, 0.0, 1.0 }, { 1.0, 0.0, 0.0 }, 100.0, random);
  EXPECT_EQ(hit.kind, HitKind::kSapling);
  EXPECT_EQ(hit.index, 0);
  EXPECT_NEAR(hit.range, 6.0 - 0.02, 1e-9);
  // Above its top the ray passes on to the trunk behind it.
  const RayHit over = caster.cast({ 0.0, 0.0, 3.2 }, { 1.0, 0.0, 0.0 }, 100.0, random);
  EXPECT_EQ(over.kind, HitKind::kTrunk);
  EXPECT_NEAR(over.range, 11.8, 1e-9);
}

TEST(RayCaster, GridTraversalMatchesBruteForce)
{
  ForestWorld w = flatWorld();
  Random r(5);
  for (int i = 0; i < 80; ++i)
  {
    TrunkSpec t = trunk(r.uniform(0.0, 40.0), r.uniform(0.0, 40.0), r.uniform(0.1, 0.5));
    t.lean_x = r.uniform(-0.05, 0.05);
    t.lean_y = r.uniform(-0.05, 0.05);
    w.trunks.push_back(t);
  }
  ForestRayCaster caster(w, 1.7);
  for (int i = 0; i < 3000; ++i)
  {
    const Eigen::Vector3d o(r.uniform(-10.0, 50.0), r.uniform(-10.0, 50.0), r.uniform(0.5, 3.0));
    const double az = r.uniform(-M_PI, M_PI), e = r.uniform(0.0, 0.2);  // upwards: no ground
    const Eigen::Vector3d d(std::cos(e) * std::cos(az), std::cos(e) * std::sin(az), std::sin(e));
    double best = 60.0;
    int best_index = -1;
    for (std::size_t k = 0; k < w.trunks.size(); ++k)
    {
      const double t = ForestRayCaster::intersectTrunk(w.trunks[k], 0.0, o, d);
      if (t < best)
      {
        best = t;
        best_index = static_cast<int>(k);
      }
    }
    const RayHit hit = caster.cast(o, d, 60.0, r);
    ASSERT_EQ(hit.index, best_index) << "ray " << i;
    if (best_index >= 0)
    {
      ASSERT_NEAR(hit.range, best, 1e-9);
    }
  }
}

TEST(RayCaster, FoliageStopsRaysAfterAnExponentialFreePath)
{
  ForestWorld w = flatWorld();
  FoliageSpec f;
  f.center = Eigen::Vector3d(20.0, 0.0, 10.0);
  f.radius = 5.0;
  f.mean_free_path = 1.0;
  w.foliage.push_back(f);
  ForestRayCaster caster(w);
  Random random(9);
  double depth = 0.0;
  int hits = 0;
  for (int i = 0; i < 20000; ++i)
  {
    const RayHit h = caster.cast({ 0.0, 0.0, 10.0 }, { 1.0, 0.0, 0.0 }, 100.0, random);
    if (h.kind == HitKind::kFoliage)
    {
      depth += h.range - 15.0;
      ++hits;
    }
  }
  // P(pass through 10 m of foliage) = exp(-10); mean depth of an exponential truncated at 10 is ~1.
  EXPECT_GT(hits, 19990);
  EXPECT_NEAR(depth / hits, 1.0, 0.03);
}
