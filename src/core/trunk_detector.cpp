// Trunk detection: ground, height band, Euclidean clustering (PCL), RANSAC circle (PCL) + least squares.
// The only PCL translation unit of the core: keep PCL out of headers.
#include "rbpf_slam/core/trunk_detector.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <chrono>
#include <cstdint>
#include <unordered_map>

#include <Eigen/Dense>

#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_circle.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>

namespace rbpf_slam
{
namespace core
{
namespace
{
constexpr double kPi = 3.14159265358979323846;

/** A cluster's points in the levelled frame. */
using Points3 = std::vector<Eigen::Vector3d>;

/** Result of fitting one cluster. */
struct Fit
{
  bool ok = false;
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double radius = 0.0;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();  // (cx, cy, r)
  int inliers = 0;
  double arc_angle = 0.0;  // angle the inliers subtend at the centre [rad]
  TrunkMethod method = TrunkMethod::kCircle;
};

/** Kasa (algebraic) circle fit; false if degenerate. */
bool kasaFit(const std::vector<Eigen::Vector2d>& p, Eigen::Vector2d* c, double* r)
{
  if (p.size() < 3)
    return false;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& q : p)
    mean += q;
  mean /= static_cast<double>(p.size());
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const auto& q0 : p)
  {
    const Eigen::Vector2d q = q0 - mean;
    const Eigen::Vector3d row(q.x(), q.y(), 1.0);
    const double z = q.squaredNorm();
    A += row * row.transpose();
    b -= row * z;
  }
  const Eigen::Vector3d s = A.ldlt().solve(b);
  if (!s.allFinite())
    return false;
  *c = mean + Eigen::Vector2d(-s.x() / 2.0, -s.y() / 2.0);
  const double r2 = (s.x() * s.x() + s.y() * s.y()) / 4.0 - s.z();
  if (!(r2 > 0.0))
    return false;
  *r = std::sqrt(r2);
  return true;
}

/** Sum of squared algebraic residuals (scaled to distances) of the Kasa fit. */
double kasaCost(const std::vector<Eigen::Vector2d>& p)
{
  Eigen::Vector2d c;
  double r = 0.0;
  if (!kasaFit(p, &c, &r))
    return 1e9;
  double cost = 0.0;
  for (const auto& q : p)
  {
    const double d = (q - c).norm() - r;
    cost += d * d;
  }
  return cost;
}

/** Angle subtended at @p c by the points (the widest gap removed). */
double arcAngle(const std::vector<Eigen::Vector2d>& p, const Eigen::Vector2d& c)
{
  if (p.size() < 2)
    return 0.0;
  std::vector<double> a;
  a.reserve(p.size());
  for (const auto& q : p)
    a.push_back(std::atan2(q.y() - c.y(), q.x() - c.x()));
  std::sort(a.begin(), a.end());
  double widest_gap = a.front() + 2.0 * kPi - a.back();
  for (std::size_t i = 1; i < a.size(); ++i)
    widest_gap = std::max(widest_gap, a[i] - a[i - 1]);
  return 2.0 * kPi - widest_gap;
}

/**
 * Geometric least squares for (cx, cy, r) by Gauss-Newton with a weak prior on r (so that short arcs
 * stay well posed), then the covariance of the estimate.
 */
bool refineCircle(const std::vector<Eigen::Vector2d>& p, const TrunkDetectorConfig& cfg, Eigen::Vector2d* c, double* r,
                  Eigen::Matrix3d* cov)
{
  Eigen::Vector3d x(c->x(), c->y(), *r);
  const double prior_w = 1.0 / (cfg.arc_radius_sigma * cfg.arc_radius_sigma);
  const double sigma2 = cfg.range_sigma * cfg.range_sigma;
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  // Large clusters (near trunks) are thinned to about 400 evenly spread points for the iterations; each
  // point then stands for `weight` points, so the information (and the covariance) stays that of all.
  const std::size_t stride = std::max<std::size_t>(1, p.size() / 400);
  const double weight = static_cast<double>(p.size()) / static_cast<double>((p.size() + stride - 1) / stride);
  for (int it = 0; it < 10; ++it)
  {
    H.setZero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < p.size(); i += stride)
    {
      const Eigen::Vector2d d = p[i] - x.head<2>();
      const double n = d.norm();
      if (n < 1e-9)
        continue;
      const double res = n - x.z();
      const Eigen::Vector3d J(-d.x() / n, -d.y() / n, -1.0);
      H += weight * J * J.transpose() / sigma2;
      g += weight * J * res / sigma2;
    }
    H(2, 2) += prior_w;
    g.z() += prior_w * (x.z() - cfg.arc_radius_prior);
    const Eigen::Vector3d step = H.ldlt().solve(-g);
    if (!step.allFinite())
      return false;
    // Keep steps sane: a degenerate arc may push the centre far away.
    const double limit = 0.5;
    x += step.norm() > limit ? (step * (limit / step.norm())).eval() : step;
    if (step.norm() < 1e-6)
      break;
  }
  if (!x.allFinite() || x.z() <= 0.0)
    return false;
  // Residual scale: the data's own spread if it exceeds the sensor noise.
  double ss = 0.0;
  for (const auto& q : p)
  {
    const double res = (q - x.head<2>()).norm() - x.z();
    ss += res * res;
  }
  const double dof = std::max<double>(1.0, static_cast<double>(p.size()) - 3.0);
  const double scale = std::max(1.0, ss / dof / sigma2);
  Eigen::Matrix3d Hd = H;
  Hd(2, 2) -= prior_w;
  Hd *= 1.0 / scale;
  Hd(2, 2) += prior_w;
  *cov = Hd.inverse();
  if (!cov->allFinite())
    return false;
  *c = x.head<2>();
  *r = x.z();
  return true;
}
}  // namespace

