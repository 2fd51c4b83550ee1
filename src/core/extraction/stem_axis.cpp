// Stems in a cluster of a sweep as leaning cylinders, found by their vertical continuity (see stem_axis.h).
#include "rbpf_slam/core/extraction/stem_axis.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "rbpf_slam/core/extraction/circle_fit.h"
#include "rbpf_slam/core/extraction/trunk_fit.h"

namespace rbpf_slam
{
namespace core
{
namespace
{
constexpr double kPi = 3.14159265358979323846;
constexpr int kMinSlicePoints = 2;   // inliers that make a slice count for a hypothesis
constexpr int kRefineRounds = 4;     // inlier selections and refits of the best hypothesis
constexpr int kGaussNewtonSteps = 6; // per refit
constexpr int kMaxSamplingTries = 8; // draws of a nearby pair per hypothesis
// [rad] a gap in elevation angle between two points that separates two rings of the sensor (rings of a 64-ring lidar
// lie 0.4 deg = 0.007 rad apart; a ring tilted with the sensor changes its elevation across a stem by far less)
constexpr double kRingGap = 0.004;

/** A leaning cylinder: axis (cx, cy) + lean * (z - z0), radius r. */
struct Cylinder
{
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  Eigen::Vector2d lean = Eigen::Vector2d::Zero();
  double z0 = 0.0;
  double radius = 0.0;

  Eigen::Vector2d axisAt(double z) const { return center + lean * (z - z0); }
  /** Signed distance of @p p to the bark: > 0 outside, < 0 inside. */
  double residual(const Eigen::Vector3d& p) const { return (p.head<2>() - axisAt(p.z())).norm() - radius; }
};

/** The cylinder of @p fit. */
Cylinder cylinderOf(const StemAxisFit& fit)
{
  Cylinder cyl;
  cyl.center = fit.center;
  cyl.lean = fit.lean;
  cyl.z0 = fit.height;
  cyl.radius = fit.radius;
  return cyl;
}

/** What a cylinder explains among the points still in play. */
struct Support
{
  int inliers = 0;
  int interior = 0;
  int slices = 0;
  double coverage = 0.0;  // mean share of the silhouette the slices show
  int see_through = 0;    // cells of the silhouette (on the slices) where the sweep returned from behind the bark
  int silhouette_cells = 0;  // cells of the silhouette looked at
  double score = -std::numeric_limits<double>::infinity();
};

class AxisSearch
{
public:
  AxisSearch(const std::vector<Eigen::Vector3d>& points, const TrunkDetectorConfig& config,
             const NearestReturns* occluders)
    : pts_(points), cfg_(config), occluders_(occluders), active_(points.size(), true)
  {
    // Slices follow the sensor's rings: points ordered by elevation angle, a new slice where the angle jumps by
    // more than kRingGap (between two rings) or the slice would grow thicker than slice_height (a dense cloud). A
    // tilted ring's height changes across a stem; its elevation hardly does.
    std::vector<std::pair<double, int>> order;
    order.reserve(pts_.size());
    elevation_.resize(pts_.size());
    azimuth_.resize(pts_.size());
    for (std::size_t i = 0; i < pts_.size(); ++i)
    {
      elevation_[i] = std::atan2(pts_[i].z(), pts_[i].head<2>().norm());
      azimuth_[i] = std::atan2(pts_[i].y(), pts_[i].x());
      order.emplace_back(elevation_[i], static_cast<int>(i));
    }
    std::sort(order.begin(), order.end());
    slice_.resize(pts_.size());
    int max_slice = 0;
    double prev = order.empty() ? 0.0 : order.front().first;
    double z_start = order.empty() ? 0.0 : pts_[static_cast<std::size_t>(order.front().second)].z();
    for (const auto& e : order)
    {
      const double z = pts_[static_cast<std::size_t>(e.second)].z();
      if (e.first - prev > kRingGap || std::abs(z - z_start) > cfg_.slice_height)
      {
        ++max_slice;
        z_start = z;
      }
      prev = e.first;
      slice_[static_cast<std::size_t>(e.second)] = max_slice;
    }
    slice_count_.assign(static_cast<std::size_t>(max_slice) + 1, 0);
  }

