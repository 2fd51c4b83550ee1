// One cluster's trunk: centroid or circle fit, acceptance, verticality, the observation.
#include "rbpf_slam/core/extraction/trunk_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <Eigen/Eigenvalues>

#include "rbpf_slam/core/extraction/circle_fit.h"

namespace rbpf_slam
{
namespace core
{
namespace
{
constexpr double kPi = 3.14159265358979323846;
constexpr double kCleanFraction = 0.95;  // [-] an algebraic circle explaining this share of the points needs no RANSAC
constexpr double kCentroidBias = 0.5;    // [radii] the centroid's own error, towards the sensor
constexpr double kCentroidFloor = 1e-4;  // [m^2] (1 cm)^2 added to the centroid's variance
constexpr int kMinHalfPoints = 3;        // [points] each half of a cluster needs this many for the verticality test
constexpr double kFullCoverage = 0.5 * kPi;  // [rad] an arc this wide counts as fully covered in the score
constexpr double kPoorFitOutliers = 0.05;  // [-] share of points beyond the inlier distance that may be a second trunk
constexpr double kPoorFitRms = 1.5;     // [range sigmas] capped residuals beyond this RMS leave room for a second trunk
constexpr int kPairCuts = 32;           // places along the bearing order where a cluster may be cut into two trunks
constexpr double kPairRssRatio = 0.5;   // [-] two circles must at least halve the single circle's capped residuals
constexpr int kPairIterations = 4;     // fits and reassignments of the two parts at most
constexpr double kPairOverlap = 0.75;   // [inlier distances] two trunks' circles may overlap by this much (radius errors)
constexpr double kRssFloor = 0.1;
constexpr double kSilhouetteSlack = 0.005;  // [rad] a silhouette may end this much (about a beam) beyond its points       // [range sigmas] RMS floor of the residuals compared (exact data stay finite)

Eigen::Vector2d meanOf(const std::vector<Eigen::Vector2d>& points)
{
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& q : points)
    mean += q;
  return mean / static_cast<double>(points.size());
}

CircleRefineParams refineParams(const TrunkDetectorConfig& config)
{
  CircleRefineParams p;
  p.range_sigma = config.range_sigma;
  p.radius_prior = config.arc_radius_prior;
  p.radius_sigma = config.arc_radius_sigma;
  return p;
}

/**
 * The circle to refine: the algebraic fit or RANSAC when either gives a trunk-sized circle behind the points (a
 * trunk's visible side faces the sensor), with have_circle set; else the algebraic fit on all points, else the arc
 * fallback, both with have_circle false (every point is then an inlier).
 */
void initialCircle(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& mean,
                   const TrunkDetectorConfig& config, Eigen::Vector2d* center, double* radius, bool* have_circle)
{
  const int n = static_cast<int>(points.size());
  *center = mean + mean.normalized() * config.arc_radius_prior;
  *radius = config.arc_radius_prior;
  *have_circle = false;
  if (n < config.min_fit_points)
    return;
  const auto behindAndSized = [&](const Eigen::Vector2d& c, double r) {
    return c.norm() > mean.norm() && r >= config.min_radius && r <= config.max_radius;
  };
  // A clean cluster (the algebraic fit on all points already explains nearly all of them) needs no RANSAC; the
  // robust sampler is for clusters with clutter in them.
  Eigen::Vector2d kc;
  double kr = 0.0;
  const bool algebraic = fitCircleAlgebraic(points, &kc, &kr) && behindAndSized(kc, kr);
  if (algebraic && countCircleInliers(points, kc, kr, config.ransac_threshold) >= kCleanFraction * n)
  {
    *center = kc;
    *radius = kr;
    *have_circle = true;
    return;
  }
  RansacCircleParams ransac;
  ransac.min_radius = config.min_radius;
  ransac.max_radius = config.max_radius;
  ransac.threshold = config.ransac_threshold;
  ransac.max_iterations = config.ransac_iterations;
  Eigen::Vector2d rc;
  double rr = 0.0;
  if (ransacCircle(points, ransac, &rc, &rr) && rc.norm() > mean.norm())
  {
    *center = rc;
    *radius = rr;
    *have_circle = true;
    return;
  }
  if (algebraic)
  {
    *center = kc;
    *radius = kr;
  }
}
/** Standard normal density and distribution. */
double normalPdf(double z)
{
  return std::exp(-0.5 * z * z) / std::sqrt(2.0 * kPi);
}
double normalCdf(double z)
{
  return 0.5 * std::erfc(-z / std::sqrt(2.0));
}

/**
 * Mean and variance of N(mu, sigma^2) truncated to [lo, hi]: the radius prior once the arc's width has said that the
 * trunk is at least half as wide as its chord.
 */
void truncatedNormal(double mu, double sigma, double lo, double hi, double* mean, double* variance)
{
  const double a = (lo - mu) / sigma, b = (hi - mu) / sigma;
  const double z = normalCdf(b) - normalCdf(a);
  if (z > 1e-12)
  {
    const double d = (normalPdf(a) - normalPdf(b)) / z;
    *mean = mu + sigma * d;
    *variance = sigma * sigma * std::max(1e-6, 1.0 + (a * normalPdf(a) - b * normalPdf(b)) / z - d * d);
  }
  else  // far in the upper tail: nearly exponential above lo with scale sigma^2 / (lo - mu)
  {
    const double scale = std::min(hi - lo, sigma * sigma / std::max(lo - mu, 1e-9));
    *mean = lo + scale;
    *variance = scale * scale;
  }
}
}  // namespace

TrunkFit fitTrunkCentroid(const std::vector<Eigen::Vector2d>& points, const TrunkDetectorConfig& config)
{
  TrunkFit fit;
  const int n = static_cast<int>(points.size());
  const Eigen::Vector2d mean = meanOf(points);
  // Radius: half the widest extent across the line of sight.
  const Eigen::Vector2d across = Eigen::Vector2d(-mean.y(), mean.x()).normalized();
  double lo = 1e9, hi = -1e9;
  for (const auto& q : points)
  {
    const double s = across.dot(q);
    lo = std::min(lo, s);
    hi = std::max(hi, s);
  }
  fit.center = mean;
  fit.radius = 0.5 * (hi - lo);
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  for (const auto& q : points)
    scatter += (q - mean) * (q - mean).transpose();
  fit.covariance.setZero();
  const double bias = kCentroidBias * fit.radius;
  fit.covariance.topLeftCorner<2, 2>() =
      scatter / (static_cast<double>(n) * n) + Eigen::Matrix2d::Identity() * (bias * bias + kCentroidFloor);
  fit.covariance(2, 2) = std::pow(bias + config.range_sigma, 2);
  fit.inliers = n;
  fit.arc_angle = 0.0;
  fit.method = TrunkMethod::kCentroid;
  fit.ok = true;
  return fit;
}

TrunkFit fitTrunkCircle(const std::vector<Eigen::Vector2d>& points, const TrunkDetectorConfig& config)
{
  TrunkFit fit;
  const int n = static_cast<int>(points.size());
  const Eigen::Vector2d mean = meanOf(points);
  Eigen::Vector2d c;
  double r = 0.0;
  bool have_circle = false;
  initialCircle(points, mean, config, &c, &r, &have_circle);

  // Least squares on the inliers of the initial circle (all points when there is none).
  std::vector<Eigen::Vector2d> in = have_circle ? circleInliers(points, c, r, config.ransac_threshold) : points;
  if (in.size() < 3)
    in = points;
  const CircleRefineParams refine = refineParams(config);
  Eigen::Matrix3d cov;
  if (!refineCircle(in, refine, &c, &r, &cov))
    return fit;
  // The inliers were chosen around the initial circle; an algebraic or sampled circle is biased (short noisy arcs
  // fit small circles), so a window around it cuts the residuals asymmetrically and the refinement inherits the
  // bias. Choose them again around the refined circle and refine once more.
  if (have_circle)
  {
    std::vector<Eigen::Vector2d> again = circleInliers(points, c, r, config.ransac_threshold);
    if (again.size() >= 3 && again.size() != in.size())
    {
      Eigen::Vector2d c2 = c;
      double r2 = r;
      Eigen::Matrix3d cov2;
      if (refineCircle(again, refine, &c2, &r2, &cov2))
      {
        c = c2;
        r = r2;
        cov = cov2;
        in.swap(again);
      }
    }
  }
  fit.inliers = countCircleInliers(points, c, r, config.ransac_threshold);
  fit.center = c;
  fit.radius = r;
  fit.covariance = cov;
  fit.arc_angle = subtendedAngle(in, c);
  fit.method =
      (n < config.min_fit_points || fit.arc_angle < config.min_fit_arc) ? TrunkMethod::kArc : TrunkMethod::kCircle;
  fit.ok = true;
  return fit;
}

TrunkFit fitShortArc(const std::vector<Eigen::Vector2d>& points, double beam_spacing, const TrunkDetectorConfig& config)
{
  // Too few beams, too close together, to measure the curvature: the radius comes from the prior, the centre is one
  // radius behind the arc's middle. Frame: u along the ray through the middle of the arc's lateral extent, v across.
  //
  //   Radius: the prior N(arc_radius_prior, arc_radius_sigma^2), truncated to [max(min_radius, w), max_radius] where
  //   w is half the chord (the points lie on the trunk, so it is at least that wide): mean R, variance sR^2.
  //   Centre along the ray: every point i at lateral offset x_i from the middle ray lies sqrt(R^2 - x_i^2) in front
  //   of the centre, so rho_c = mean_i(rho_i + sqrt(R^2 - x_i^2)). Its variance sums
  //     - the radius: (dRho/dR)^2 sR^2 with dRho/dR = mean_i R / sqrt(R^2 - x_i^2) (>= 1: a point near the
  //       silhouette's edge says little about the depth; the root is kept >= R/4 so the slope stays <= 4),
  //     - the range noise: range_sigma^2 / n,
  //     - the bearing of the points: a beam of width about its spacing s = rho_c * beam_spacing returns from
  //       anywhere across it, uniformly, so x_i is uncertain by s/sqrt(12) and moves the depth by
  //       x_i / sqrt(R^2 - x_i^2) times that.
  //   Centre across the ray: the trunk may sit anywhere that gives the same beams. The set of centres whose
  //   silhouette (2R wide) covers exactly these beams and misses their neighbours is an interval at most one beam
  //   spacing long, whatever R; a uniform distribution over it has a variance of at most s^2/12 (the beam width's
  //   own s/sqrt(12) is the same bound), plus range_sigma^2 / n for the points' own noise.
  //   The centre's depth and the radius are correlated: cov(rho_c, R) = dRho/dR sR^2.
  TrunkFit fit;
  const int n = static_cast<int>(points.size());
  if (n < 1)
    return fit;
  const Eigen::Vector2d mean = meanOf(points);
  if (!(mean.norm() > 0.0))
    return fit;
  Eigen::Vector2d u = mean.normalized();
  Eigen::Vector2d v(-u.y(), u.x());
  double x_lo = 0.0, x_hi = 0.0;
  for (const auto& q : points)
  {
    x_lo = std::min(x_lo, v.dot(q - mean));
    x_hi = std::max(x_hi, v.dot(q - mean));
  }
  const Eigen::Vector2d middle = mean + v * (0.5 * (x_lo + x_hi));
  u = middle.normalized();
  v = Eigen::Vector2d(-u.y(), u.x());
  const double half_chord = 0.5 * (x_hi - x_lo);

  const double lo = std::max(config.min_radius, half_chord);
  const double hi = std::max(config.max_radius, lo + 1e-3);
  double radius = 0.0, radius_var = 0.0;
  truncatedNormal(config.arc_radius_prior, config.arc_radius_sigma, lo, hi, &radius, &radius_var);

  double depth = 0.0, slope_r = 0.0, slope_x = 0.0;
  for (const auto& q : points)
  {
    const double x = v.dot(q);
    const double root = std::max(std::sqrt(std::max(radius * radius - x * x, 0.0)), 0.25 * radius);
    depth += u.dot(q) + root;
    slope_r += radius / root;
    slope_x += std::abs(x) / root;
  }
  depth /= n;
  slope_r /= n;
  slope_x /= n;
  const double spacing = depth * std::abs(beam_spacing);
  const double range_var = config.range_sigma * config.range_sigma / n;
  const double along_var = slope_r * slope_r * radius_var + range_var + slope_x * slope_x * spacing * spacing / 12.0;
  const double across_var = spacing * spacing / 12.0 + range_var;

  fit.center = u * depth;
  fit.radius = radius;
  fit.covariance.setZero();
  fit.covariance.topLeftCorner<2, 2>() = along_var * u * u.transpose() + across_var * v * v.transpose();
  fit.covariance.topRightCorner<2, 1>() = slope_r * radius_var * u;
  fit.covariance.bottomLeftCorner<1, 2>() = slope_r * radius_var * u.transpose();
  fit.covariance(2, 2) = radius_var;
  fit.inliers = n;
  fit.arc_angle = 2.0 * std::asin(std::min(1.0, half_chord / radius));
  fit.method = TrunkMethod::kArc;
  fit.ok = true;
  return fit;
}

namespace
{
/** The start (centre x, centre y, radius): one prior radius behind the middle of the arc's lateral extent. */
Eigen::Vector3d partialArcStart(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& mean,
                                const TrunkDetectorConfig& config)
{
  const Eigen::Vector2d u0 = mean.normalized(), v0(-u0.y(), u0.x());
  double x_lo = 0.0, x_hi = 0.0;
  for (const auto& q : points)
  {
    x_lo = std::min(x_lo, v0.dot(q - mean));
    x_hi = std::max(x_hi, v0.dot(q - mean));
  }
  const Eigen::Vector2d middle = mean + v0 * (0.5 * (x_lo + x_hi));
  Eigen::Vector3d x;
  x << middle + middle.normalized() * config.arc_radius_prior, config.arc_radius_prior;
  return x;
}

/** The least squares of fitPartialArc over (centre x, centre y, radius): the points, the radius prior, the edges. */
class PartialArcProblem
{
public:
  PartialArcProblem(const std::vector<Eigen::Vector2d>& points, const std::vector<SilhouetteEdge>& edges,
                    const Eigen::Vector2d& mean, const TrunkDetectorConfig& config)
      : points_(points), edges_(edges), config_(config), side_(edges.size())
  {
    // The centre lies on the arc's side of each edge ray: the sign of (mean x direction).
    for (std::size_t k = 0; k < edges.size(); ++k)
      side_[k] = mean.x() * edges[k].direction.y() - mean.y() * edges[k].direction.x() >= 0.0 ? 1.0 : -1.0;
    sigma2_ = config.range_sigma * config.range_sigma;
    prior_w_ = 1.0 / (config.arc_radius_sigma * config.arc_radius_sigma);
  }