bool parseTrunkMethod(const std::string& text, TrunkMethod* method)
{
  if (text == "centroid")
    *method = TrunkMethod::kCentroid;
  else if (text == "circle")
    *method = TrunkMethod::kCircle;
  else
    return false;
  return true;
}

const char* trunkMethodName(TrunkMethod method)
{
  switch (method)
  {
    case TrunkMethod::kCentroid:
      return "centroid";
    case TrunkMethod::kCircle:
      return "circle";
    case TrunkMethod::kArc:
      return "arc";
  }
  return "unknown";
}

std::string TrunkDetectorConfig::validate() const
{
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (method != TrunkMethod::kCentroid && method != TrunkMethod::kCircle)
    return "method must be centroid or circle";
  if (!positive(ground_cell))
    return "ground_cell must be > 0";
  if (!(ground_max_slope >= 0.0))
    return "ground_max_slope must be >= 0";
  if (!std::isfinite(min_height) || !std::isfinite(max_height) || !(max_height > min_height))
    return "max_height must be > min_height";
  if (!(voxel_size >= 0.0))
    return "voxel_size must be >= 0";
  if (!positive(cluster_tolerance))
    return "cluster_tolerance must be > 0";
  if (min_points < 3)
    return "min_points must be >= 3";
  if (max_points < min_points)
    return "max_points must be >= min_points";
  if (!positive(min_radius) || !(max_radius > min_radius))
    return "min_radius must be > 0 and max_radius > min_radius";
  if (!positive(ransac_threshold))
    return "ransac_threshold must be > 0";
  if (ransac_iterations < 1)
    return "ransac_iterations must be >= 1";
  if (!(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0))
    return "min_inlier_ratio must be in [0, 1]";
  if (!(min_vertical_extent >= 0.0))
    return "min_vertical_extent must be >= 0";
  if (!positive(max_tilt))
    return "max_tilt must be > 0";
  if (min_fit_points < 3)
    return "min_fit_points must be >= 3";
  if (!(min_fit_arc >= 0.0))
    return "min_fit_arc must be >= 0";
  if (!positive(arc_radius_prior) || !positive(arc_radius_sigma))
    return "arc_radius_prior and arc_radius_sigma must be > 0";
  if (!positive(range_sigma))
    return "range_sigma must be > 0";
  if (!std::isfinite(range_offset) || std::abs(range_offset) > 1.0)
    return "range_offset must be finite and within +-1 m";
  if (!(min_range >= 0.0) || !(max_range > min_range))
    return "max_range must be > min_range >= 0";
  if (!(sensor_height >= 0.0))
    return "sensor_height must be >= 0 (0: unknown)";
  return "";
}

struct TrunkDetector::Impl
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr band{ new pcl::PointCloud<pcl::PointXYZ> };
  pcl::search::KdTree<pcl::PointXYZ>::Ptr tree{ new pcl::search::KdTree<pcl::PointXYZ> };
  std::uint64_t calls = 0;
};

TrunkDetector::TrunkDetector(const TrunkDetectorConfig& config) : impl_(new Impl)
{
  setConfig(config);
}

TrunkDetector::~TrunkDetector() = default;

void TrunkDetector::setConfig(const TrunkDetectorConfig& config)
{
  const std::string error = config.validate();
  if (!error.empty())
    throw std::invalid_argument("TrunkDetector: " + error);
  config_ = config;
}