  int remaining() const { return static_cast<int>(std::count(active_.begin(), active_.end(), true)); }

  /** The active points inside @p cyl's bark or within @p band outside it, with the members removed before. */
  std::vector<int> nearOf(const Cylinder& cyl, double band) const
  {
    std::vector<int> near;
    for (std::size_t i = 0; i < pts_.size(); ++i)
      if (cyl.residual(pts_[i]) <= band && (active_[i] || std::abs(cyl.residual(pts_[i])) <= cfg_.ransac_threshold))
        near.push_back(static_cast<int>(i));
    return near;
  }

  void remove(const std::vector<int>& members)
  {
    for (int i : members)
      active_[static_cast<std::size_t>(i)] = false;
  }

  /**
   * What @p cyl explains among the active points. Per slice holding at least kMinSlicePoints inliers, the share of
   * the circle's silhouette (the bearings it covers as seen from the sensor, the origin) that its inliers span,
   * widened by their mean spacing (each stands for a beam): a stem's every ring crosses its whole silhouette
   * (unless something nearer hides part of it), a circle through foliage or across a branch meets a few scattered
   * points. The score counts the inliers, each weighted by its slice's share (a column of consistent
   * cross-sections), less the points inside the bark.
   */
  Support support(const Cylinder& cyl, double bound = -std::numeric_limits<double>::infinity())
  {
    Support s;
    const std::size_t ns = slice_count_.size();
    std::fill(slice_count_.begin(), slice_count_.end(), 0);
    slice_lo_.assign(ns, std::numeric_limits<double>::infinity());
    slice_hi_.assign(ns, -std::numeric_limits<double>::infinity());
    slice_elevation_.assign(ns, 0.0);
    slice_z_.assign(ns, 0.0);
    const bool upright = cyl.lean.isZero();
    const double axis_azimuth = std::atan2(cyl.center.y(), cyl.center.x());
    for (std::size_t i = 0; i < pts_.size(); ++i)
    {
      if (!active_[i])
        continue;
      const Eigen::Vector3d& p = pts_[i];
      const Eigen::Vector2d axis = cyl.axisAt(p.z());
      const double e = (p.head<2>() - axis).norm() - cyl.radius;
      if (std::abs(e) <= cfg_.ransac_threshold)
      {
        ++s.inliers;
        const std::size_t k = static_cast<std::size_t>(slice_[i]);
        ++slice_count_[k];
        // Bearing relative to the axis' (no wrap-around: both lie within a trunk's width).
        double rel = upright ? azimuth_[i] - axis_azimuth
                             : std::atan2(axis.x() * p.y() - axis.y() * p.x(), axis.dot(p.head<2>()));
        if (rel > kPi)
          rel -= 2.0 * kPi;
        else if (rel < -kPi)
          rel += 2.0 * kPi;
        slice_elevation_[k] += elevation_[i];
        slice_z_[k] += p.z();
        slice_lo_[k] = std::min(slice_lo_[k], rel);
        slice_hi_[k] = std::max(slice_hi_[k], rel);
      }
      else if (e < -cfg_.ransac_threshold)
        ++s.interior;
    }
    const double d = cyl.center.norm();
    const double width = d > cyl.radius ? 2.0 * std::asin(cyl.radius / d) : 2.0 * kPi;
    double sum = 0.0, weighted = 0.0;
    for (std::size_t k = 0; k < ns; ++k)
    {
      const int n = slice_count_[k];
      if (n < kMinSlicePoints)
        continue;
      ++s.slices;
      const double share = std::min(1.0, (slice_hi_[k] - slice_lo_[k]) * n / (n - 1) / width);
      sum += share;
      weighted += share * n;
    }
    s.coverage = s.slices > 0 ? sum / s.slices : 0.0;
    // The beams through the silhouette only lower the score: not counted where it cannot exceed @p bound.
    if (occluders_ && weighted - s.interior > bound)
      countSeeThrough(cyl, &s);
    s.score = weighted - s.interior - s.see_through;
    return s;
  }