  /** Information, gradient and chi-square at `at`. */
  double linearise(const Eigen::Vector3d& at, Eigen::Matrix3d* info, Eigen::Vector3d* grad) const
  {
    info->setZero();
    grad->setZero();
    double sum = 0.0;
    for (const auto& q : points_)
    {
      const Eigen::Vector2d d = q - at.head<2>();
      const double dn = d.norm();
      if (dn < 1e-9)
        continue;
      const double res = dn - at.z();
      const Eigen::Vector3d J(-d.x() / dn, -d.y() / dn, -1.0);
      *info += J * J.transpose() / sigma2_;
      *grad += J * res / sigma2_;
      sum += res * res / sigma2_;
    }
    (*info)(2, 2) += prior_w_;
    grad->z() += prior_w_ * (at.z() - config_.arc_radius_prior);
    sum += prior_w_ * std::pow(at.z() - config_.arc_radius_prior, 2);
    for (std::size_t k = 0; k < edges_.size(); ++k)
    {
      // Distance from the centre to the edge ray, minus the radius. The edge lies anywhere between the two beams
      // (uniform over their spacing s at the trunk's range: variance s^2/12), and each beam, about as wide as
      // its spacing, returns from anywhere across it (as much again); the range noise does not move it sideways.
      const Eigen::Vector2d& e = edges_[k].direction;
      const double lateral = at.head<2>().norm() * edges_[k].spacing;
      const double var = 2.0 * lateral * lateral / 12.0;
      const double res = side_[k] * (at.x() * e.y() - at.y() * e.x()) - at.z();
      const Eigen::Vector3d J(side_[k] * e.y(), -side_[k] * e.x(), -1.0);
      *info += J * J.transpose() / var;
      *grad += J * res / var;
      sum += res * res / var;
    }
    return sum;
  }

private:
  const std::vector<Eigen::Vector2d>& points_;
  const std::vector<SilhouetteEdge>& edges_;
  const TrunkDetectorConfig& config_;
  std::vector<double> side_;
  double sigma2_ = 0.0, prior_w_ = 0.0;
};

/** Gauss-Newton from @p x: false when a step is not finite. */
bool minimisePartialArc(const PartialArcProblem& problem, Eigen::Vector3d* x)
{
  constexpr int kIterations = 20;
  constexpr double kMaxStep = 0.5;     // [m] per iteration
  constexpr double kConverged = 1e-7;  // [m]
  Eigen::Matrix3d H;
  Eigen::Vector3d g;
  for (int it = 0; it < kIterations; ++it)
  {
    problem.linearise(*x, &H, &g);
    const Eigen::Vector3d step = H.ldlt().solve(-g);
    if (!step.allFinite())
      return false;
    *x += step.norm() > kMaxStep ? (step * (kMaxStep / step.norm())).eval() : step;
    if (step.norm() < kConverged)
      break;
  }
  return true;
}

/**
 * Whether the points show the trunk's front, its point nearest the sensor: the centre's bearing lies within theirs,
 * widened by a mean beam spacing of the arc and two standard deviations of the centre's bearing. Then the front
 * pins the depth and the silhouette edge the side; a few beams beside an occluder, or the end of a wall, which a
 * circle of the prior radius fits as well as a trunk's edge does, show no front.
 */
bool showsTrunkFront(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& c, const Eigen::Matrix3d& cov)
{
  const int n = static_cast<int>(points.size());
  const double bearing_c = std::atan2(c.y(), c.x());
  double lo = 1e9, hi = -1e9;
  for (const auto& q : points)
  {
    const double b = std::remainder(std::atan2(q.y(), q.x()) - bearing_c, 2.0 * kPi);
    lo = std::min(lo, b);
    hi = std::max(hi, b);
  }
  const Eigen::Vector2d across(-c.y() / c.norm(), c.x() / c.norm());
  const double margin =
      (hi - lo) / std::max(1, n - 1) + 2.0 * std::sqrt(across.dot(cov.topLeftCorner<2, 2>() * across)) / c.norm();
  return !(lo > margin || hi < -margin);
}
}  // namespace

TrunkFit fitPartialArc(const std::vector<Eigen::Vector2d>& points, const std::vector<SilhouetteEdge>& edges,
                       const TrunkDetectorConfig& config)
{
  constexpr double kChi2Z = 3.09;  // standard normal quantile of 99.9 %
  TrunkFit fit;
  const int n = static_cast<int>(points.size());
  if (n < 2)
    return fit;
  // Start one prior radius behind the middle of the arc's lateral extent (as fitShortArc places the centre).
  const Eigen::Vector2d mean = meanOf(points);
  if (!(mean.norm() > 0.0))
    return fit;
  Eigen::Vector3d x = partialArcStart(points, mean, config);
  const PartialArcProblem problem(points, edges, mean, config);
  if (!minimisePartialArc(problem, &x))
    return fit;
  if (!x.allFinite() || x.z() <= 0.0)
    return fit;
  Eigen::Matrix3d H;
  Eigen::Vector3d g;
  const double chi2 = problem.linearise(x, &H, &g);
  const Eigen::Matrix3d cov = H.inverse();
  if (!cov.allFinite())
    return fit;
  // Chi-square's 99.9 % quantile by the Wilson-Hilferty approximation.
  const auto quantile = [&](double dof) {
    const double h = 2.0 / (9.0 * dof);
    return dof * std::pow(1.0 - h + kChi2Z * std::sqrt(h), 3);
  };
  // Residuals against the noise.
  const double dof = static_cast<double>(n + 1 + static_cast<int>(edges.size()) - 3);
  if (dof < 1.0 || chi2 > quantile(dof))
    return fit;
  // The visible piece hardly measures the radius: a fit that needs one beyond three of the prior's standard
  // deviations is no trunk of this kind (a wall's end fits a wide circle).
  if (std::abs(x.z() - config.arc_radius_prior) > 3.0 * config.arc_radius_sigma)
    return fit;
  const Eigen::Vector2d c = x.head<2>();
  // The sensor sees only the half of a circle that faces it: a point whose direction from the centre points away
  // from the sensor (beyond the noise) says that the circle is the wrong one.
  for (const auto& q : points)
    if ((q - c).dot(q.normalized()) > 3.0 * config.range_sigma)
      return fit;
  if (!(c.norm() > mean.norm()))
    return fit;
  if (!showsTrunkFront(points, c, cov))
    return fit;
  fit.center = c;
  fit.radius = x.z();
  fit.covariance = cov;
  fit.inliers = countCircleInliers(points, c, x.z(), config.ransac_threshold);
  fit.arc_angle = subtendedAngle(points, c);
  fit.method =
      (n < config.min_fit_points || fit.arc_angle < config.min_fit_arc) ? TrunkMethod::kArc : TrunkMethod::kCircle;
  fit.ok = true;
  return fit;
}

bool isTrunkShapedArc(const std::vector<Eigen::Vector2d>& points, const TrunkDetectorConfig& config)
{
  const int n = static_cast<int>(points.size());
  if (n < 2)
    return true;
  // Width: the points lie on the trunk's visible side, which is no wider than the trunk.
  const Eigen::Vector2d a = points.front(), b = points.back();
  const double chord = (b - a).norm();
  if (chord > 2.0 * config.max_radius)
    return false;
  if (n < 3 || chord <= 0.0)
    return true;
  // Curvature: a trunk's side bulges towards the sensor at least as much as the flattest trunk (max_radius) through
  // the same ends does. The inner points' mean offset from the chord, towards the sensor, beyond that bulge must not
  // be below minus three of its standard deviations (a point's offset from a chord of two noisy ends: range_sigma
  // times sqrt(1.5)). A straight wall or a car's side bulges by nothing, a box's corner away from the sensor.
  const Eigen::Vector2d mid = 0.5 * (a + b), t = (b - a) / chord;
  Eigen::Vector2d towards(-t.y(), t.x());
  if (towards.dot(-mid) < 0.0)
    towards = -towards;
  const double r2 = config.max_radius * config.max_radius;
  const double base = std::sqrt(std::max(r2 - 0.25 * chord * chord, 0.0));
  double excess = 0.0;
  for (int i = 1; i + 1 < n; ++i)
  {
    const Eigen::Vector2d& q = points[static_cast<std::size_t>(i)];
    const double x = t.dot(q - mid);
    const double bulge = std::sqrt(std::max(r2 - x * x, 0.0)) - base;
    excess += towards.dot(q - a) - bulge;
  }
  const int inner = n - 2;
  excess /= inner;
  return excess >= -3.0 * config.range_sigma * std::sqrt(1.5 / inner);
}

TrunkFit fitTrunk(const std::vector<Eigen::Vector2d>& points, const TrunkDetectorConfig& config)
{
  return config.method == TrunkMethod::kCentroid ? fitTrunkCentroid(points, config) : fitTrunkCircle(points, config);
}

TrunkRejection checkTrunkFit(const TrunkFit& fit, int num_points, const TrunkDetectorConfig& config)
{
  if (!fit.ok)
    return TrunkRejection::kShape;
  if (fit.radius < config.min_radius || fit.radius > config.max_radius)
    return TrunkRejection::kRadius;
  if (static_cast<double>(fit.inliers) < config.min_inlier_ratio * num_points)
    return TrunkRejection::kInliers;
  const double range = fit.center.norm();
  if (range < config.min_range || range > config.max_range)
    return TrunkRejection::kShape;
  return TrunkRejection::kNone;
}

bool isPoorSingleFit(const std::vector<Eigen::Vector2d>& points, const TrunkFit& fit, TrunkRejection rejection,
                     const TrunkDetectorConfig& config)
{
  if (rejection != TrunkRejection::kNone || !fit.ok)
    return true;
  const double t = config.ransac_threshold;
  int outliers = 0;
  double ss = 0.0;
  for (const auto& q : points)
  {
    const double e = std::abs((q - fit.center).norm() - fit.radius);
    outliers += e > t;
    ss += std::pow(std::min(e, t), 2);
  }
  if (outliers >= std::max(static_cast<double>(config.min_fit_points), kPoorFitOutliers * points.size()))
    return true;
  return !points.empty() && ss / static_cast<double>(points.size()) > std::pow(kPoorFitRms * config.range_sigma, 2);
}

namespace
{
using Moments = Eigen::Matrix<double, 11, 1>;

/** The points' bearings about the bearing @p b0 (wrapped). */
std::vector<double> bearingsAbout(const std::vector<Eigen::Vector2d>& points, double b0)
{
  std::vector<double> bearing(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    bearing[i] = std::remainder(std::atan2(points[i].y(), points[i].x()) - b0, 2.0 * kPi);
  return bearing;
}

/** The indices of @p bearing in its increasing order (stable). */
std::vector<int> bearingOrder(const std::vector<double>& bearing)
{
  std::vector<int> order(bearing.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return bearing[static_cast<std::size_t>(a)] < bearing[static_cast<std::size_t>(b)];
  });
  return order;
}

/** The distance of @p q from the circle of @p fit. */
double distanceTo(const TrunkFit& fit, const Eigen::Vector2d& q)
{
  return std::abs((q - fit.center).norm() - fit.radius);
}

/**
 * The partitions of a cluster in bearing order into a middle interval and the rest, scored by the parts' algebraic
 * fits from running sums of their moments.
 */
class PairCuts
{
public:
  PairCuts(const std::vector<Eigen::Vector2d>& points, const std::vector<int>& order, const Eigen::Vector2d& mean,
           int min_part, const TrunkDetectorConfig& config)
      : prefix_(points.size() + 1, Moments::Zero()),
        mean_(mean),
        n_(static_cast<int>(points.size())),
        min_part_(min_part),
        config_(config)
  {
    // Running sums in that order of the algebraic fit's moments (about the mean, where they stay well conditioned):
    // 1, x, y, xx, xy, yy, xz, yz, z, zz with z = xx + yy, and the range.
    for (std::size_t k = 0; k < order.size(); ++k)
    {
      const Eigen::Vector2d& p = points[static_cast<std::size_t>(order[k])];
      const Eigen::Vector2d q = p - mean;
      const double z = q.squaredNorm();
      Moments m;
      m << 1.0, q.x(), q.y(), q.x() * q.x(), q.x() * q.y(), q.y() * q.y(), q.x() * z, q.y() * z, z, z * z, p.norm();
      prefix_[k + 1] = prefix_[k] + m;
    }
    total_ = prefix_.back();
  }