namespace
{
/** Fits one cluster (2D points in the levelled frame, sensor at the origin). */
Fit fitCluster(const std::vector<Eigen::Vector2d>& p, const TrunkDetectorConfig& cfg)
{
  Fit fit;
  const int n = static_cast<int>(p.size());
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& q : p)
    mean += q;
  mean /= n;
  if (cfg.method == TrunkMethod::kCentroid)
  {
    // The study's method: the centre of the visible points. Radius: half the widest horizontal extent.
    double extent = 0.0;
    const Eigen::Vector2d across = Eigen::Vector2d(-mean.y(), mean.x()).normalized();
    double lo = 1e9, hi = -1e9;
    for (const auto& q : p)
    {
      const double s = across.dot(q);
      lo = std::min(lo, s);
      hi = std::max(hi, s);
    }
    extent = hi - lo;
    fit.center = mean;
    fit.radius = 0.5 * extent;
    Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
    for (const auto& q : p)
      scatter += (q - mean) * (q - mean).transpose();
    fit.covariance.setZero();
    // Spread of the mean plus the method's own uncertainty (about half a radius, towards the sensor).
    fit.covariance.topLeftCorner<2, 2>() =
        scatter / (static_cast<double>(n) * n) + Eigen::Matrix2d::Identity() * (0.25 * fit.radius * fit.radius + 1e-4);
    fit.covariance(2, 2) = std::pow(0.5 * fit.radius + cfg.range_sigma, 2);
    fit.inliers = n;
    fit.arc_angle = 0.0;
    fit.method = TrunkMethod::kCentroid;
    fit.ok = true;
    return fit;
  }

  // Initial circle: RANSAC (PCL, circle 2D with radius limits) when there are enough points, else a
  // centre one prior radius behind the arc's middle.
  Eigen::Vector2d c = mean + mean.normalized() * cfg.arc_radius_prior;
  double r = cfg.arc_radius_prior;
  bool have_ransac = false;
  // A clean cluster (the algebraic fit on all points already explains 95 % of them) needs no RANSAC; the
  // robust sampler is for clusters with clutter in them.
  bool clean = false;
  if (n >= cfg.min_fit_points)
  {
    Eigen::Vector2d kc;
    double kr = 0.0;
    if (kasaFit(p, &kc, &kr) && kc.norm() > mean.norm() && kr >= cfg.min_radius && kr <= cfg.max_radius)
    {
      int inliers = 0;
      for (const auto& q : p)
        inliers += std::abs((q - kc).norm() - kr) <= cfg.ransac_threshold;
      if (inliers >= 0.95 * n)
      {
        c = kc;
        r = kr;
        have_ransac = true;
        clean = true;
      }
    }
  }
  if (n >= cfg.min_fit_points && !clean)
  {
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    cloud->points.reserve(p.size());
    for (const auto& q : p)
      cloud->points.emplace_back(static_cast<float>(q.x()), static_cast<float>(q.y()), 0.0f);
    cloud->width = static_cast<std::uint32_t>(cloud->points.size());
    cloud->height = 1;
    // random = false: PCL seeds its sampler with a fixed value, so runs repeat.
    pcl::SampleConsensusModelCircle2D<pcl::PointXYZ>::Ptr model(
        new pcl::SampleConsensusModelCircle2D<pcl::PointXYZ>(cloud, false));
    model->setRadiusLimits(cfg.min_radius, cfg.max_radius);
    pcl::RandomSampleConsensus<pcl::PointXYZ> ransac(model, cfg.ransac_threshold);
    ransac.setMaxIterations(cfg.ransac_iterations);
    if (ransac.computeModel())
    {
      Eigen::VectorXf coef;
      ransac.getModelCoefficients(coef);
      if (coef.size() == 3 && coef.allFinite())
      {
        const Eigen::Vector2d rc(coef[0], coef[1]);
        // A trunk's visible side faces the sensor: its centre lies behind the points.
        if (rc.norm() > mean.norm())
        {
          c = rc;
          r = coef[2];
          have_ransac = true;
        }
      }
    }
    if (!have_ransac)
    {
      Eigen::Vector2d kc;
      double kr = 0.0;
      if (kasaFit(p, &kc, &kr) && kc.norm() > mean.norm() && kr >= cfg.min_radius && kr <= cfg.max_radius)
      {
        c = kc;
        r = kr;
      }
    }
  }
  // Inliers of the initial circle, then least squares on them.
  std::vector<Eigen::Vector2d> in;
  in.reserve(p.size());
  for (const auto& q : p)
    if (std::abs((q - c).norm() - r) <= cfg.ransac_threshold || !have_ransac)
      in.push_back(q);
  if (in.size() < 3)
    in = p;
  Eigen::Matrix3d cov;
  if (!refineCircle(in, cfg, &c, &r, &cov))
    return fit;
  // The inliers were chosen around the initial circle; an algebraic or sampled circle is biased (short
  // noisy arcs fit small circles), so a window around it cuts the residuals asymmetrically and the
  // refinement inherits the bias. Choose them again around the refined circle and refine once more.
  if (have_ransac)
  {
    std::vector<Eigen::Vector2d> again;
    again.reserve(p.size());
    for (const auto& q : p)
      if (std::abs((q - c).norm() - r) <= cfg.ransac_threshold)
        again.push_back(q);
    if (again.size() >= 3 && again.size() != in.size())
    {
      Eigen::Vector2d c2 = c;
      double r2 = r;
      Eigen::Matrix3d cov2;
      if (refineCircle(again, cfg, &c2, &r2, &cov2))
      {
        c = c2;
        r = r2;
        cov = cov2;
        in.swap(again);
      }
    }
  }
  fit.inliers = 0;
  for (const auto& q : p)
    if (std::abs((q - c).norm() - r) <= cfg.ransac_threshold)
      ++fit.inliers;
  fit.center = c;
  fit.radius = r;
  fit.covariance = cov;
  fit.arc_angle = arcAngle(in, c);
  fit.method = (n < cfg.min_fit_points || fit.arc_angle < cfg.min_fit_arc) ? TrunkMethod::kArc : TrunkMethod::kCircle;
  fit.ok = true;
  return fit;
}