  /** The active points within the threshold of @p cyl (an upper bound of support()'s score). */
  int countInliers(const Cylinder& cyl) const
  {
    int n = 0;
    for (std::size_t i = 0; i < pts_.size(); ++i)
      n += active_[i] && std::abs(cyl.residual(pts_[i])) <= cfg_.ransac_threshold ? 1 : 0;
    return n;
  }

  /** RANSAC over upright circles of three nearby points; false when no hypothesis has a trunk's radius. */
  bool bestHypothesis(Random* rng, Cylinder* best)
  {
    std::vector<int> idx;
    for (std::size_t i = 0; i < pts_.size(); ++i)
      if (active_[i])
        idx.push_back(static_cast<int>(i));
    const int n = static_cast<int>(idx.size());
    if (n < 3)
      return false;
    const double reach2 = std::pow(2.0 * cfg_.max_radius, 2);
    Support best_support;
    for (int it = 0; it < cfg_.ransac_iterations; ++it)
    {
      const Eigen::Vector3d& a = pts_[static_cast<std::size_t>(idx[rng->uniformIndex(n)])];
      const Eigen::Vector3d* bc[2] = { nullptr, nullptr };
      for (int k = 0, tries = 0; k < 2 && tries < kMaxSamplingTries * 2; ++tries)
      {
        const Eigen::Vector3d& q = pts_[static_cast<std::size_t>(idx[rng->uniformIndex(n)])];
        if (&q != &a && (k == 0 || &q != bc[0]) && (q.head<2>() - a.head<2>()).squaredNorm() < reach2)
          bc[k++] = &q;
      }
      if (!bc[1])
        continue;
      Cylinder cyl;
      if (!circleThrough(a.head<2>(), bc[0]->head<2>(), bc[1]->head<2>(), &cyl.center, &cyl.radius) ||
          cyl.radius < cfg_.min_radius || cyl.radius > cfg_.max_radius)
        continue;
      // score <= inliers: a hypothesis with no more inliers than the best score cannot beat it.
      if (best_support.inliers > 0 && countInliers(cyl) <= best_support.score)
        continue;
      const Support s = support(cyl, best_support.score);
      if (s.score > best_support.score)
      {
        best_support = s;
        *best = cyl;
      }
    }
    return best_support.inliers > 0;
  }

  /** The active points within the threshold of @p cyl. */
  std::vector<int> inliersOf(const Cylinder& cyl, double band = -1.0) const
  {
    if (band < 0.0)
      band = cfg_.ransac_threshold;
    std::vector<int> in;
    for (std::size_t i = 0; i < pts_.size(); ++i)
      if (active_[i] && std::abs(cyl.residual(pts_[i])) <= band)
        in.push_back(static_cast<int>(i));
    return in;
  }

  /**
   * The inlier band for the next refit: three robust standard deviations (1.4826 median absolute residual) of
   * @p members around @p cyl, within [ransac_threshold / 2, ransac_threshold]. Bark closer to the noise than the
   * threshold then keeps a touching neighbour's points or a branch's base out of the fit.
   */
  double adaptiveBand(const Cylinder& cyl, const std::vector<int>& members) const
  {
    if (members.size() < 5)
      return cfg_.ransac_threshold;
    std::vector<double> r;
    r.reserve(members.size());
    for (int i : members)
      r.push_back(std::abs(cyl.residual(pts_[static_cast<std::size_t>(i)])));
    const std::size_t m = r.size() / 2;
    std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(m), r.end());
    return std::min(cfg_.ransac_threshold, std::max(0.5 * cfg_.ransac_threshold, 3.0 * 1.4826 * r[m]));
  }