  /**
   * The middle interval [lo, hi) of the order against the rest. With two cuts the middle trunk hides the other
   * on both sides, so it must be the nearer one.
   */
  double partition(int lo, int hi) const
  {
    const int inner = hi - lo;
    if (inner < min_part_ || n_ - inner < min_part_)
      return std::numeric_limits<double>::infinity();
    const Moments middle = prefix_[static_cast<std::size_t>(hi)] - prefix_[static_cast<std::size_t>(lo)];
    double s1 = 0.0, s2 = 0.0, range1 = 0.0, range2 = 0.0;
    score(middle, &s1, &range1);
    score(total_ - middle, &s2, &range2);
    if (lo > 0 && hi < n_ && !(range1 < range2))
      return std::numeric_limits<double>::infinity();
    return s1 + s2;
  }

  /** One cut: every place. */
  double bestOneCut(int* one_cut) const
  {
    double best_one = std::numeric_limits<double>::infinity();
    for (int k = min_part_; k + min_part_ <= n_; ++k)
    {
      const double s = partition(0, k);
      if (s < best_one)
      {
        best_one = s;
        *one_cut = k;
      }
    }
    return best_one;
  }

  /** Two cuts: a grid of kPairCuts places, then each cut moved to its best place nearby. */
  double bestTwoCuts(int* lo_cut, int* hi_cut) const
  {
    const int n = n_;
    double best_two = std::numeric_limits<double>::infinity();
    int two_lo = -1, two_hi = -1;
    const int cuts = std::min(kPairCuts, n);
    for (int i = 1; i < cuts; ++i)
      for (int j = i + 1; j < cuts; ++j)
      {
        const int lo = static_cast<int>(static_cast<long>(i) * n / cuts);
        const int hi = static_cast<int>(static_cast<long>(j) * n / cuts);
        const double s = partition(lo, hi);
        if (s < best_two)
        {
          best_two = s;
          two_lo = lo;
          two_hi = hi;
        }
      }
    if (two_lo >= 0)
    {
      const int reach = n / cuts + 1;
      for (int pass = 0; pass < 2; ++pass)
      {
        const int lo0 = two_lo, hi0 = two_hi;
        for (int lo = std::max(1, lo0 - reach); lo <= lo0 + reach; ++lo)
        {
          const double s = partition(lo, two_hi);
          if (s < best_two)
          {
            best_two = s;
            two_lo = lo;
          }
        }
        for (int hi = hi0 - reach; hi <= std::min(n - 1, hi0 + reach); ++hi)
        {
          const double s = partition(two_lo, hi);
          if (s < best_two)
          {
            best_two = s;
            two_hi = hi;
          }
        }
      }
    }
    *lo_cut = two_lo;
    *hi_cut = two_hi;
    return best_two;
  }

private:
  /**
   * A part's residuals' sum of squares as distances: to its algebraic circle (|p - c|^2 - r^2 is about 2 r times
   * the distance) when that is a trunk-sized circle behind the part's points, else to its straight line (a piece too
   * short or too noisy to show its curvature; its circle is fitted with the radius prior afterwards). Also the
   * range of the part's centre (its circle's, or its mean range plus the prior radius).
   */
  void score(const Moments& m, double* sse, double* centre_range) const
  {
    const double count = m(0);
    Eigen::Matrix3d A;
    A << m(3), m(4), m(1), m(4), m(5), m(2), m(1), m(2), m(0);
    const Eigen::Vector3d b(m(6), m(7), m(8));
    const Eigen::Vector3d s = A.ldlt().solve(-b);
    const Eigen::Vector2d part_mean = mean_ + Eigen::Vector2d(m(1), m(2)) / count;
    if (s.allFinite())
    {
      const double r2 = 0.25 * (s.x() * s.x() + s.y() * s.y()) - s.z();
      const Eigen::Vector2d c = mean_ + Eigen::Vector2d(-0.5 * s.x(), -0.5 * s.y());
      if (r2 >= config_.min_radius * config_.min_radius && r2 <= config_.max_radius * config_.max_radius &&
          c.norm() > part_mean.norm())
      {
        *sse = std::max(0.0, m(9) + b.dot(s)) / (4.0 * r2);
        *centre_range = c.norm();
        return;
      }
    }
    const Eigen::Vector2d d = Eigen::Vector2d(m(1), m(2)) / count;
    Eigen::Matrix2d scatter;
    scatter << m(3) - count * d.x() * d.x(), m(4) - count * d.x() * d.y(), m(4) - count * d.x() * d.y(),
        m(5) - count * d.y() * d.y();
    *sse =
        std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(scatter, Eigen::EigenvaluesOnly).eigenvalues()(0));
    *centre_range = m(10) / count + config_.arc_radius_prior;
  }