/** Fills an observation from a fit. */
TrunkObservation toObservation(const Fit& fit, int num_points, double height)
{
  TrunkObservation o;
  o.center = fit.center;
  o.radius = fit.radius;
  o.radius_variance = fit.covariance(2, 2);
  o.range = fit.center.norm();
  o.bearing = std::atan2(fit.center.y(), fit.center.x());
  o.covariance = fit.covariance.topLeftCorner<2, 2>();
  o.num_points = num_points;
  o.num_inliers = fit.inliers;
  const double ratio = num_points > 0 ? static_cast<double>(fit.inliers) / num_points : 0.0;
  const double coverage = fit.method == TrunkMethod::kCentroid ? 1.0 : std::min(1.0, fit.arc_angle / (0.5 * kPi));
  o.score = ratio * (0.5 + 0.5 * coverage);
  o.method = fit.method;
  o.height = height;
  return o;
}

/** Accepts or rejects a fitted cluster; returns the rejection counter to bump, or nullptr if accepted. */
int* rejectReason(const Fit& fit, int num_points, const TrunkDetectorConfig& cfg, TrunkDetectorStats* st)
{
  if (!fit.ok)
    return &st->rejected_shape;
  if (fit.radius < cfg.min_radius || fit.radius > cfg.max_radius)
    return &st->rejected_radius;
  if (static_cast<double>(fit.inliers) < cfg.min_inlier_ratio * num_points)
    return &st->rejected_inliers;
  const double range = fit.center.norm();
  if (range < cfg.min_range || range > cfg.max_range)
    return &st->rejected_shape;
  return nullptr;
}

/**
 * One hash key for a 2D cell: ix in the high word, iy's low 32 bits in the low word. Shifted as unsigned, since
 * cells left of or behind the sensor have negative indices and a left shift of a negative value is undefined.
 */
std::int64_t packCell(std::int64_t ix, std::int64_t iy)
{
  return static_cast<std::int64_t>((static_cast<std::uint64_t>(ix) << 32) ^
                                   (static_cast<std::uint64_t>(iy) & 0xffffffffULL));
}
}  // namespace