  /**
   * Gauss-Newton for (cx, cy, lean x, lean y, r) on @p members, z0 their mean height; priors on the radius and the
   * lean. Fills the covariance of (cx, cy, r) at z0 (the data part scaled by the residuals' spread where it exceeds
   * the sensor's noise). False when the normal equations are singular.
   */
  bool refine(const std::vector<int>& members, Cylinder* cyl, Eigen::Matrix3d* cov) const
  {
    if (members.size() < 5)
      return false;
    double z0 = 0.0;
    for (int i : members)
      z0 += pts_[static_cast<std::size_t>(i)].z();
    z0 /= static_cast<double>(members.size());
    cyl->center = cyl->axisAt(z0);
    cyl->z0 = z0;
    const double w = 1.0 / (cfg_.range_sigma * cfg_.range_sigma);
    const double w_r = 1.0 / (cfg_.arc_radius_sigma * cfg_.arc_radius_sigma);
    const double w_lean = 1.0 / std::pow(0.5 * cfg_.max_stem_lean, 2);
    Eigen::Matrix<double, 5, 5> H;
    for (int step = 0; step < kGaussNewtonSteps; ++step)
    {
      H.setZero();
      Eigen::Matrix<double, 5, 1> g = Eigen::Matrix<double, 5, 1>::Zero();
      for (int i : members)
      {
        const Eigen::Vector3d& p = pts_[static_cast<std::size_t>(i)];
        const Eigen::Vector2d d = p.head<2>() - cyl->axisAt(p.z());
        const double dn = d.norm();
        if (!(dn > 1e-9))
          continue;
        const Eigen::Vector2d u = d / dn;
        const double dz = p.z() - z0;
        Eigen::Matrix<double, 5, 1> J;
        J << -u.x(), -u.y(), -u.x() * dz, -u.y() * dz, -1.0;
        const double e = dn - cyl->radius;
        H += w * J * J.transpose();
        g += w * J * e;
      }
      H(2, 2) += w_lean;
      H(3, 3) += w_lean;
      H(4, 4) += w_r;
      g(2) += w_lean * cyl->lean.x();
      g(3) += w_lean * cyl->lean.y();
      g(4) += w_r * (cyl->radius - cfg_.arc_radius_prior);
      const Eigen::Matrix<double, 5, 1> delta = H.ldlt().solve(-g);
      if (!delta.allFinite())
        return false;
      cyl->center += delta.head<2>();
      cyl->lean += delta.segment<2>(2);
      cyl->radius += delta(4);
      if (delta.norm() < 1e-6)
        break;
    }
    double ss = 0.0;
    for (int i : members)
      ss += std::pow(cyl->residual(pts_[static_cast<std::size_t>(i)]), 2);
    const double dof = std::max(1.0, static_cast<double>(members.size()) - 5.0);
    const double scale = std::max(1.0, ss / dof * w);
    Eigen::Matrix<double, 5, 5> Hd = H;
    Hd(2, 2) -= w_lean;
    Hd(3, 3) -= w_lean;
    Hd(4, 4) -= w_r;
    Hd /= scale;
    Hd(2, 2) += w_lean;
    Hd(3, 3) += w_lean;
    Hd(4, 4) += w_r;
    const Eigen::Matrix<double, 5, 5> full = Hd.inverse();
    if (!full.allFinite() || !(cyl->radius > 0.0))
      return false;
    const int keep[3] = { 0, 1, 4 };
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        (*cov)(r, c) = full(keep[r], keep[c]);
    return true;
  }

  /** Counts and spans of @p cyl's inliers into @p fit. */
  void describe(const Cylinder& cyl, StemAxisFit* fit)
  {
    described_ = support(cyl);
    const Support& s = described_;
    fit->members = inliersOf(cyl);
    fit->inliers = static_cast<int>(fit->members.size());
    fit->slices = s.slices;
    fit->coverage = s.coverage;
    fit->interior = s.interior;
    fit->z_lo = std::numeric_limits<double>::infinity();
    fit->z_hi = -std::numeric_limits<double>::infinity();
    std::vector<Eigen::Vector2d> levelled;
    levelled.reserve(fit->members.size());
    for (int i : fit->members)
    {
      const Eigen::Vector3d& p = pts_[static_cast<std::size_t>(i)];
      fit->z_lo = std::min(fit->z_lo, p.z());
      fit->z_hi = std::max(fit->z_hi, p.z());
      levelled.push_back(p.head<2>() - cyl.lean * (p.z() - cyl.z0));
    }
    double ss = 0.0;
    for (int i : fit->members)
      ss += std::pow(cyl.residual(pts_[static_cast<std::size_t>(i)]), 2);
    fit->rms = fit->members.empty() ? 0.0 : std::sqrt(ss / fit->members.size());
    fit->arc_angle = levelled.empty() ? 0.0 : subtendedAngle(levelled, cyl.center);
    fit->center = cyl.center;
    fit->height = cyl.z0;
    fit->lean = cyl.lean;
    fit->radius = cyl.radius;
  }