  std::vector<Moments> prefix_;
  Moments total_;
  Eigen::Vector2d mean_;
  int n_, min_part_;
  const TrunkDetectorConfig& config_;
};

/** The candidate partitions of fitTrunkPair, tried one by one: the best that passes every test is kept in the pair. */
class PairTrials
{
public:
  PairTrials(const std::vector<Eigen::Vector2d>& points, const std::vector<int>& order, int min_part, double b0,
             double bearing_lo, double bearing_hi, double rss1, double floor, const TrunkDetectorConfig& config,
             TrunkPairFit* pair)
      : points_(points),
        order_(order),
        n_(static_cast<int>(points.size())),
        min_part_(min_part),
        t_(config.ransac_threshold),
        b0_(b0),
        bearing_lo_(bearing_lo),
        bearing_hi_(bearing_hi),
        rss1_(rss1),
        floor_(floor),
        config_(config),
        pair_(pair)
  {
  }

  /** The partition of the middle interval [lo, hi) of the order against the rest (none when lo < 0). */
  void tryPartition(int lo, int hi)
  {
    if (lo < 0)
      return;
    Parts parts;
    if (!fitParts(lo, hi, &parts) || !arePairOfTrunks(parts))
      return;
    // Clearly better than one circle: residuals capped at the inlier distance.
    double rss2 = 0.0;
    for (const auto& q : points_)
      rss2 += std::pow(std::min(std::min(distanceTo(parts.fit[0], q), distanceTo(parts.fit[1], q)), t_), 2);
    rss2 = std::max(rss2, floor_);
    if (!(rss2 <= kPairRssRatio * rss1_) ||
        !(static_cast<double>(n_) * std::log(rss1_ / rss2) - 4.0 * std::log(static_cast<double>(n_)) > 0.0) ||
        !(rss2 < best_rss_))
      return;
    best_rss_ = rss2;
    pair_->ok = true;
    for (int p = 0; p < 2; ++p)
    {
      pair_->fits[p] = parts.fit[p];
      pair_->members[p] = parts.member[p];
    }
  }

private:
  struct Parts
  {
    std::vector<int> member[2];
    TrunkFit fit[2];
  };