std::vector<TrunkObservation> TrunkDetector::detect(const std::vector<Eigen::Vector3f>& points,
                                                     const Eigen::Matrix3d& level, TrunkDetectorStats* stats)
{
  TrunkDetectorStats local_stats;
  TrunkDetectorStats* st = stats ? stats : &local_stats;
  *st = TrunkDetectorStats();
  st->input_points = static_cast<int>(points.size());
  const TrunkDetectorConfig& cfg = config_;
  std::vector<TrunkObservation> out;

  // 1. Level and keep finite points.
  Points3 pts;
  pts.reserve(points.size());
  for (const auto& pf : points)
  {
    if (!pf.allFinite())
      continue;
    pts.push_back(level * pf.cast<double>());
  }
  st->finite_points = static_cast<int>(pts.size());
  if (pts.empty())
    return out;

  auto lap = std::chrono::steady_clock::now();
  const auto split = [&lap](double* acc) {
    const auto now = std::chrono::steady_clock::now();
    *acc += std::chrono::duration<double, std::milli>(now - lap).count();
    lap = now;
  };
  // 2. Ground: lowest point per cell, the lowest over the 3 x 3 neighbourhood, capped by what the slope
  //    allows from the ground under the sensor when its height is known.
  const double cell = cfg.ground_cell;
  const auto key = [cell](double x, double y) {
    return packCell(static_cast<std::int64_t>(std::floor(x / cell)), static_cast<std::int64_t>(std::floor(y / cell)));
  };
  std::unordered_map<std::int64_t, float> lowest;
  lowest.reserve(pts.size() / 4 + 16);
  for (const auto& p : pts)
  {
    auto it = lowest.find(key(p.x(), p.y()));
    if (it == lowest.end())
      lowest.emplace(key(p.x(), p.y()), static_cast<float>(p.z()));
    else if (p.z() < it->second)
      it->second = static_cast<float>(p.z());
  }
  std::unordered_map<std::int64_t, float> ground;
  ground.reserve(lowest.size());
  const auto groundAt = [&](double x, double y) {
    const std::int64_t k = key(x, y);
    auto it = ground.find(k);
    if (it != ground.end())
      return static_cast<double>(it->second);
    double g = std::numeric_limits<double>::infinity();
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
      {
        auto n = lowest.find(key(x + dx * cell, y + dy * cell));
        if (n != lowest.end())
          g = std::min(g, static_cast<double>(n->second));
      }
    if (cfg.sensor_height > 0.0)
    {
      const double cap = -cfg.sensor_height + cfg.ground_max_slope * std::hypot(x, y);
      g = std::min(g, cap);
    }
    ground.emplace(k, static_cast<float>(g));
    return g;
  };

  // 3. Height band.
  pcl::PointCloud<pcl::PointXYZ>::Ptr band = impl_->band;
  band->clear();
  for (const auto& p : pts)
  {
    const double g = groundAt(p.x(), p.y());
    const double h = p.z() - g;
    if (h >= cfg.min_height && h <= cfg.max_height)
    {
      band->points.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
    }
  }
  if (cfg.voxel_size > 0.0 && !band->points.empty())
  {
    band->width = static_cast<std::uint32_t>(band->points.size());
    band->height = 1;
    pcl::PointCloud<pcl::PointXYZ>::Ptr down(new pcl::PointCloud<pcl::PointXYZ>);
    pcl::VoxelGrid<pcl::PointXYZ> voxel;
    voxel.setInputCloud(band);
    const float v = static_cast<float>(cfg.voxel_size);
    voxel.setLeafSize(v, v, v);
    voxel.filter(*down);
    band = down;
  }
  band->width = static_cast<std::uint32_t>(band->points.size());
  band->height = 1;
  band->is_dense = true;
  st->band_points = static_cast<int>(band->points.size());
  if (band->points.size() < static_cast<std::size_t>(cfg.min_points))
    return out;

  split(&st->ms_band);
  // 4. Euclidean clustering of the horizontal projection (trunks stand upright, and the rings of a far trunk
  //    are further apart vertically than any sensible tolerance). To keep the neighbour searches short the
  //    projection is first reduced to one point per 2D cell of a fifth of the tolerance; each point then
  //    belongs to the cluster of its cell.
  const double leaf = cfg.cluster_tolerance / 3.0;
  const auto cellKey = [leaf](float x, float y) {
    return packCell(static_cast<std::int64_t>(std::floor(x / leaf)), static_cast<std::int64_t>(std::floor(y / leaf)));
  };
  std::unordered_map<std::int64_t, int> cell_of;
  cell_of.reserve(band->points.size());
  pcl::PointCloud<pcl::PointXYZ>::Ptr flat(new pcl::PointCloud<pcl::PointXYZ>);
  std::vector<int> point_cell(band->points.size());
  for (std::size_t i = 0; i < band->points.size(); ++i)
  {
    const auto& q = band->points[i];
    const auto inserted = cell_of.emplace(cellKey(q.x, q.y), static_cast<int>(flat->points.size()));
    if (inserted.second)
      flat->points.emplace_back(q.x, q.y, 0.0f);
    point_cell[i] = inserted.first->second;
  }
  flat->width = static_cast<std::uint32_t>(flat->points.size());
  flat->height = 1;
  flat->is_dense = true;
  std::vector<pcl::PointIndices> cell_clusters;
  impl_->tree->setInputCloud(flat);
  pcl::EuclideanClusterExtraction<pcl::PointXYZ> ec;
  ec.setClusterTolerance(cfg.cluster_tolerance);
  ec.setMinClusterSize(1);
  ec.setMaxClusterSize(std::numeric_limits<int>::max());
  ec.setSearchMethod(impl_->tree);
  ec.setInputCloud(flat);
  ec.extract(cell_clusters);
  std::vector<int> cluster_of_cell(flat->points.size(), -1);
  for (std::size_t c = 0; c < cell_clusters.size(); ++c)
    for (int i : cell_clusters[c].indices)
      cluster_of_cell[static_cast<std::size_t>(i)] = static_cast<int>(c);
  std::vector<pcl::PointIndices> clusters(cell_clusters.size());
  for (std::size_t i = 0; i < band->points.size(); ++i)
    clusters[static_cast<std::size_t>(cluster_of_cell[static_cast<std::size_t>(point_cell[i])])].indices.push_back(
        static_cast<int>(i));
  st->clusters = static_cast<int>(clusters.size());

  struct Candidate
  {
    Points3 p;
    double z_lo, z_hi;
  };
  std::vector<Candidate> candidates;
  for (const auto& idx : clusters)
  {
    const int n = static_cast<int>(idx.indices.size());
    if (n < cfg.min_points || n > cfg.max_points)
    {
      ++st->rejected_size;
      continue;
    }
    Candidate c;
    c.p.reserve(idx.indices.size());
    c.z_lo = 1e9;
    c.z_hi = -1e9;
    for (int i : idx.indices)
    {
      const auto& q = band->points[static_cast<std::size_t>(i)];
      c.p.emplace_back(q.x, q.y, q.z);
      c.z_lo = std::min<double>(c.z_lo, q.z);
      c.z_hi = std::max<double>(c.z_hi, q.z);
    }
    if (c.z_hi - c.z_lo < cfg.min_vertical_extent)
    {
      ++st->rejected_shape;
      continue;
    }
    candidates.push_back(std::move(c));
  }

  split(&st->ms_cluster);
  // 5. Residual tilt from the trunks: trunks grow straight up, so the tilt that makes every candidate's
  //    horizontal projection the thinnest circle is the sensor's. Small angles: x += a z, y += b z.
  double tilt_a = 0.0, tilt_b = 0.0;
  if (cfg.level_by_trunks && cfg.method == TrunkMethod::kCircle)
  {
    std::vector<const Candidate*> usable;
    for (const auto& c : candidates)
    {
      std::vector<Eigen::Vector2d> p2;
      for (const auto& q : c.p)
        p2.emplace_back(q.x(), q.y());
      Eigen::Vector2d kc;
      double kr = 0.0;
      if (c.p.size() >= 20 && kasaFit(p2, &kc, &kr) && kr >= cfg.min_radius && kr <= cfg.max_radius &&
          kc.norm() > p2.front().norm() - cfg.max_radius)
        usable.push_back(&c);
    }
    if (usable.size() >= 2)
    {
      // Joint least squares: every usable trunk is a vertical cylinder (centre, radius of its own) in the
      // frame sheared by the shared tilt (a, b): residual |(x + a z - cx, y + b z - cy)| - r, z from the
      // band's middle. Gauss-Newton with the per-trunk parameters eliminated (Schur complement), Huber
      // weights, a weak prior on the tilt; up to 200 points per trunk.
      struct TrunkState
      {
        std::vector<Eigen::Vector3d> p;
        Eigen::Vector3d phi;  // cx, cy, r
      };
      std::vector<TrunkState> ts;
      for (const Candidate* c : usable)
      {
        TrunkState t;
        const double z_mid = 0.5 * (c->z_lo + c->z_hi);
        const std::size_t stride = std::max<std::size_t>(1, c->p.size() / 200);
        std::vector<Eigen::Vector2d> p2;
        for (std::size_t i = 0; i < c->p.size(); i += stride)
        {
          t.p.emplace_back(c->p[i].x(), c->p[i].y(), c->p[i].z() - z_mid);
          p2.emplace_back(c->p[i].x(), c->p[i].y());
        }
        Eigen::Vector2d kc;
        double kr = 0.0;
        if (!kasaFit(p2, &kc, &kr))
          continue;
        t.phi = Eigen::Vector3d(kc.x(), kc.y(), kr);
        ts.push_back(std::move(t));
      }
      const double sigma = cfg.range_sigma;
      const double huber = 2.0 * sigma;
      const double prior = 1.0 / (0.2 * 0.2);  // tilt prior: 0.2 rad
      Eigen::Vector2d theta(0.0, 0.0);
      for (int it = 0; it < 8 && ts.size() >= 2; ++it)
      {
        Eigen::Matrix2d S = Eigen::Matrix2d::Identity() * prior * sigma * sigma;
        Eigen::Vector2d rhs = -prior * sigma * sigma * theta;
        std::vector<Eigen::Matrix3d> Hff(ts.size());
        std::vector<Eigen::Matrix<double, 2, 3>> Htf(ts.size());
        std::vector<Eigen::Vector3d> gf(ts.size());
        for (std::size_t k = 0; k < ts.size(); ++k)
        {
          Eigen::Matrix2d Htt = Eigen::Matrix2d::Zero();
          Eigen::Vector2d gt = Eigen::Vector2d::Zero();
          Hff[k].setZero();
          Htf[k].setZero();
          gf[k].setZero();
          for (const auto& q : ts[k].p)
          {
            const Eigen::Vector2d d(q.x() + theta.x() * q.z() - ts[k].phi.x(), q.y() + theta.y() * q.z() - ts[k].phi.y());
            const double n = d.norm();
            if (n < 1e-9)
              continue;
            const double res = n - ts[k].phi.z();
            const double w = std::abs(res) <= huber ? 1.0 : huber / std::abs(res);
            const Eigen::Vector2d jt(d.x() / n * q.z(), d.y() / n * q.z());
            const Eigen::Vector3d jf(-d.x() / n, -d.y() / n, -1.0);
            Htt += w * jt * jt.transpose();
            Htf[k] += w * jt * jf.transpose();
            Hff[k] += w * jf * jf.transpose();
            gt += w * jt * res;
            gf[k] += w * jf * res;
          }
          Hff[k].diagonal().array() += 1e-9;
          const Eigen::Matrix3d inv = Hff[k].inverse();
          S += Htt - Htf[k] * inv * Htf[k].transpose();
          rhs += -gt + Htf[k] * inv * gf[k];
        }
        const Eigen::Vector2d dtheta = S.ldlt().solve(rhs);
        if (!dtheta.allFinite())
          break;
        theta += dtheta;
        for (std::size_t k = 0; k < ts.size(); ++k)
          ts[k].phi += Hff[k].inverse() * (-gf[k] - Htf[k].transpose() * dtheta);
        if (theta.norm() > std::tan(cfg.max_tilt))
        {
          theta.setZero();  // implausible: keep the input's levelling
          break;
        }
        if (dtheta.norm() < 1e-5)
          break;
      }
      tilt_a = theta.x();
      tilt_b = theta.y();
    }
  }
  st->tilt_pitch = std::atan(tilt_a);
  st->tilt_roll = -std::atan(tilt_b);

  split(&st->ms_tilt);
  // 6. Fit each candidate in the levelled frame; reject non-trunks.
  std::vector<Eigen::Vector2d> p2;
  for (const auto& c : candidates)
  {
    const double z_mid = 0.5 * (c.z_lo + c.z_hi);
    p2.clear();
    for (const auto& q : c.p)
      p2.emplace_back(q.x() + tilt_a * q.z(), q.y() + tilt_b * q.z());  // levelled about the sensor origin
    const int n = static_cast<int>(p2.size());
    const Fit fit = fitCluster(p2, cfg);
    if (int* reason = rejectReason(fit, n, cfg, st))
    {
      ++*reason;
      continue;
    }
    // Verticality: the centroids of the lower and upper halves of the cluster, after levelling, must sit
    // above each other (a lying branch or a slanted bush does not).
    Eigen::Vector2d lo = Eigen::Vector2d::Zero(), hi = Eigen::Vector2d::Zero();
    int nlo = 0, nhi = 0;
    for (std::size_t i = 0; i < c.p.size(); ++i)
    {
      if (c.p[i].z() < z_mid)
      {
        lo += p2[i];
        ++nlo;
      }
      else
      {
        hi += p2[i];
        ++nhi;
      }
    }
    if (nlo > 2 && nhi > 2)
    {
      const double shift = (hi / nhi - lo / nlo).norm();
      if (shift > std::tan(cfg.max_tilt) * 0.5 * (c.z_hi - c.z_lo) + 2.0 * cfg.ransac_threshold)
      {
        ++st->rejected_shape;
        continue;
      }
    }
    out.push_back(toObservation(fit, n, z_mid));
  }
  split(&st->ms_fit);
  st->trunks = static_cast<int>(out.size());
  ++impl_->calls;
  return out;
}