  /**
   * Points of the cluster the stem's bark would hide from the sensor (the origin): within its silhouette (the
   * bearings its circle covers at the point's height, narrowed by the threshold at each side) and behind its front
   * surface by more than the threshold. Foliage and bushes return from inside and behind any circle fitted to their
   * front; a stem hides what stands behind it.
   */
  int shadowedPoints(const StemAxisFit& fit) const
  {
    int hidden = 0;
    const double inner = fit.radius - cfg_.ransac_threshold;
    if (!(inner > 0.0))
      return 0;
    for (const Eigen::Vector3d& p : pts_)
    {
      const Eigen::Vector2d axis = fit.center + fit.lean * (p.z() - fit.height);
      const double d = axis.norm();
      const double range = p.head<2>().norm();
      if (!(d > fit.radius) || !(range > 0.0))
        continue;
      // Distance of the axis from the point's line of sight, and the axis' depth along it.
      const Eigen::Vector2d ray = p.head<2>() / range;
      const double along = ray.dot(axis);
      const double across = std::abs(ray.x() * axis.y() - ray.y() * axis.x());
      if (along <= 0.0 || across >= inner)
        continue;
      const double front = along - std::sqrt(fit.radius * fit.radius - across * across);
      if (range > front + 2.0 * cfg_.ransac_threshold)
        ++hidden;
    }
    return hidden;
  }

  /**
   * Free space behind the bark: on each slice counted in @p s, the cells of the sweep's nearest returns within the
   * circle's silhouette (narrowed by a cell at each side) whose nearest return lies behind the circle's
   * front by more than twice the threshold: the beam went through where the stem would stand. Cells without a
   * return say nothing.
   */
  void countSeeThrough(const Cylinder& cyl, Support* s) const
  {
    const double step = occluders_->azimuthCell();
    for (std::size_t k = 0; k < slice_count_.size(); ++k)
    {
      const int n = slice_count_[k];
      if (n < kMinSlicePoints)
        continue;
      const Eigen::Vector2d axis = cyl.axisAt(slice_z_[k] / n);
      const double d = axis.norm();
      if (!(d > cyl.radius))
        continue;
      const double half = std::asin(cyl.radius / d) - step;
      const double bearing = std::atan2(axis.y(), axis.x());
      const double elevation = slice_elevation_[k] / n;
      // sin and cos of a by rotating through the steps.
      const double cos_step = std::cos(step), sin_step = std::sin(step);
      double cos_a = std::cos(-half + 0.5 * step), sin_a = std::sin(-half + 0.5 * step);
      for (double a = -half + 0.5 * step; a < half; a += step)
      {
        const double c = cos_a, sn = sin_a;
        cos_a = c * cos_step - sn * sin_step;
        sin_a = sn * cos_step + c * sin_step;
        const double nearest = occluders_->nearest(elevation, bearing + a);
        if (!std::isfinite(nearest))
          continue;
        ++s->silhouette_cells;
        const double across = d * sn;
        const double front = d * c - std::sqrt(std::max(0.0, cyl.radius * cyl.radius - across * across));
        if (nearest > front + 2.0 * cfg_.ransac_threshold)
          ++s->see_through;
      }
    }
  }

  /**
   * The share of the silhouette cells of the stem last described (describe()) where the sweep saw through it
   * (countSeeThrough()); 0 without any.
   */
  double seeThroughShare() const
  {
    const Support& s = described_;
    return s.silhouette_cells > 0 ? static_cast<double>(s.see_through) / s.silhouette_cells : 0.0;
  }