  /** The parts' circles, refitted until their members stay; false when a part's fit fails. */
  bool fitParts(int lo, int hi, Parts* parts)
  {
    for (int k = 0; k < n_; ++k)
      parts->member[k >= lo && k < hi ? 0 : 1].push_back(order_[static_cast<std::size_t>(k)]);
    for (int it = 0; it < kPairIterations; ++it)
    {
      for (int p = 0; p < 2; ++p)
      {
        std::sort(parts->member[p].begin(), parts->member[p].end());
        part_.clear();
        for (int i : parts->member[p])
          part_.push_back(points_[static_cast<std::size_t>(i)]);
        parts->fit[p] = fitTrunkCircle(part_, config_);
        if (!parts->fit[p].ok)
          return false;
      }
      std::vector<int> again[2];
      for (int i = 0; i < n_; ++i)
      {
        const Eigen::Vector2d& q = points_[static_cast<std::size_t>(i)];
        again[distanceTo(parts->fit[0], q) <= distanceTo(parts->fit[1], q) ? 0 : 1].push_back(i);
      }
      if (again[0] == parts->member[0] || static_cast<int>(again[0].size()) < min_part_ ||
          static_cast<int>(again[1].size()) < min_part_)
        break;
      parts->member[0].swap(again[0]);
      parts->member[1].swap(again[1]);
    }
    return true;
  }