std::vector<TrunkObservation> TrunkDetector::detectScan(const PlanarScan& scan, TrunkDetectorStats* stats)
{
  TrunkDetectorStats local_stats;
  TrunkDetectorStats* st = stats ? stats : &local_stats;
  *st = TrunkDetectorStats();
  const TrunkDetectorConfig& cfg = config_;
  std::vector<TrunkObservation> out;
  st->input_points = static_cast<int>(scan.ranges.size());

  // REP-117: NaN (an erroneous reading), -Inf (too close to measure), 0 and readings below range_min tell
  // nothing about what is there; +Inf and readings beyond range_max say that nothing is there (no return). A
  // beam that tells nothing neither ends an arc nor bounds one: arcs run across it (their points stay closer
  // than the cluster tolerance or they split), and the neighbour tests look past it. Otherwise every dropout in a
  // wall would cut it into short arcs that look like trunks.
  const auto uninformative = [&](double raw) { return std::isnan(raw) || raw <= 0.0 || raw < scan.range_min; };
  // Arcs: runs of valid beams whose neighbours are closer than the cluster tolerance.
  std::vector<std::vector<Eigen::Vector2d>> arcs;
  std::vector<std::pair<int, int>> spans;  // first and last beam of each arc
  std::vector<Eigen::Vector2d> current;
  int first = -1, last = -1;  // beams of the current arc's first and last point
  Eigen::Vector2d prev(0.0, 0.0);
  const auto close = [&]() {
    if (!current.empty())
    {
      arcs.push_back(current);
      spans.emplace_back(first, last);
    }
    current.clear();
  };
  for (std::size_t i = 0; i < scan.ranges.size(); ++i)
  {
    const double raw = scan.ranges[i];
    if (uninformative(raw))
      continue;
    const bool valid = std::isfinite(raw) && raw <= scan.range_max;
    if (!valid)
    {
      close();
      continue;
    }
    const double r = raw + cfg.range_offset;
    ++st->finite_points;
    const double a = scan.angle_min + scan.angle_increment * static_cast<double>(i);
    const Eigen::Vector2d p(r * std::cos(a), r * std::sin(a));
    // Beams that told nothing in between widen the gap the surface leaves between two of its points: the
    // tolerance grows with the beams between them, so a dropout does not split a wall.
    if (!current.empty() && (p - prev).norm() > cfg.cluster_tolerance * static_cast<double>(static_cast<int>(i) - last))
      close();
    if (current.empty())
      first = static_cast<int>(i);
    last = static_cast<int>(i);
    current.push_back(p);
    prev = p;
  }
  close();
  st->clusters = static_cast<int>(arcs.size());
  st->band_points = st->finite_points;

  // A 2D arc may have very few points (a far trunk): fit with min_points 2 allowed by the arc fallback,
  // but still ask for the configured minimum (a single beam is no trunk).
  for (std::size_t k = 0; k < arcs.size(); ++k)
  {
    const auto& arc = arcs[k];
    const int n = static_cast<int>(arc.size());
    if (n < std::min(cfg.min_points, 3) || n > cfg.max_points)
    {
      ++st->rejected_size;
      continue;
    }
    // An arc partly hidden behind a nearer object is not a whole trunk side: the beams just outside it
    // must be further away (or no return).
    const auto nearer = [&](int beam, int step, double r) {
      const int count = static_cast<int>(scan.ranges.size());
      while (beam >= 0 && beam < count && uninformative(scan.ranges[static_cast<std::size_t>(beam)]))
        beam += step;
      if (beam < 0 || beam >= count)
        return false;
      const double rb = scan.ranges[static_cast<std::size_t>(beam)];
      return std::isfinite(rb) && rb < r - cfg.cluster_tolerance;
    };
    if (nearer(spans[k].first - 1, -1, arc.front().norm()) || nearer(spans[k].second + 1, 1, arc.back().norm()))
    {
      ++st->rejected_shape;
      continue;
    }
    const Fit fit = fitCluster(arc, cfg);
    if (int* reason = rejectReason(fit, n, cfg, st))
    {
      ++*reason;
      continue;
    }
    // A straight wall segment fits a huge circle or the prior: its arc must bulge towards the sensor.
    if (fit.method != TrunkMethod::kCentroid && fit.arc_angle > cfg.max_arc_angle)
    {
      ++st->rejected_shape;
      continue;
    }
    out.push_back(toObservation(fit, n, 0.0));
  }
  st->trunks = static_cast<int>(out.size());
  return out;
}

}  // namespace core
}  // namespace rbpf_slam