  /**
   * Like Support::coverage, but the part of the silhouette outside a slice's inliers where the sweep returned from
   * nearer than the stem's front (occluders_) counts as shown. Equal to @p fit's coverage without occluders.
   * @p fit must be the stem last described (describe()): its slices are those support() left.
   */
  double visibleCoverage(const StemAxisFit& fit) const
  {
    const Cylinder cyl = cylinderOf(fit);
    const Support& s = described_;
    if (!occluders_ || s.slices == 0)
      return s.coverage;
    const double step = occluders_->azimuthCell();
    double sum = 0.0;
    for (std::size_t k = 0; k < slice_count_.size(); ++k)
    {
      const int n = slice_count_[k];
      if (n < kMinSlicePoints)
        continue;
      const Eigen::Vector2d axis = cyl.axisAt(slice_z_[k] / n);
      const double d = axis.norm();
      if (!(d > cyl.radius))
      {
        sum += 1.0;
        continue;
      }
      // The inliers' bearings are relative to the axis at their own height, as in support().
      const double half = std::asin(cyl.radius / d);
      const double bearing = std::atan2(axis.y(), axis.x());
      const double front = d - cyl.radius - cfg_.ransac_threshold;
      const double widen = 0.5 * (slice_hi_[k] - slice_lo_[k]) / (n - 1);
      const double lo = slice_lo_[k] - widen, hi = slice_hi_[k] + widen;
      const double elevation = slice_elevation_[k] / n;
      double shown = std::min(hi, half) - std::max(lo, -half);
      for (double a = -half + 0.5 * step; a < half; a += step)
        if ((a < lo || a > hi) && occluders_->nearest(elevation, bearing + a) < front)
          shown += step;
      sum += std::min(1.0, std::max(0.0, shown) / (2.0 * half));
    }
    return sum / s.slices;
  }

  /**
   * Two touching trunks whose fronts make one shallow arc fit one wide cylinder: fitTrunkPair() on the horizontal
   * projection (along the axis' lean) of the points @p near it, as for a cluster (its tests decide). The two stems,
   * or none.
   */
  std::vector<StemAxisFit> splitTouching(const StemAxisFit& fit, const std::vector<int>& near) const
  {
    std::vector<StemAxisFit> parts;
    if (near.size() < 2 * static_cast<std::size_t>(std::max(cfg_.min_fit_points, cfg_.min_points)))
      return parts;
    std::vector<Eigen::Vector2d> p2;
    p2.reserve(near.size());
    for (int i : near)
    {
      const Eigen::Vector3d& p = pts_[static_cast<std::size_t>(i)];
      p2.push_back(p.head<2>() - fit.lean * (p.z() - fit.height));
    }
    TrunkFit single;
    single.ok = true;
    single.center = fit.center;
    single.radius = fit.radius;
    single.covariance = fit.covariance;
    single.inliers = fit.inliers;
    single.arc_angle = fit.arc_angle;
    const TrunkRejection rejection = checkTrunkFit(single, static_cast<int>(p2.size()), cfg_);
    if (!isPoorSingleFit(p2, single, rejection, cfg_))
      return parts;
    const TrunkPairFit pair = fitTrunkPair(p2, single, cfg_);
    if (!pair.ok)
      return parts;
    for (int k = 0; k < 2; ++k)
    {
      StemAxisFit part = fit;
      part.center = pair.fits[k].center;
      part.radius = pair.fits[k].radius;
      part.covariance = pair.fits[k].covariance;
      part.arc_angle = pair.fits[k].arc_angle;
      part.members.clear();
      part.z_lo = std::numeric_limits<double>::infinity();
      part.z_hi = -std::numeric_limits<double>::infinity();
      for (int j : pair.members[k])
      {
        const int i = near[static_cast<std::size_t>(j)];
        part.members.push_back(i);
        part.z_lo = std::min(part.z_lo, pts_[static_cast<std::size_t>(i)].z());
        part.z_hi = std::max(part.z_hi, pts_[static_cast<std::size_t>(i)].z());
      }
      part.inliers = static_cast<int>(part.members.size());
      parts.push_back(std::move(part));
    }
    return parts;
  }