  /** Whether the parts' circles are two trunks side by side that the points show whole. */
  bool arePairOfTrunks(const Parts& parts) const
  {
    // Each part a trunk of its own, seen over a wide enough arc.
    for (int p = 0; p < 2; ++p)
    {
      const int size = static_cast<int>(parts.member[p].size());
      if (size < min_part_ || parts.fit[p].method != TrunkMethod::kCircle ||
          checkTrunkFit(parts.fit[p], size, config_) != TrunkRejection::kNone)
        return false;
    }
    // Two trunks side by side, not one circle fitted twice nor a trunk and a sliver of itself: the circles overlap
    // by at most kPairOverlap inlier distances (their radii's errors).
    const double apart = (parts.fit[0].center - parts.fit[1].center).norm();
    if (apart < parts.fit[0].radius + parts.fit[1].radius - kPairOverlap * t_)
      return false;
    // The two silhouettes end where the points end: nothing else hides the pair's outer edges.
    for (int p = 0; p < 2; ++p)
    {
      const TrunkFit& fit = parts.fit[p];
      const double range = fit.center.norm();
      if (!(range > fit.radius))
        return false;
      const double half = std::asin(fit.radius / range);
      const double centre = std::remainder(std::atan2(fit.center.y(), fit.center.x()) - b0_, 2.0 * kPi);
      const double margin = 2.0 * t_ / range + kSilhouetteSlack;
      if (centre - half < bearing_lo_ - margin || centre + half > bearing_hi_ + margin)
        return false;
    }
    return true;
  }

