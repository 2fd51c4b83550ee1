#include "rbpf_slam/core/extraction/stem_columns.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <utility>

#include "rbpf_slam/core/extraction/circle_fit.h"
#include "rbpf_slam/core/extraction/ground_model.h"

namespace rbpf_slam
{
namespace core
{
namespace
{
constexpr double kPi = 3.14159265358979323846;
constexpr int kSectors = 24;               // coverage is counted in sectors of 15°
constexpr long kMaxGroundCells = 4000000;  // a larger grid doubles its cell (a stray point far away)
constexpr std::size_t kLowestKept = 64;    // a cell's ground is looked for among its lowest heights
constexpr double kMinFitBand = 0.005;      // [m] the last refit's band is at least this

bool positive(double v)
{
  return std::isfinite(v) && v > 0.0;
}

bool finite(const Eigen::Vector3f& p)
{
  return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z());
}

int sliceCount(const StemColumnsConfig& c)
{
  return static_cast<int>(std::floor((c.slice_max - c.slice_min) / c.slice_step + 1e-9)) + 1;
}
}  // namespace

std::string StemColumnsConfig::validate() const
{
  if (!positive(ground_cell) || !positive(ground_band) || !positive(ground_search))
    return "ground_cell, ground_band and ground_search must be > 0";
  if (ground_min_points < 1)
    return "ground_min_points must be >= 1";
  if (!(max_ground_slope >= 0.0) || !std::isfinite(max_ground_slope))
    return "max_ground_slope must be >= 0";
  if (std::isinf(ground_height))
    return "ground_height must be finite (or NaN: from the cloud)";
  if (!std::isfinite(slice_min) || !std::isfinite(slice_max) || !(slice_max >= slice_min))
    return "slice_max must be >= slice_min";
  if (!positive(slice_step) || !positive(slice_thickness) || slice_thickness > slice_step)
    return "slice_step must be > 0 and slice_thickness in (0, slice_step]";
  if (!positive(cluster_tolerance) || min_cluster_points < 3)
    return "cluster_tolerance must be > 0 and min_cluster_points >= 3";
  if (!positive(min_dbh) || !(max_dbh > min_dbh) || !std::isfinite(max_dbh))
    return "min_dbh must be > 0 and max_dbh > min_dbh";
  if (!positive(inlier_band) || ransac_iterations < 1 || min_inliers < 3)
    return "inlier_band must be > 0, ransac_iterations >= 1 and min_inliers >= 3";
  if (!(min_coverage >= 0.0 && min_coverage <= 1.0) || !(min_coverage_sensor >= 0.0 && min_coverage_sensor <= 1.0))
    return "min_coverage and min_coverage_sensor must be in [0, 1]";
  if (!(max_interior_share >= 0.0) || max_circles_per_cluster < 1)
    return "max_interior_share must be >= 0 and max_circles_per_cluster >= 1";
  if (!positive(dbh_window))
    return "dbh_window must be > 0";
  if (!(max_lean_deg >= 0.0 && max_lean_deg < 80.0))
    return "max_lean_deg must be in [0, 80)";
  if (!positive(centre_tolerance) || !positive(radius_tolerance) || !(radius_tolerance_share >= 0.0) ||
      !(max_taper >= 0.0))
    return "centre_tolerance and radius_tolerance must be > 0, radius_tolerance_share and max_taper >= 0";
  if (!(max_gap >= 0.0) || !std::isfinite(max_gap) || min_slices < 3)
    return "max_gap must be >= 0 and min_slices >= 3";
  if (!std::isfinite(breast_height))
    return "breast_height must be finite";
  if (has_sensor && !sensor.allFinite())
    return "sensor must be finite";
  return "";
}

// --- Ground -----------------------------------------------------------------------------------------------------

float lowestDenseHeight(float* z, std::size_t n, int min_points, double band)
{
  if (n == 0)
    return std::numeric_limits<float>::quiet_NaN();
  const std::size_t k = std::min(n, kLowestKept);
  std::partial_sort(z, z + k, z + n);
  const std::size_t m = std::min<std::size_t>(static_cast<std::size_t>(std::max(1, min_points)), k);
  for (std::size_t i = 0; i + m <= k; ++i)
    if (z[i + m - 1] - z[i] <= band)
      return std::accumulate(z + i, z + i + m, 0.0f) / static_cast<float>(m);
  return z[0];
}

void GroundGrid::build(const std::vector<Eigen::Vector3f>& points, const StemColumnsConfig& config)
{
  double x_min = std::numeric_limits<double>::infinity(), y_min = x_min;
  double x_max = -x_min, y_max = -x_min;
  for (const auto& p : points)
    if (finite(p))
    {
      x_min = std::min<double>(x_min, p.x());
      x_max = std::max<double>(x_max, p.x());
      y_min = std::min<double>(y_min, p.y());
      y_max = std::max<double>(y_max, p.y());
    }
  ground_.clear();
  nx_ = ny_ = 0;
  flat_ = std::isfinite(config.ground_height) ? config.ground_height : 0.0;
  if (!(x_max >= x_min))
    return;
  cell_ = config.ground_cell;
  while (true)
  {
    nx_ = static_cast<long>(std::floor((x_max - x_min) / cell_)) + 1;
    ny_ = static_cast<long>(std::floor((y_max - y_min) / cell_)) + 1;
    if (nx_ * ny_ <= kMaxGroundCells)
      break;
    cell_ *= 2.0;
  }
  x0_ = x_min;
  y0_ = y_min;
  // The heights sorted by cell (counting sort), then each cell's lowest dense height.
  const std::size_t cells = static_cast<std::size_t>(nx_ * ny_);
  std::vector<std::uint32_t> start(cells + 1, 0);
  std::vector<std::uint32_t> cell_of(points.size(), 0);
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    const auto& p = points[i];
    if (!finite(p))
      continue;
    const long ix = std::min(nx_ - 1, static_cast<long>((p.x() - x0_) / cell_));
    const long iy = std::min(ny_ - 1, static_cast<long>((p.y() - y0_) / cell_));
    cell_of[i] = static_cast<std::uint32_t>(iy * nx_ + ix);
    ++start[cell_of[i] + 1];
  }
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<float> z(start.back());
  std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
  for (std::size_t i = 0; i < points.size(); ++i)
    if (finite(points[i]))
      z[fill[cell_of[i]]++] = points[i].z();
  std::vector<std::uint32_t>().swap(cell_of);
  std::vector<float> lowest(cells);
  for (std::size_t c = 0; c < cells; ++c)
    lowest[c] =
        lowestDenseHeight(z.data() + start[c], start[c + 1] - start[c], config.ground_min_points, config.ground_band);
  fillFromNeighbours(lowest, config);
}

