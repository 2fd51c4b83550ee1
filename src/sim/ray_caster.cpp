#include "rbpf_slam/sim/ray_caster.h"

#include <algorithm>
#include <cmath>

namespace rbpf_slam
{
namespace sim
{
using core::Random;

namespace
{
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kMinT = 1e-6;
constexpr double kTrunkBuried = 0.5;  ///< [m] trunks start below the ground so undulation leaves no gap

/** @brief Entry distance into a sphere, or +inf. */
double intersectSphere(const Eigen::Vector3d& center, double radius, const Eigen::Vector3d& o,
                       const Eigen::Vector3d& d, double* t_exit)
{
  const Eigen::Vector3d w = o - center;
  const double b = w.dot(d);
  const double c = w.squaredNorm() - radius * radius;
  const double disc = b * b - c;
  if (disc < 0.0)
    return kInf;
  const double root = std::sqrt(disc);
  const double t1 = -b + root;
  if (t1 < kMinT)
    return kInf;
  if (t_exit)
    *t_exit = t1;
  return std::max(-b - root, 0.0);
}

/** @brief Entry distance into a capsule (segment a-b, radius r), or +inf. */
double intersectCapsule(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r, const Eigen::Vector3d& o,
                        const Eigen::Vector3d& d)
{
  const Eigen::Vector3d ba = b - a;
  const Eigen::Vector3d oa = o - a;
  const double baba = ba.dot(ba);
  const double bard = ba.dot(d);
  const double baoa = ba.dot(oa);
  const double rdoa = d.dot(oa);
  const double oaoa = oa.dot(oa);
  const double qa = baba - bard * bard;
  const double qb = baba * rdoa - baoa * bard;
  const double qc = baba * oaoa - baoa * baoa - r * r * baba;
  double best = kInf;
  if (qa > 1e-12)
  {
    const double h = qb * qb - qa * qc;
    if (h >= 0.0)
    {
      const double t = (-qb - std::sqrt(h)) / qa;
      const double y = baoa + t * bard;
      if (t > kMinT && y > 0.0 && y < baba)
        best = t;
    }
  }
  if (best == kInf)
  {
    best = std::min(intersectSphere(a, r, o, d, nullptr), intersectSphere(b, r, o, d, nullptr));
    if (best <= kMinT)
      best = kInf;
  }
  return best;
}
}  // namespace

ForestRayCaster::ForestRayCaster(const ForestWorld& world, double cell_size)
  : world_(world), ground_(world.ground), cell_(cell_size)
{
  std::vector<ShapeBounds> boxes = placeShapes();
  extent_min_x_ = world_.min_x - world_.ground.margin;
  extent_min_y_ = world_.min_y - world_.ground.margin;
  extent_max_x_ = world_.max_x + world_.ground.margin;
  extent_max_y_ = world_.max_y + world_.ground.margin;
  findTop();
  sizeGrid(boxes);
  for (ShapeBounds& b : boxes)
    setHeightRange(&b);
  for (const ShapeBounds& b : boxes)
  {
    shapes_.push_back(b.shape);
    shape_z_.emplace_back(b.z0, b.z1);
    insert(b.shape, b.x0, b.y0, b.x1, b.y1);
  }
  mailbox_.assign(shapes_.size(), 0);
}

std::vector<ForestRayCaster::ShapeBounds> ForestRayCaster::placeShapes()
{
  std::vector<ShapeBounds> boxes;
  for (std::size_t i = 0; i < world_.trunks.size(); ++i)
  {
    const TrunkSpec& t = world_.trunks[i];
    trunk_base_z_.push_back(ground_.height(t.x, t.y));
    Eigen::Vector3d circle;
    boxes.push_back(stemBounds(t, { HitKind::kTrunk, static_cast<int>(i) }, &circle));
    trunk_bound_.push_back(circle);
  }
  for (std::size_t i = 0; i < world_.foliage.size(); ++i)
  {
    const FoliageSpec& f = world_.foliage[i];
    Eigen::Vector3d c = f.center;
    c.z() += ground_.height(c.x(), c.y());
    foliage_center_.push_back(c);
    boxes.push_back({ { HitKind::kFoliage, static_cast<int>(i) }, c.x() - f.radius, c.y() - f.radius,
                      c.x() + f.radius, c.y() + f.radius });
  }
  for (std::size_t i = 0; i < world_.rocks.size(); ++i)
  {
    const RockSpec& r = world_.rocks[i];
    Eigen::Vector3d c = r.center;
    c.z() += ground_.height(c.x(), c.y());
    rock_center_.push_back(c);
    boxes.push_back({ { HitKind::kRock, static_cast<int>(i) }, c.x() - r.radius, c.y() - r.radius, c.x() + r.radius,
                      c.y() + r.radius });
  }
  for (std::size_t i = 0; i < world_.branches.size(); ++i)
  {
    const BranchSpec& b = world_.branches[i];
    branch_a_.emplace_back(b.a.x(), b.a.y(), ground_.height(b.a.x(), b.a.y()) + b.radius);
    branch_b_.emplace_back(b.b.x(), b.b.y(), ground_.height(b.b.x(), b.b.y()) + b.radius);
    boxes.push_back({ { HitKind::kBranch, static_cast<int>(i) }, std::min(b.a.x(), b.b.x()) - b.radius,
                      std::min(b.a.y(), b.b.y()) - b.radius, std::max(b.a.x(), b.b.x()) + b.radius,
                      std::max(b.a.y(), b.b.y()) + b.radius });
  }
  for (std::size_t i = 0; i < world_.boxes.size(); ++i)
  {
    const BoxSpec& b = world_.boxes[i];
    box_base_z_.push_back(ground_.height(b.x, b.y));
    const double r = 0.5 * std::hypot(b.length, b.width);  // the base's circumscribed circle
    boxes.push_back({ { HitKind::kBox, static_cast<int>(i) }, b.x - r, b.y - r, b.x + r, b.y + r });
  }
  for (std::size_t i = 0; i < world_.saplings.size(); ++i)
  {
    const TrunkSpec& t = world_.saplings[i];
    sapling_base_z_.push_back(ground_.height(t.x, t.y));
    Eigen::Vector3d circle;
    boxes.push_back(stemBounds(t, { HitKind::kSapling, static_cast<int>(i) }, &circle));
    sapling_bound_.push_back(circle);
  }
  for (std::size_t i = 0; i < world_.stubs.size(); ++i)
  {
    const StubSpec& b = world_.stubs[i];
    const double z0 = ground_.height(b.foot.x(), b.foot.y());
    stub_a_.emplace_back(b.a.x(), b.a.y(), b.a.z() + z0);
    stub_b_.emplace_back(b.b.x(), b.b.y(), b.b.z() + z0);
    boxes.push_back({ { HitKind::kStub, static_cast<int>(i) }, std::min(b.a.x(), b.b.x()) - b.radius,
                      std::min(b.a.y(), b.b.y()) - b.radius, std::max(b.a.x(), b.b.x()) + b.radius,
                      std::max(b.a.y(), b.b.y()) + b.radius });
  }
  return boxes;
}

ForestRayCaster::ShapeBounds ForestRayCaster::stemBounds(const TrunkSpec& t, const Shape& shape,
                                                         Eigen::Vector3d* circle)
{
  // The axis may lean: its top is displaced by lean * height (normalised axis is shorter in z).
  const double top_x = t.x + t.lean_x * t.height, top_y = t.y + t.lean_y * t.height;
  const double r = t.radius + kTrunkBuried * t.taper;
  // Bounding circle of the trunk's horizontal footprint over its whole height (for a cheap 2D reject).
  const double half_x = 0.5 * (top_x - t.x), half_y = 0.5 * (top_y - t.y);
  const double bound_r = r + std::hypot(half_x, half_y) + kTrunkBuried * std::hypot(t.lean_x, t.lean_y);
  *circle = Eigen::Vector3d(t.x + half_x, t.y + half_y, bound_r * bound_r);
  return { shape, std::min(t.x, top_x) - r, std::min(t.y, top_y) - r, std::max(t.x, top_x) + r,
           std::max(t.y, top_y) + r };
}

void ForestRayCaster::findTop()
{
  for (std::size_t i = 0; i < world_.trunks.size(); ++i)
    top_z_ = std::max(top_z_, trunk_base_z_[i] + world_.trunks[i].height);
  for (std::size_t i = 0; i < world_.foliage.size(); ++i)
    top_z_ = std::max(top_z_, foliage_center_[i].z() + world_.foliage[i].radius);
  for (std::size_t i = 0; i < world_.rocks.size(); ++i)
    top_z_ = std::max(top_z_, rock_center_[i].z() + world_.rocks[i].radius);
  for (std::size_t i = 0; i < world_.branches.size(); ++i)
    top_z_ = std::max(top_z_, std::max(branch_a_[i].z(), branch_b_[i].z()) + world_.branches[i].radius);
  for (std::size_t i = 0; i < world_.boxes.size(); ++i)
    top_z_ = std::max(top_z_, box_base_z_[i] + world_.boxes[i].height);
  for (std::size_t i = 0; i < world_.saplings.size(); ++i)
    top_z_ = std::max(top_z_, sapling_base_z_[i] + world_.saplings[i].height);
  for (std::size_t i = 0; i < world_.stubs.size(); ++i)
    top_z_ = std::max(top_z_, std::max(stub_a_[i].z(), stub_b_[i].z()) + world_.stubs[i].radius);
  top_z_ += 1e-6;
}

void ForestRayCaster::sizeGrid(const std::vector<ShapeBounds>& boxes)
{
  double min_x = kInf, min_y = kInf, max_x = -kInf, max_y = -kInf;
  auto grow = [&](double x0, double y0, double x1, double y1) {
    min_x = std::min(min_x, x0);
    min_y = std::min(min_y, y0);
    max_x = std::max(max_x, x1);
    max_y = std::max(max_y, y1);
  };
  for (const ShapeBounds& b : boxes)
    grow(b.x0, b.y0, b.x1, b.y1);
  if (boxes.empty())
    grow(0.0, 0.0, cell_, cell_);
  origin_x_ = min_x;
  origin_y_ = min_y;
  nx_ = std::max(1, static_cast<int>(std::ceil((max_x - min_x) / cell_)));
  ny_ = std::max(1, static_cast<int>(std::ceil((max_y - min_y) / cell_)));
  cells_.assign(static_cast<std::size_t>(nx_) * ny_, {});
}

void ForestRayCaster::setHeightRange(ShapeBounds* bounds) const
{
  ShapeBounds& b = *bounds;
  const int i = b.shape.index;
  switch (b.shape.kind)
  {
    case HitKind::kTrunk:
      b.z0 = trunk_base_z_[i] - kTrunkBuried;
      b.z1 = trunk_base_z_[i] + world_.trunks[i].height;
      break;
    case HitKind::kFoliage:
      b.z0 = foliage_center_[i].z() - world_.foliage[i].radius;
      b.z1 = foliage_center_[i].z() + world_.foliage[i].radius;
      break;
    case HitKind::kRock:
      b.z0 = rock_center_[i].z() - world_.rocks[i].radius;
      b.z1 = rock_center_[i].z() + world_.rocks[i].radius;
      break;
    case HitKind::kBranch:
      b.z0 = std::min(branch_a_[i].z(), branch_b_[i].z()) - world_.branches[i].radius;
      b.z1 = std::max(branch_a_[i].z(), branch_b_[i].z()) + world_.branches[i].radius;
      break;
    case HitKind::kBox:
      b.z0 = box_base_z_[i] - kTrunkBuried;
      b.z1 = box_base_z_[i] + world_.boxes[i].height;
      break;
    case HitKind::kSapling:
      b.z0 = sapling_base_z_[i] - kTrunkBuried;
      b.z1 = sapling_base_z_[i] + world_.saplings[i].height;
      break;
    case HitKind::kStub:
      b.z0 = std::min(stub_a_[i].z(), stub_b_[i].z()) - world_.stubs[i].radius;
      b.z1 = std::max(stub_a_[i].z(), stub_b_[i].z()) + world_.stubs[i].radius;
      break;
    default:
      break;
  }
  b.z0 -= 1e-6;
  b.z1 += 1e-6;
}

void ForestRayCaster::insert(const Shape&, double min_x, double min_y, double max_x, double max_y)
{
  const int id = static_cast<int>(shapes_.size()) - 1;
  const int i0 = std::max(0, static_cast<int>(std::floor((min_x - origin_x_) / cell_)));
  const int j0 = std::max(0, static_cast<int>(std::floor((min_y - origin_y_) / cell_)));
  const int i1 = std::min(nx_ - 1, static_cast<int>(std::floor((max_x - origin_x_) / cell_)));
  const int j1 = std::min(ny_ - 1, static_cast<int>(std::floor((max_y - origin_y_) / cell_)));
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i)
      cells_[static_cast<std::size_t>(j) * nx_ + i].push_back(id);
}

double ForestRayCaster::intersectTrunk(const TrunkSpec& trunk, double ground_z, const Eigen::Vector3d& o,
                                       const Eigen::Vector3d& d)
{
  // Cone frustum around the axis p0 + s a, radius r0 - k s, for s in [-buried, height].
  Eigen::Vector3d a(trunk.lean_x, trunk.lean_y, 1.0);
  a.normalize();
  const Eigen::Vector3d p0(trunk.x, trunk.y, ground_z);
  const Eigen::Vector3d w = o - p0;
  const double k = trunk.taper;
  const double da = d.dot(a), wa = w.dot(a), wd = w.dot(d);
  const double c = trunk.radius - k * wa;
  const double qa = 1.0 - da * da - k * k * da * da;
  const double qb = wd - wa * da + c * k * da;
  const double qc = w.squaredNorm() - wa * wa - c * c;
  if (qa < 1e-9)
    return kInf;  // ray (nearly) along the axis: it cannot enter through the side
  const double disc = qb * qb - qa * qc;
  if (disc < 0.0)
    return kInf;
  const double root = std::sqrt(disc);
  for (double t : { (-qb - root) / qa, (-qb + root) / qa })
  {
    if (t <= kMinT)
      continue;
    const double s = wa + t * da;
    if (s >= -kTrunkBuried && s <= trunk.height && trunk.radius - k * s > 0.0)
      return t;
  }
  return kInf;
}

double ForestRayCaster::intersectShape(const Shape& shape, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                       double t_max, Random& random) const
{
  switch (shape.kind)
  {
    case HitKind::kTrunk:
    {
      // 2D reject: the ray's horizontal line passes outside the trunk's bounding circle.
      const Eigen::Vector3d& b = trunk_bound_[shape.index];
      const double wx = b.x() - o.x(), wy = b.y() - o.y();
      const double dd = d.x() * d.x() + d.y() * d.y();
      const double cross = wx * d.y() - wy * d.x();
      if (cross * cross > b.z() * dd)
        return kInf;
    }
      return intersectTrunk(world_.trunks[shape.index], trunk_base_z_[shape.index], o, d);
    case HitKind::kRock:
      return intersectSphere(rock_center_[shape.index], world_.rocks[shape.index].radius, o, d, nullptr);
    case HitKind::kBranch:
      return intersectCapsule(branch_a_[shape.index], branch_b_[shape.index], world_.branches[shape.index].radius, o,
                              d);
    case HitKind::kBox:
      return intersectBox(world_.boxes[shape.index], box_base_z_[shape.index], o, d);
    case HitKind::kSapling:
    {
      const Eigen::Vector3d& b = sapling_bound_[shape.index];
      const double wx = b.x() - o.x(), wy = b.y() - o.y();
      const double cross = wx * d.y() - wy * d.x();
      if (cross * cross > b.z() * (d.x() * d.x() + d.y() * d.y()))
        return kInf;
    }
      return intersectTrunk(world_.saplings[shape.index], sapling_base_z_[shape.index], o, d);
    case HitKind::kStub:
      return intersectCapsule(stub_a_[shape.index], stub_b_[shape.index], world_.stubs[shape.index].radius, o, d);
    case HitKind::kFoliage:
    {
      const FoliageSpec& f = world_.foliage[shape.index];
      double t_exit = 0.0;
      const double t_in = intersectSphere(foliage_center_[shape.index], f.radius, o, d, &t_exit);
      if (t_in >= t_max)
        return kInf;
      // Porous: the ray stops after an exponential free path inside the sphere.
      const double free_path = -f.mean_free_path * std::log(1.0 - random.uniform());
      const double t = t_in + free_path;
      return t < t_exit ? std::max(t, kMinT) : kInf;
    }
    default:
      return kInf;
  }
}

double ForestRayCaster::intersectGround(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_max) const
{
  if (ground_.slope() == Eigen::Vector2d::Zero())
    return intersectRelief(o, d, t_max);
  // z(t) - plane(x(t), y(t)) - relief(x(t), y(t)) = z'(t) - relief(x(t), y(t)) for the ray sheared by the plane
  // (its heights measured from the plane), with the same parameter t: the crossing with the sloping ground is the
  // sheared ray's crossing with the relief, whose bounds (|relief| <= amplitude, its curvature along the ray) hold
  // whatever the slope is.
  const Eigen::Vector2d& s = ground_.slope();
  Eigen::Vector3d o_sheared = o, d_sheared = d;
  o_sheared.z() -= s.dot(o.head<2>());
  d_sheared.z() -= s.dot(d.head<2>());
  return intersectRelief(o_sheared, d_sheared, t_max);
}

double ForestRayCaster::intersectRelief(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_max) const
{
  const double amp = ground_.amplitude();
  double t = 0.0;
  if (o.z() > amp)
  {
    if (d.z() >= 0.0)
      return kInf;
    t = (o.z() - amp) / -d.z();  // first point at which the ray can touch the highest ground
  }
  // f(t) = z(t) - h(x(t), y(t)). Along the ray |f''| <= K = A/W sum (k_i . d_xy)^2, so from any t with f > 0
  // the parabola f + f' s - K s^2 / 2 bounds f from below: its first root is a step that never passes the
  // first crossing (and is Newton's step where the ground is flat). The floor kMinStep bounds the work of
  // grazing rays (a bump thinner than that may be stepped over); a crossing is then refined on its bracket.
  const double curvature = std::max(1e-12, ground_.curvatureBoundAlong(d.x(), d.y()));
  const auto clearance = [&](double s) {
    const Eigen::Vector3d p = o + s * d;
    return p.z() - ground_.relief(p.x(), p.y());
  };
  if (clearance(t) <= 0.0)
    return t <= t_max ? t : kInf;  // starts under ground (only possible at t = 0) or touches at the top
  constexpr double kMinStep = 0.01;
  double t_above = t;
  for (int i = 0; i < 2000; ++i)
  {
    const Eigen::Vector3d p = o + t * d;
    Eigen::Vector2d grad;
    const double f = p.z() - ground_.reliefAndGradient(p.x(), p.y(), &grad);
    if (f <= 0.0)
    {
      // Regula falsi (Illinois variant) on the bracket [t_above, t]: f is nearly linear over it.
      double lo = t_above, hi = t, f_lo = clearance(t_above), f_hi = f;
      int side = 0;
      for (int n = 0; n < 30 && hi - lo > 1e-7; ++n)
      {
        const double mid = hi - f_hi * (hi - lo) / (f_hi - f_lo);
        const double f_mid = clearance(mid);
        if (std::abs(f_mid) < 1e-6)
        {
          hi = mid;
          break;
        }
        if (f_mid > 0.0)
        {
          lo = mid;
          f_lo = f_mid;
          if (side == -1)
            f_hi *= 0.5;
          side = -1;
        }
        else
        {
          hi = mid;
          f_hi = f_mid;
          if (side == 1)
            f_lo *= 0.5;
          side = 1;
        }
      }
      return hi <= t_max ? hi : kInf;
    }
    if (t > t_max)
      return kInf;
    if (d.z() >= 0.0 && o.z() + t * d.z() > amp)
      return kInf;  // climbing above the highest ground
    if (f < 1e-6)
      return t <= t_max ? t : kInf;  // on the ground (the safe steps approach it from above)
    t_above = t;
    const double df = d.z() - grad.dot(d.head<2>());
    const double safe = (df + std::sqrt(df * df + 2.0 * curvature * f)) / curvature;
    t += std::max(safe, kMinStep);
  }
  return kInf;
}

double ForestRayCaster::clipToExtent(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double max_range) const
{
  double best = max_range;
  for (int axis = 0; axis < 2; ++axis)
  {
    const double lo = axis == 0 ? extent_min_x_ : extent_min_y_;
    const double hi = axis == 0 ? extent_max_x_ : extent_max_y_;
    const double p = o[axis], v = d[axis];
    if (v > 1e-15)
      best = std::min(best, (hi - p) / v);
    else if (v < -1e-15)
      best = std::min(best, (lo - p) / v);
    else if (p < lo || p > hi)
      best = -1.0;
  }
  return best;
}

double ForestRayCaster::shapeReach(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double best) const
{
  double t_shapes = best;
  if (d.z() > 1e-12)
    t_shapes = std::min(t_shapes, std::max(0.0, (top_z_ - o.z()) / d.z()));
  else if (o.z() > top_z_)
    t_shapes = -1.0;
  return t_shapes;
}

void ForestRayCaster::nextRayId()
{
  ++ray_id_;
  if (ray_id_ == 0)
  {
    std::fill(mailbox_.begin(), mailbox_.end(), 0);
    ray_id_ = 1;
  }
}

void ForestRayCaster::testCell(int ci, int cj, double t_in, double t_out, RayState* ray)
{
  const Eigen::Vector3d& o = ray->origin;
  const Eigen::Vector3d& d = ray->dir;
  // Within a cell the ray's height runs between its values at the cell's entry and exit; a shape whose
  // height range misses that span is skipped there (and may still be tested in a later cell).
  const double z_a = o.z() + t_in * d.z(), z_b = o.z() + std::min(t_out, ray->best) * d.z();
  const double z_lo = std::min(z_a, z_b), z_hi = std::max(z_a, z_b);
  for (int id : cells_[static_cast<std::size_t>(cj) * nx_ + ci])
  {
    if (mailbox_[id] == ray_id_)
      continue;
    if (z_hi < shape_z_[id].first || z_lo > shape_z_[id].second)
      continue;
    mailbox_[id] = ray_id_;
    const double t = intersectShape(shapes_[id], o, d, ray->best, ray->random);
    if (t < ray->best)
    {
      ray->best = t;
      ray->hit.kind = shapes_[id].kind;
      ray->hit.index = shapes_[id].index;
    }
  }
}

void ForestRayCaster::traverseGrid(double t_shapes, RayState* ray)
{
  const Eigen::Vector3d& o = ray->origin;
  const Eigen::Vector3d& d = ray->dir;
  const double horiz = std::hypot(d.x(), d.y());
  double gx = (o.x() - origin_x_) / cell_, gy = (o.y() - origin_y_) / cell_;
  if (horiz < 1e-9)
  {
    const int ci = static_cast<int>(std::floor(gx)), cj = static_cast<int>(std::floor(gy));
    if (ci >= 0 && cj >= 0 && ci < nx_ && cj < ny_)
      testCell(ci, cj, 0.0, t_shapes, ray);
    return;
  }
  // Parameterise by t (3D distance): the grid coordinate moves at d.xy / cell per unit t.
  const double vx = d.x() / cell_, vy = d.y() / cell_;
  // Clip the traversal to the grid's extent [0, nx] x [0, ny].
  double t0 = 0.0, t1 = t_shapes;
  auto clip = [&](double p, double v, double n) {
    if (std::abs(v) < 1e-15)
      return p >= 0.0 && p <= n;
    double ta = (0.0 - p) / v, tb = (n - p) / v;
    if (ta > tb)
      std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    return t0 <= t1;
  };
  if (!clip(gx, vx, nx_) || !clip(gy, vy, ny_))
    return;
  gx += vx * t0;
  gy += vy * t0;
  int ci = std::min(nx_ - 1, std::max(0, static_cast<int>(std::floor(gx))));
  int cj = std::min(ny_ - 1, std::max(0, static_cast<int>(std::floor(gy))));
  const int step_i = vx > 0 ? 1 : -1, step_j = vy > 0 ? 1 : -1;
  const double dt_x = std::abs(vx) > 1e-15 ? 1.0 / std::abs(vx) : kInf;
  const double dt_y = std::abs(vy) > 1e-15 ? 1.0 / std::abs(vy) : kInf;
  double next_x = std::abs(vx) > 1e-15 ? t0 + ((vx > 0 ? ci + 1 - gx : gx - ci) * dt_x) : kInf;
  double next_y = std::abs(vy) > 1e-15 ? t0 + ((vy > 0 ? cj + 1 - gy : gy - cj) * dt_y) : kInf;
  double t_in = t0;
  while (true)
  {
    const double t_exit = std::min(next_x, next_y);
    testCell(ci, cj, t_in, std::min(t_exit, t1), ray);
    t_in = t_exit;
    if (ray->best <= t_exit || t_exit > t1)
      break;
    if (next_x < next_y)
    {
      ci += step_i;
      next_x += dt_x;
    }
    else
    {
      cj += step_j;
      next_y += dt_y;
    }
    if (ci < 0 || cj < 0 || ci >= nx_ || cj >= ny_)
      break;
  }
}

RayHit ForestRayCaster::cast(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double max_range, Random& random)
{
  RayHit hit;
  // The world ends at the ground's extent (stand bounds + margin): clip the ray to that box in x, y.
  double best = clipToExtent(o, d, max_range);
  if (best <= 0.0)
    return hit;
  // Ground first: a downward ray's ground hit bounds the search among the shapes.
  const double t_ground = intersectGround(o, d, best);
  if (t_ground < best)
  {
    best = t_ground;
    hit.kind = HitKind::kGround;
    hit.index = -1;
    hit.range = best;
  }
  // Above the highest shape nothing is left to hit.
  const double t_shapes = shapeReach(o, d, best);
  if (t_shapes < 0.0 || shapes_.empty())
    return hit;
  nextRayId();
  // 2D grid traversal of the ray's horizontal projection.
  RayState ray{ o, d, random, best, hit };
  traverseGrid(t_shapes, &ray);
  if (ray.hit.kind != HitKind::kNone)
    ray.hit.range = ray.best;
  return ray.hit;
}

}  // namespace sim
}  // namespace rbpf_slam