  const std::vector<Eigen::Vector2d>& points_;
  const std::vector<int>& order_;
  const int n_, min_part_;
  const double t_, b0_, bearing_lo_, bearing_hi_, rss1_, floor_;
  const TrunkDetectorConfig& config_;
  TrunkPairFit* pair_;
  std::vector<Eigen::Vector2d> part_;  // scratch: one part's points
  double best_rss_ = std::numeric_limits<double>::infinity();
};
}  // namespace

TrunkPairFit fitTrunkPair(const std::vector<Eigen::Vector2d>& points, const TrunkFit& single,
                          const TrunkDetectorConfig& config)
{
  TrunkPairFit pair;
  const int n = static_cast<int>(points.size());
  const int min_part = std::max(config.min_fit_points, config.min_points);
  if (config.method != TrunkMethod::kCircle || n < 2 * min_part)
    return pair;
  const Eigen::Vector2d mean = meanOf(points);
  if (!(mean.norm() > 0.0))
    return pair;

  // Bearing order, about the bearing of the cluster's mean.
  const double b0 = std::atan2(mean.y(), mean.x());
  const std::vector<double> bearing = bearingsAbout(points, b0);
  const std::vector<int> order = bearingOrder(bearing);

  const double bearing_lo = bearing[static_cast<std::size_t>(order.front())];
  const double bearing_hi = bearing[static_cast<std::size_t>(order.back())];

  const PairCuts cuts(points, order, mean, min_part, config);
  // The single circle's residuals, each capped at the inlier distance.
  const double t = config.ransac_threshold;
  double rss1 = 0.0;
  for (const auto& q : points)
    rss1 += single.ok ? std::pow(std::min(std::abs((q - single.center).norm() - single.radius), t), 2) : t * t;
  const double floor = static_cast<double>(n) * std::pow(kRssFloor * config.range_sigma, 2);
  rss1 = std::max(rss1, floor);

  // One cut: every place. Two cuts: a grid of kPairCuts places, then each cut moved to its best place nearby.
  int one_cut = -1, two_lo = -1, two_hi = -1;
  const double best_one = cuts.bestOneCut(&one_cut);
  const double best_two = cuts.bestTwoCuts(&two_lo, &two_hi);

  // Each candidate partition: fit each part, give every point to the circle it lies nearer to, and again until
  // the parts stay. Kept when its circles pass every test.
  PairTrials trials(points, order, min_part, b0, bearing_lo, bearing_hi, rss1, floor, config, &pair);
  // The partition the algebraic circles explain better first, the other only when it fails; neither when even the
  // better one does not explain the points better than the single circle (its residuals uncapped).
  if (!(std::min(best_one, best_two) < rss1))
    return pair;
  if (best_two < best_one)
  {
    trials.tryPartition(two_lo, two_hi);
    if (!pair.ok && std::isfinite(best_one))
      trials.tryPartition(0, one_cut);
  }
  else
  {
    trials.tryPartition(0, one_cut);
    if (!pair.ok && std::isfinite(best_two))
      trials.tryPartition(two_lo, two_hi);
  }
  return pair;
}