namespace
{
/**
 * @brief Chamfer sweeps over a grid, forward and back, twice: @p relax(cell, neighbour, step) updates a cell from a
 * neighbour @p step metres away.
 */
template <typename Relax>
void chamferSweeps(long nx, long ny, double cell, Relax relax)
{
  const std::array<std::array<long, 2>, 4> forward = { { { -1, -1 }, { 0, -1 }, { 1, -1 }, { -1, 0 } } };
  const auto visit = [&](long ix, long iy, long sign)
  {
    for (const auto& d : forward)
    {
      const long jx = ix + sign * d[0], jy = iy + sign * d[1];
      if (jx >= 0 && jy >= 0 && jx < nx && jy < ny)
        relax(static_cast<std::size_t>(iy * nx + ix), static_cast<std::size_t>(jy * nx + jx),
              cell * std::hypot(static_cast<double>(d[0]), static_cast<double>(d[1])));
    }
  };
  for (int round = 0; round < 2; ++round)
  {
    for (long iy = 0; iy < ny; ++iy)
      for (long ix = 0; ix < nx; ++ix)
        visit(ix, iy, 1);
    for (long iy = ny - 1; iy >= 0; --iy)
      for (long ix = nx - 1; ix >= 0; --ix)
        visit(ix, iy, -1);
  }
}
}  // namespace

void GroundGrid::fillFromNeighbours(const std::vector<float>& lowest, const StemColumnsConfig& config)
{
  const std::size_t cells = lowest.size();
  const double inf = std::numeric_limits<double>::infinity();
  // A cell shows ground when no neighbour's ground plus the slope over the way lies below its lowest points.
  std::vector<double> capped(cells);
  for (std::size_t c = 0; c < cells; ++c)
    capped[c] = std::isnan(lowest[c]) ? inf : lowest[c];
  chamferSweeps(nx_, ny_, cell_,
                [&](std::size_t c, std::size_t n, double step)
                { capped[c] = std::min(capped[c], capped[n] + config.max_ground_slope * step); });
  // Other cells (under a stem or a shrub, or empty) take the ground of the nearest cell that shows it.
  std::vector<double> value(cells, inf), distance(cells, inf), ground_values;
  for (std::size_t c = 0; c < cells; ++c)
    if (!std::isnan(lowest[c]) && capped[c] >= lowest[c] - 1e-6)
    {
      value[c] = lowest[c];
      distance[c] = 0.0;
      ground_values.push_back(value[c]);
    }
  chamferSweeps(nx_, ny_, cell_,
                [&](std::size_t c, std::size_t n, double step)
                {
                  if (distance[n] + step < distance[c])
                  {
                    distance[c] = distance[n] + step;
                    value[c] = value[n];
                  }
                });
  double prior = config.ground_height;
  if (!std::isfinite(prior) && !ground_values.empty())
  {
    std::nth_element(ground_values.begin(), ground_values.begin() + ground_values.size() / 2, ground_values.end());
    prior = ground_values[ground_values.size() / 2];
  }
  flat_ = std::isfinite(prior) ? prior : 0.0;
  ground_.resize(cells);
  for (std::size_t c = 0; c < cells; ++c)
    ground_[c] = static_cast<float>(distance[c] <= config.ground_search ? value[c] : flat_);
}