  /** Whether the sensor (the origin) sees the inliers in front of the axis: their mean range is the shorter. */
  bool axisBehindPoints(const StemAxisFit& fit) const
  {
    double range = 0.0;
    for (int i : fit.members)
    {
      const Eigen::Vector3d& p = pts_[static_cast<std::size_t>(i)];
      range += (p.head<2>() - fit.lean * (p.z() - fit.height)).norm();
    }
    return range / static_cast<double>(fit.members.size()) < fit.center.norm();
  }

private:
  const std::vector<Eigen::Vector3d>& pts_;
  const TrunkDetectorConfig& cfg_;
  const NearestReturns* occluders_;
  std::vector<bool> active_;
  std::vector<int> slice_;
  std::vector<double> elevation_, azimuth_;  // each point's elevation and azimuth angles from the sensor
  std::vector<int> slice_count_;
  std::vector<double> slice_lo_, slice_hi_, slice_elevation_, slice_z_;
  Support described_;  // support() of the stem last described
};

/** Whether @p fit overlaps a stem of @p stems: two stems stand side by side, their bark at most touching. */
bool overlapsAny(const StemAxisFit& fit, const std::vector<StemAxisFit>& stems, const TrunkDetectorConfig& cfg)
{
  for (const auto& s : stems)
  {
    const Eigen::Vector2d other = s.center + s.lean * (fit.height - s.height);
    if ((fit.center - other).norm() < fit.radius + s.radius - cfg.ransac_threshold)
      return true;
  }
  return false;
}

/** Why @p fit is no stem (kNone: it is one). */
StemAxisRejection judge(const StemAxisFit& fit, const AxisSearch& search, const TrunkDetectorConfig& cfg)
{
  // min_radius tells a tree from a sapling and max_radius bounds the stems looked for; a fit within two of its
  // standard deviations below the one or above the other may be of a stem within (a stem of 8 cm DBH seen over a
  // few points a ring fits 3.5-4.5 cm).
  const double radius_margin = 2.0 * std::sqrt(std::max(0.0, fit.covariance(2, 2)));
  if (fit.radius + radius_margin < cfg.min_radius || fit.radius - radius_margin > cfg.max_radius)
    return StemAxisRejection::kRadius;
  const double range = fit.center.norm();
  if (range < cfg.min_range || range > cfg.max_range)
    return StemAxisRejection::kShape;
  if (fit.inliers < cfg.min_points)
    return StemAxisRejection::kInliers;
  if (fit.slices < cfg.min_slices || fit.z_hi - fit.z_lo < cfg.min_vertical_extent ||
      fit.lean.norm() > std::tan(cfg.max_stem_lean))
    return StemAxisRejection::kShape;
  if (cfg.seen_from_all_sides ? fit.interior > cfg.max_interior_share * fit.inliers :
                                 (search.shadowedPoints(fit) > cfg.max_interior_share * fit.inliers ||
                                  search.seeThroughShare() > cfg.max_see_through))
    return StemAxisRejection::kClutter;
  // One sensor sees at most the half of a stem facing it. At the silhouette the beam grazes the bark, so range
  // noise moves a point along the bark's tangent, as far as it stays within the inlier band b (sqrt(2 r b + b^2)),
  // which widens the arc by the angle that subtends at the axis on each side.
  const double b = cfg.ransac_threshold;
  const double slide = std::sqrt(2.0 * fit.radius * b + b * b);
  if (!cfg.seen_from_all_sides && fit.arc_angle > kPi + 2.0 * std::atan(slide / fit.radius))
    return StemAxisRejection::kShape;
  if (!cfg.seen_from_all_sides &&
      (!search.axisBehindPoints(fit) || search.visibleCoverage(fit) < cfg.min_silhouette_coverage))
    return StemAxisRejection::kShape;
  return StemAxisRejection::kNone;
}
}  // namespace

std::vector<StemAxisFit> fitStemAxes(const std::vector<Eigen::Vector3d>& points, const TrunkDetectorConfig& config,
                                     Random* rng, StemAxisRejection* last, const NearestReturns* occluders)
{
  std::vector<StemAxisFit> stems;
  StemAxisRejection why = StemAxisRejection::kNone;
  AxisSearch search(points, config, occluders);
  // A rejected hypothesis (a shrub, a branch clump) takes its points out of play too, so that a stem behind it in
  // the same cluster is still looked for.
  for (int attempt = 0;
       attempt < 2 * config.max_stems_per_cluster && static_cast<int>(stems.size()) < config.max_stems_per_cluster;
       ++attempt)
  {
    if (search.remaining() < config.min_points)
    {
      why = StemAxisRejection::kSize;
      break;
    }
    Cylinder cyl;
    if (!search.bestHypothesis(rng, &cyl))
    {
      why = StemAxisRejection::kRadius;
      break;
    }
    StemAxisFit fit;
    bool refined = false;
    double band = config.ransac_threshold;
    for (int round = 0; round < kRefineRounds; ++round)
    {
      const std::vector<int> in = search.inliersOf(cyl, band);
      if (round > 0)
        band = search.adaptiveBand(cyl, in);
      Cylinder next = cyl;
      Eigen::Matrix3d cov;
      if (!search.refine(in, &next, &cov))
        break;
      cyl = next;
      fit.covariance = cov;
      refined = true;
    }
    if (!refined)
    {
      why = StemAxisRejection::kInliers;
      break;
    }
    search.describe(cyl, &fit);
    why = judge(fit, search, config);
    if (why == StemAxisRejection::kNone && overlapsAny(fit, stems, config))
      why = StemAxisRejection::kShape;
    if (fit.members.empty())
      break;
    search.remove(fit.members);
    if (why != StemAxisRejection::kNone)
      continue;
    // The noise's tails and what lies inside the bark belong to this stem too: they must not make a second one.
    // With them, a wide cylinder over two touching trunks explains its points poorly, and they split it.
    const std::vector<int> near = search.nearOf(cyl, 2.0 * config.ransac_threshold);
    search.remove(near);
    fit.ok = true;
    std::vector<StemAxisFit> parts = search.splitTouching(fit, near);
    for (auto& part : parts)
      stems.push_back(std::move(part));
    if (parts.empty())
      stems.push_back(std::move(fit));
  }
  if (last)
    *last = why;
  return stems;
}

NearestReturns::NearestReturns(double elevation_cell, double azimuth_cell)
  : elevation_cell_(elevation_cell), azimuth_cell_(azimuth_cell)
{
}

std::int64_t NearestReturns::key(double elevation, double azimuth) const
{
  double a = azimuth;
  if (a < -kPi || a >= kPi)
    a -= 2.0 * kPi * std::floor((a + kPi) / (2.0 * kPi));
  const auto ie = static_cast<std::int64_t>(std::floor(elevation / elevation_cell_));
  const auto ia = static_cast<std::int64_t>(std::floor((a + kPi) / azimuth_cell_));
  return ie * 1000003 + ia;
}

void NearestReturns::build(const std::vector<Eigen::Vector3d>& points)
{
  nearest_.clear();
  for (const auto& p : points)
  {
    const double range = p.head<2>().norm();
    if (!(range > 0.0))
      continue;
    const std::int64_t k = key(std::atan2(p.z(), range), std::atan2(p.y(), p.x()));
    const auto it = nearest_.find(k);
    if (it == nearest_.end())
      nearest_.emplace(k, static_cast<float>(range));
    else
      it->second = std::min(it->second, static_cast<float>(range));
  }
}

double NearestReturns::nearest(double elevation, double azimuth) const
{
  const auto it = nearest_.find(key(elevation, azimuth));
  return it == nearest_.end() ? std::numeric_limits<double>::infinity() : static_cast<double>(it->second);
}

TrunkObservation toTrunkObservation(const StemAxisFit& fit, int num_points)
{
  TrunkFit t;
  t.ok = fit.ok;
  t.center = fit.center;
  t.radius = fit.radius;
  t.covariance = fit.covariance;
  t.inliers = fit.inliers;
  t.arc_angle = fit.arc_angle;
  t.method = TrunkMethod::kCircle;
  return toTrunkObservation(t, num_points, fit.height);
}

}  // namespace core
}  // namespace rbpf_slam