void countRejection(TrunkRejection rejection, TrunkDetectorStats* stats)
{
  switch (rejection)
  {
    case TrunkRejection::kNone:
      break;
    case TrunkRejection::kShape:
      ++stats->rejected_shape;
      break;
    case TrunkRejection::kRadius:
      ++stats->rejected_radius;
      break;
    case TrunkRejection::kInliers:
      ++stats->rejected_inliers;
      break;
  }
}

bool isUpright(const TrunkCandidate& candidate, const std::vector<Eigen::Vector2d>& levelled,
               const TrunkDetectorConfig& config)
{
  const double z_mid = candidate.zMid();
  Eigen::Vector2d lo = Eigen::Vector2d::Zero(), hi = Eigen::Vector2d::Zero();
  int nlo = 0, nhi = 0;
  for (std::size_t i = 0; i < candidate.points.size(); ++i)
  {
    if (candidate.points[i].z() < z_mid)
    {
      lo += levelled[i];
      ++nlo;
    }
    else
    {
      hi += levelled[i];
      ++nhi;
    }
  }
  if (nlo < kMinHalfPoints || nhi < kMinHalfPoints)
    return true;  // too few points to tell
  const double shift = (hi / nhi - lo / nlo).norm();
  // The axis may lean by max_tilt over half the span, plus what two noisy halves' centroids may disagree by.
  return !(shift > std::tan(config.max_tilt) * 0.5 * (candidate.z_hi - candidate.z_lo) + 2.0 * config.ransac_threshold);
}

TrunkObservation toTrunkObservation(const TrunkFit& fit, int num_points, double height)
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
  const double coverage = fit.method == TrunkMethod::kCentroid ? 1.0 : std::min(1.0, fit.arc_angle / kFullCoverage);
  o.score = ratio * (0.5 + 0.5 * coverage);
  o.method = fit.method;
  o.height = height;
  return o;
}

}  // namespace core
}  // namespace rbpf_slam