double GroundGrid::cellHeight(long ix, long iy) const
{
  ix = std::max(0L, std::min(nx_ - 1, ix));
  iy = std::max(0L, std::min(ny_ - 1, iy));
  return ground_[static_cast<std::size_t>(iy * nx_ + ix)];
}

double GroundGrid::heightAt(double x, double y) const
{
  if (ground_.empty())
    return flat_;
  const double fx = (x - x0_) / cell_ - 0.5, fy = (y - y0_) / cell_ - 0.5;
  const double bx = std::floor(fx), by = std::floor(fy);
  const double tx = fx - bx, ty = fy - by;
  const long ix = static_cast<long>(bx), iy = static_cast<long>(by);
  return (1.0 - ty) * ((1.0 - tx) * cellHeight(ix, iy) + tx * cellHeight(ix + 1, iy)) +
         ty * ((1.0 - tx) * cellHeight(ix, iy + 1) + tx * cellHeight(ix + 1, iy + 1));
}

// --- Slices and clusters ----------------------------------------------------------------------------------------

std::vector<std::vector<Eigen::Vector3f>> slicePoints(const std::vector<Eigen::Vector3f>& points,
                                                      const GroundGrid& ground, const StemColumnsConfig& config)
{
  const int count = sliceCount(config);
  std::vector<std::vector<Eigen::Vector3f>> slices(static_cast<std::size_t>(count));
  const double half = 0.5 * config.slice_thickness;
  for (const auto& p : points)
  {
    if (!finite(p))
      continue;
    const double h = p.z() - ground.heightAt(p.x(), p.y()) - config.slice_min;
    if (h < -half || h > (count - 1) * config.slice_step + half)
      continue;
    const long k = std::lround(h / config.slice_step);
    if (k >= 0 && k < count && std::abs(h - k * config.slice_step) <= half)
      slices[static_cast<std::size_t>(k)].push_back(p);
  }
  return slices;
}

namespace
{
int findRoot(std::vector<int>* parent, int i)
{
  while ((*parent)[static_cast<std::size_t>(i)] != i)
  {
    auto& pi = (*parent)[static_cast<std::size_t>(i)];
    pi = (*parent)[static_cast<std::size_t>(pi)];
    i = pi;
  }
  return i;
}
}  // namespace

std::vector<std::vector<int>> clusterSlice(const std::vector<Eigen::Vector3f>& slice, double tolerance, int min_points)
{
  // Points in occupied cells of side `tolerance`; cells that touch (8 neighbours) are one cluster, so points
  // closer than the tolerance always share one.
  std::vector<std::pair<std::int64_t, int>> keyed;
  keyed.reserve(slice.size());
  for (std::size_t i = 0; i < slice.size(); ++i)
  {
    const auto ix = static_cast<std::int64_t>(std::floor(slice[i].x() / tolerance));
    const auto iy = static_cast<std::int64_t>(std::floor(slice[i].y() / tolerance));
    keyed.emplace_back(packCell(ix, iy), static_cast<int>(i));
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<std::int64_t> cells;
  std::vector<int> cell_of_point(slice.size());
  for (const auto& kp : keyed)
  {
    if (cells.empty() || cells.back() != kp.first)
      cells.push_back(kp.first);
    cell_of_point[static_cast<std::size_t>(kp.second)] = static_cast<int>(cells.size()) - 1;
  }
  std::vector<int> parent(cells.size());
  std::iota(parent.begin(), parent.end(), 0);
  for (std::size_t c = 0; c < cells.size(); ++c)
  {
    const std::int64_t ix = cells[c] >> 32;
    const std::int64_t iy = static_cast<std::int32_t>(static_cast<std::uint32_t>(cells[c] & 0xffffffff));
    const std::array<std::array<std::int64_t, 2>, 4> half = { { { 1, -1 }, { 1, 0 }, { 1, 1 }, { 0, 1 } } };
    for (const auto& d : half)
    {
      const auto it = std::lower_bound(cells.begin(), cells.end(), packCell(ix + d[0], iy + d[1]));
      if (it != cells.end() && *it == packCell(ix + d[0], iy + d[1]))
      {
        const int a = findRoot(&parent, static_cast<int>(c));
        const int b = findRoot(&parent, static_cast<int>(it - cells.begin()));
        parent[static_cast<std::size_t>(std::max(a, b))] = std::min(a, b);
      }
    }
  }
  std::vector<int> cluster_of_root(cells.size(), -1);
  std::vector<std::vector<int>> clusters;
  for (std::size_t i = 0; i < slice.size(); ++i)
  {
    const int root = findRoot(&parent, cell_of_point[i]);
    int& k = cluster_of_root[static_cast<std::size_t>(root)];
    if (k < 0)
    {
      k = static_cast<int>(clusters.size());
      clusters.emplace_back();
    }
    clusters[static_cast<std::size_t>(k)].push_back(static_cast<int>(i));
  }
  clusters.erase(std::remove_if(clusters.begin(), clusters.end(),
                                [&](const std::vector<int>& c) { return static_cast<int>(c.size()) < min_points; }),
                 clusters.end());
  return clusters;
}

// --- Circles ----------------------------------------------------------------------------------------------------

namespace
{
/** @brief A cluster's points sorted by x, so that those near a circle are found by bisection. */
struct SortedPoints
{
  std::vector<Eigen::Vector2d> xy;
  std::vector<float> z;
  std::vector<char> active;

  /** @brief Index range of the points with x in [lo, hi]. */
  std::pair<std::size_t, std::size_t> range(double lo, double hi) const
  {
    const auto a =
        std::lower_bound(xy.begin(), xy.end(), lo, [](const Eigen::Vector2d& p, double v) { return p.x() < v; });
    const auto b = std::upper_bound(a, xy.end(), hi, [](double v, const Eigen::Vector2d& p) { return v < p.x(); });
    return { static_cast<std::size_t>(a - xy.begin()), static_cast<std::size_t>(b - xy.begin()) };
  }
};

/**
 * @brief Inliers (active points within the band), interior points (any point inside the band) and covered sectors
 * of a circle.
 */
struct CircleSupport
{
  std::vector<std::size_t> inliers;
  int interior = 0;
  double coverage = 0.0;
  Eigen::Vector2d inlier_mean = Eigen::Vector2d::Zero();
};

CircleSupport support(const SortedPoints& pts, const Eigen::Vector2d& c, double r, double band, bool want_inliers)
{
  CircleSupport s;
  const double reach = r + band;
  const double inner = r - band;
  std::array<bool, kSectors> sector{};
  const auto span = pts.range(c.x() - reach, c.x() + reach);
  for (std::size_t i = span.first; i < span.second; ++i)
  {
    if (std::abs(pts.xy[i].y() - c.y()) > reach)
      continue;
    const Eigen::Vector2d d = pts.xy[i] - c;
    const double dist = d.norm();
    // Points inside count whether or not an earlier ring took them: the ring must be hollow in the cloud.
    if (dist < inner)
      ++s.interior;
    else if (pts.active[i] && dist <= r + band)
    {
      s.inliers.push_back(i);
      if (want_inliers)
      {
        const double a = std::atan2(d.y(), d.x()) + kPi;
        sector[static_cast<std::size_t>(std::min(kSectors - 1.0, a / (2.0 * kPi) * kSectors))] = true;
        s.inlier_mean += pts.xy[i];
      }
    }
  }
  if (want_inliers && !s.inliers.empty())
  {
    s.coverage = static_cast<double>(std::count(sector.begin(), sector.end(), true)) / kSectors;
    s.inlier_mean /= static_cast<double>(s.inliers.size());
  }
  return s;
}

/** @brief The best RANSAC circle among the active points: inliers less twice the points inside the ring. */
bool ransacStemCircle(const SortedPoints& pts, const std::vector<std::size_t>& active, const StemColumnsConfig& cfg,
                      Random* rng, Eigen::Vector2d* centre, double* radius)
{
  const double r_min = 0.5 * cfg.min_dbh, r_max = 0.5 * cfg.max_dbh;
  double best = 0.0;
  bool found = false;
  for (int it = 0; it < cfg.ransac_iterations; ++it)
  {
    // The three points lie within a stem's diameter of the first: big clusters hold several stems.
    const std::size_t i = active[rng->uniformIndex(active.size())];
    const auto span = pts.range(pts.xy[i].x() - 2.0 * r_max, pts.xy[i].x() + 2.0 * r_max);
    const std::size_t n = span.second - span.first;
    const std::size_t j = span.first + rng->uniformIndex(n), k = span.first + rng->uniformIndex(n);
    if (j == i || k == i || j == k || !pts.active[j] || !pts.active[k] ||
        (pts.xy[j] - pts.xy[i]).norm() > 2.0 * r_max || (pts.xy[k] - pts.xy[i]).norm() > 2.0 * r_max)
      continue;
    Eigen::Vector2d c;
    double r = 0.0;
    if (!circleThrough(pts.xy[i], pts.xy[j], pts.xy[k], &c, &r) || r < r_min || r > r_max)
      continue;
    const CircleSupport s = support(pts, c, r, cfg.inlier_band, false);
    const double score = static_cast<double>(s.inliers.size()) - 2.0 * s.interior;
    if (score > best)
    {
      best = score;
      *centre = c;
      *radius = r;
      found = true;
    }
  }
  return found;
}

/** @brief The spread of points about a circle: 1.4826 × the median absolute distance to it. */
double residualSpread(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& centre, double radius)
{
  std::vector<double> e;
  e.reserve(points.size());
  for (const auto& p : points)
    e.push_back(std::abs((p - centre).norm() - radius));
  std::nth_element(e.begin(), e.begin() + e.size() / 2, e.end());
  return 1.4826 * e[e.size() / 2];
}

/**
 * @brief Geometric least squares on the inliers, three times: twice within the inlier band, then within three
 * times the points' own spread about the circle (at most the band), so that needles, bark scales and twig stubs
 * on the ring, which lie only outside the bark, pull the radius less. The support returned is the band's.
 */
CircleSupport refineStemCircle(const SortedPoints& pts, const StemColumnsConfig& cfg, Eigen::Vector2d* centre,
                               double* radius)
{
  double band = cfg.inlier_band;
  for (int round = 0; round < 3; ++round)
  {
    const CircleSupport s = support(pts, *centre, *radius, band, false);
    if (s.inliers.size() < 3)
      break;
    std::vector<Eigen::Vector2d> in;
    in.reserve(s.inliers.size());
    for (std::size_t i : s.inliers)
      in.push_back(pts.xy[i]);
    CircleRefineParams params;
    params.range_sigma = band;
    params.radius_prior = *radius;
    params.radius_sigma = 1e3;  // no prior: the inliers alone decide
    Eigen::Vector2d c = *centre;
    double r = *radius;
    Eigen::Matrix3d cov;
    if (!refineCircle(in, params, &c, &r, &cov))
      break;
    *centre = c;
    *radius = r;
    if (round == 1)
      band = std::min(cfg.inlier_band, std::max(kMinFitBand, 3.0 * residualSpread(in, c, r)));
  }
  return support(pts, *centre, *radius, cfg.inlier_band, true);
}

bool acceptStemCircle(const CircleSupport& s, const Eigen::Vector2d& centre, double radius,
                      const StemColumnsConfig& cfg)
{
  if (radius < 0.5 * cfg.min_dbh || radius > 0.5 * cfg.max_dbh)
    return false;
  if (static_cast<int>(s.inliers.size()) < cfg.min_inliers)
    return false;
  if (s.coverage < (cfg.has_sensor ? cfg.min_coverage_sensor : cfg.min_coverage))
    return false;
  // Bark is opaque: the disc inside the band holds (almost) nothing. Measured against the band's points, scaled
  // down where the disc is smaller than the band (thin stems), so a gap in a solid blob is no ring.
  const double band = cfg.inlier_band;
  const double disc = std::pow(std::max(0.0, radius - band), 2) / (4.0 * radius * band);
  if (s.interior > cfg.max_interior_share * std::min(1.0, disc) * static_cast<double>(s.inliers.size()))
    return false;
  // Seen from one place, the bark faces the sensor: the arc lies between the sensor and the centre.
  return !cfg.has_sensor || (s.inlier_mean - centre).dot(cfg.sensor.head<2>() - centre) > 0.0;
}
}  // namespace

std::vector<StemCircle> fitStemCircles(const std::vector<Eigen::Vector3f>& cluster, int slice, double height,
                                       const StemColumnsConfig& config, Random* rng)
{
  std::vector<StemCircle> out;
  SortedPoints pts;
  std::vector<Eigen::Vector3f> sorted = cluster;
  std::sort(sorted.begin(), sorted.end(),
            [](const Eigen::Vector3f& a, const Eigen::Vector3f& b) { return a.x() < b.x(); });
  for (const auto& p : sorted)
  {
    pts.xy.emplace_back(p.x(), p.y());
    pts.z.push_back(p.z());
  }
  pts.active.assign(pts.xy.size(), 1);
  for (int attempt = 0; attempt < config.max_circles_per_cluster; ++attempt)
  {
    std::vector<std::size_t> active;
    for (std::size_t i = 0; i < pts.active.size(); ++i)
      if (pts.active[i])
        active.push_back(i);
    Eigen::Vector2d c;
    double r = 0.0;
    if (static_cast<int>(active.size()) < config.min_inliers || !ransacStemCircle(pts, active, config, rng, &c, &r))
      break;
    const CircleSupport s = refineStemCircle(pts, config, &c, &r);
    if (s.inliers.empty())
      break;
    if (acceptStemCircle(s, c, r, config))
    {
      StemCircle circle;
      circle.slice = slice;
      circle.height = height;
      circle.center = c;
      circle.radius = r;
      circle.inliers = static_cast<int>(s.inliers.size());
      circle.coverage = s.coverage;
      circle.z_min = std::numeric_limits<double>::infinity();
      circle.z_max = -circle.z_min;
      for (std::size_t i : s.inliers)
      {
        circle.z_min = std::min<double>(circle.z_min, pts.z[i]);
        circle.z_max = std::max<double>(circle.z_max, pts.z[i]);
      }
      out.push_back(circle);
    }
    // Whatever it was, its ring is used up: the next attempt looks at the rest.
    for (std::size_t i : s.inliers)
      pts.active[i] = 0;
  }
  return out;
}

// --- Columns and stems ------------------------------------------------------------------------------------------

std::vector<std::vector<StemCircle>> linkColumns(std::vector<StemCircle> circles, const StemColumnsConfig& config)
{
  std::stable_sort(circles.begin(), circles.end(),
                   [](const StemCircle& a, const StemCircle& b) { return a.slice < b.slice; });
  std::vector<std::vector<StemCircle>> columns;
  const double lean = std::tan(config.max_lean_deg * kPi / 180.0);
  std::size_t begin = 0;
  while (begin < circles.size())
  {
    std::size_t end = begin;
    while (end < circles.size() && circles[end].slice == circles[begin].slice)
      ++end;
    // Every admissible (circle, column) pair, the closest first (distance over what is allowed).
    std::vector<std::pair<double, std::pair<std::size_t, std::size_t>>> pairs;
    for (std::size_t i = begin; i < end; ++i)
      for (std::size_t k = 0; k < columns.size(); ++k)
      {
        const StemCircle& last = columns[k].back();
        const double dh = circles[i].height - last.height;
        if (circles[i].slice <= last.slice || dh > config.max_gap + config.slice_step + 1e-9)
          continue;
        const double allowed_c = config.centre_tolerance + lean * dh;
        const double allowed_r =
            config.radius_tolerance + config.radius_tolerance_share * last.radius + config.max_taper * dh;
        const double dc = (circles[i].center - last.center).norm();
        const double dr = std::abs(circles[i].radius - last.radius);
        if (dc <= allowed_c && dr <= allowed_r)
          pairs.push_back({ dc / allowed_c + dr / allowed_r, { i, k } });
      }
    std::sort(pairs.begin(), pairs.end());
    std::vector<char> circle_used(end - begin, 0), column_used(columns.size(), 0);
    for (const auto& p : pairs)
    {
      const std::size_t i = p.second.first, k = p.second.second;
      if (circle_used[i - begin] || column_used[k])
        continue;
      circle_used[i - begin] = column_used[k] = 1;
      columns[k].push_back(circles[i]);
    }
    for (std::size_t i = begin; i < end; ++i)
      if (!circle_used[i - begin])
        columns.push_back({ circles[i] });
    begin = end;
  }
  return columns;
}

namespace
{
/** @brief Least-squares line v = a + b x; the residuals' sum of squares in *ssr. */
struct Line
{
  double a = 0.0, b = 0.0;
  double at(double x) const { return a + b * x; }
};

Line fitLine(const std::vector<double>& x, const std::vector<double>& v)
{
  const double n = static_cast<double>(x.size());
  const double mx = std::accumulate(x.begin(), x.end(), 0.0) / n;
  const double mv = std::accumulate(v.begin(), v.end(), 0.0) / n;
  double sxx = 0.0, sxv = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i)
  {
    sxx += (x[i] - mx) * (x[i] - mx);
    sxv += (x[i] - mx) * (v[i] - mv);
  }
  Line line;
  line.b = sxx > 1e-12 ? sxv / sxx : 0.0;
  line.a = mv - line.b * mx;
  return line;
}

double median(std::vector<double> v)
{
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

/** @brief Lines of centre x, y and radius over height (relative to breast height) through the kept circles. */
struct ColumnFit
{
  Line cx, cy, r;
  std::vector<double> centre_residual, radius_residual;
  std::vector<char> for_radius;  ///< the slices of the radius line
};

/** @brief Whether the radius line takes slice @p i: a kept slice within the window, or any kept one when the window
 * holds fewer than three. */
std::vector<char> radiusSlices(const std::vector<StemCircle>& column, const std::vector<char>& keep,
                               const StemColumnsConfig& config)
{
  std::vector<char> in_window(column.size(), 0);
  for (std::size_t i = 0; i < column.size(); ++i)
    in_window[i] = keep[i] && std::abs(column[i].height - config.breast_height) <= config.dbh_window + 1e-9;
  return std::count(in_window.begin(), in_window.end(), 1) >= 3 ? in_window : keep;
}

ColumnFit fitColumn(const std::vector<StemCircle>& column, const std::vector<char>& keep,
                    const StemColumnsConfig& config)
{
  const double breast_height = config.breast_height;
  const std::vector<char> for_radius = radiusSlices(column, keep, config);
  std::vector<double> h, x, y, hr, r;
  for (std::size_t i = 0; i < column.size(); ++i)
  {
    if (keep[i])
    {
      h.push_back(column[i].height - breast_height);
      x.push_back(column[i].center.x());
      y.push_back(column[i].center.y());
    }
    if (for_radius[i])
    {
      hr.push_back(column[i].height - breast_height);
      r.push_back(column[i].radius);
    }
  }
  ColumnFit fit;
  fit.cx = fitLine(h, x);
  fit.cy = fitLine(h, y);
  fit.r = fitLine(hr, r);
  fit.for_radius = for_radius;
  for (const auto& c : column)
  {
    const double dh = c.height - breast_height;
    fit.centre_residual.push_back(std::hypot(c.center.x() - fit.cx.at(dh), c.center.y() - fit.cy.at(dh)));
    fit.radius_residual.push_back(c.radius - fit.r.at(dh));
  }
  return fit;
}

/** @brief Drops the slices whose centre or radius stands out from the others' line (clutter on one ring). */
std::vector<char> dropOutliers(const std::vector<StemCircle>& column, const ColumnFit& fit)
{
  std::vector<double> abs_r;  // of the radius line's slices
  for (std::size_t i = 0; i < column.size(); ++i)
    if (fit.for_radius[i])
      abs_r.push_back(std::abs(fit.radius_residual[i]));
  const double limit_c = std::max(0.01, 3.0 * 1.4826 * median(fit.centre_residual));
  const double limit_r = std::max(0.005, 3.0 * 1.4826 * median(abs_r));
  std::vector<char> keep(column.size(), 1);
  for (std::size_t i = 0; i < column.size(); ++i)
    keep[i] = fit.centre_residual[i] <= limit_c && (!fit.for_radius[i] || std::abs(fit.radius_residual[i]) <= limit_r);
  return keep;
}

double rmsOfKept(const std::vector<double>& v, const std::vector<char>& keep)
{
  double sum = 0.0;
  int n = 0;
  for (std::size_t i = 0; i < v.size(); ++i)
    if (keep[i])
    {
      sum += v[i] * v[i];
      ++n;
    }
  return n > 0 ? std::sqrt(sum / n) : 0.0;
}
}  // namespace

bool stemFromColumn(const std::vector<StemCircle>& column, const StemColumnsConfig& config, Stem* stem)
{
  if (static_cast<int>(column.size()) < config.min_slices)
    return false;
  std::vector<char> keep(column.size(), 1);
  ColumnFit fit = fitColumn(column, keep, config);
  if (column.size() >= 4)
  {
    keep = dropOutliers(column, fit);
    fit = fitColumn(column, keep, config);
  }
  const int kept = static_cast<int>(std::count(keep.begin(), keep.end(), 1));
  if (kept < std::max(3, config.min_slices - 1))
    return false;
  const double r_bh = fit.r.at(0.0);
  if (r_bh < 0.5 * config.min_dbh || r_bh > 0.5 * config.max_dbh)
    return false;
  // A stem's sections lie on one straight, slowly tapering axis; a branch or a shrub's do not.
  const double lean = std::hypot(fit.cx.b, fit.cy.b);
  if (rmsOfKept(fit.centre_residual, keep) > config.centre_tolerance ||
      rmsOfKept(fit.radius_residual, fit.for_radius) > config.radius_tolerance + config.radius_tolerance_share * r_bh ||
      lean > std::tan(config.max_lean_deg * kPi / 180.0) + 2.0 * config.centre_tolerance ||
      std::abs(fit.r.b) > config.max_taper + 2.0 * config.radius_tolerance)
    return false;
  // The standard error of the radius line at breast height, from its slices' residuals.
  std::vector<double> h;
  double ssr = 0.0;
  for (std::size_t i = 0; i < column.size(); ++i)
    if (fit.for_radius[i])
    {
      h.push_back(column[i].height - config.breast_height);
      ssr += fit.radius_residual[i] * fit.radius_residual[i];
    }
  const double n_r = static_cast<double>(h.size());
  const double mh = std::accumulate(h.begin(), h.end(), 0.0) / n_r;
  double shh = 0.0;
  for (double v : h)
    shh += (v - mh) * (v - mh);
  const double s = std::sqrt(ssr / (n_r - 2.0));
  *stem = Stem();
  stem->center = Eigen::Vector2d(fit.cx.at(0.0), fit.cy.at(0.0));
  stem->dbh = 2.0 * r_bh;
  stem->dbh_sigma = 2.0 * s * std::sqrt(1.0 / n_r + (shh > 0.0 ? mh * mh / shh : 0.0));
  stem->slices = kept;
  stem->lean_deg = std::atan(lean) * 180.0 / kPi;
  stem->z_min = std::numeric_limits<double>::infinity();
  stem->z_max = -stem->z_min;
  for (const auto& c : column)
  {
    stem->points += c.inliers;
    stem->z_min = std::min(stem->z_min, c.z_min);
    stem->z_max = std::max(stem->z_max, c.z_max);
  }
  return true;
}

namespace
{
/** @brief One stem per trunk: of stems whose axes lie within the larger radius, the one of most slices stays. */
std::vector<Stem> suppressDuplicates(std::vector<Stem> stems)
{
  std::stable_sort(stems.begin(), stems.end(), [](const Stem& a, const Stem& b) { return a.slices > b.slices; });
  std::vector<Stem> kept;
  for (const auto& s : stems)
  {
    const bool duplicate =
        std::any_of(kept.begin(), kept.end(),
                    [&](const Stem& k) { return (k.center - s.center).norm() < 0.5 * std::max(k.dbh, s.dbh); });
    if (!duplicate)
      kept.push_back(s);
  }
  std::sort(kept.begin(), kept.end(),
            [](const Stem& a, const Stem& b)
            { return a.center.x() != b.center.x() ? a.center.x() < b.center.x() : a.center.y() < b.center.y(); });
  return kept;
}
}  // namespace

std::vector<Stem> findStems(const std::vector<Eigen::Vector3f>& points, const StemColumnsConfig& config,
                            StemColumnsStats* stats, const std::function<void(double)>& progress)
{
  const std::string error = config.validate();
  if (!error.empty())
    throw std::invalid_argument("findStems: " + error);
  const auto report = [&](double share)
  {
    if (progress)
      progress(share);
  };
  StemColumnsStats local;
  StemColumnsStats& st = stats ? *stats : local;
  st = StemColumnsStats();
  st.input_points = points.size();
  st.finite_points = static_cast<std::size_t>(std::count_if(points.begin(), points.end(), finite));
  GroundGrid ground;
  ground.build(points, config);
  report(0.1);  // the circles take most of the time
  const auto slices = slicePoints(points, ground, config);
  report(0.2);
  Random rng(config.seed);
  std::vector<StemCircle> circles;
  for (std::size_t k = 0; k < slices.size(); ++k)
  {
    st.slice_points += slices[k].size();
    const double height = config.slice_min + static_cast<double>(k) * config.slice_step;
    for (const auto& indices : clusterSlice(slices[k], config.cluster_tolerance, config.min_cluster_points))
    {
      std::vector<Eigen::Vector3f> cluster;
      cluster.reserve(indices.size());
      for (int i : indices)
        cluster.push_back(slices[k][static_cast<std::size_t>(i)]);
      ++st.clusters;
      for (const auto& c : fitStemCircles(cluster, static_cast<int>(k), height, config, &rng))
        circles.push_back(c);
    }
    report(0.2 + 0.8 * static_cast<double>(k + 1) / static_cast<double>(slices.size()));
  }
  st.circles = static_cast<int>(circles.size());
  const auto columns = linkColumns(std::move(circles), config);
  st.columns = static_cast<int>(columns.size());
  std::vector<Stem> stems;
  for (const auto& column : columns)
  {
    Stem stem;
    if (stemFromColumn(column, config, &stem))
    {
      stem.ground = ground.heightAt(stem.center.x(), stem.center.y());
      stems.push_back(stem);
    }
  }
  stems = suppressDuplicates(std::move(stems));
  st.stems = static_cast<int>(stems.size());
  return stems;
}

}  // namespace core
}  // namespace rbpf_slam
