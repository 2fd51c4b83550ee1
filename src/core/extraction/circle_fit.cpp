// Circle fits on the horizontal projection of a trunk: algebraic start, RANSAC for clusters with clutter, geometric
// least squares with a radius prior, and the covariance of the result.
#include "rbpf_slam/core/extraction/circle_fit.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <Eigen/Dense>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_circle.h>

namespace rbpf_slam
{
namespace core
{
namespace
{
constexpr double kPi = 3.14159265358979323846;
constexpr std::size_t kRefineMaxPoints = 400;  // [points] the Gauss-Newton iterations use at most about this many
constexpr int kRefineIterations = 10;          // Gauss-Newton iterations at most
constexpr double kRefineMaxStep = 0.5;         // [m] longest step: a degenerate arc may push the centre far away
constexpr double kRefineConverged = 1e-6;      // [m] a step this short ends the iterations
constexpr double kMinDistance = 1e-9;          // [m] a point this close to the centre has no direction
}  // namespace

namespace
{
/** The algebraic fit on the x and y of any points (2D, or 3D projected horizontally). */
template <typename Point>
bool fitCircleAlgebraicXY(const std::vector<Point>& points, Eigen::Vector2d* center, double* radius)
{
  if (points.size() < 3)
    return false;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& q : points)
    mean += Eigen::Vector2d(q.x(), q.y());
  mean /= static_cast<double>(points.size());
  // About the mean, so that the normal equations stay well conditioned far from the sensor.
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const auto& q0 : points)
  {
    const Eigen::Vector2d q = Eigen::Vector2d(q0.x(), q0.y()) - mean;
    const Eigen::Vector3d row(q.x(), q.y(), 1.0);
    const double z = q.squaredNorm();
    A += row * row.transpose();
    b -= row * z;
  }
  const Eigen::Vector3d s = A.ldlt().solve(b);
  if (!s.allFinite())
    return false;
  *center = mean + Eigen::Vector2d(-s.x() / 2.0, -s.y() / 2.0);
  const double r2 = (s.x() * s.x() + s.y() * s.y()) / 4.0 - s.z();
  if (!(r2 > 0.0))
    return false;
  *radius = std::sqrt(r2);
  return true;
}
}  // namespace

bool circleThrough(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c, Eigen::Vector2d* center,
                   double* radius)
{
  const Eigen::Vector2d ab = b - a, ac = c - a;
  const double det = 2.0 * (ab.x() * ac.y() - ab.y() * ac.x());
  if (std::abs(det) < 1e-12)
    return false;
  const double ab2 = ab.squaredNorm(), ac2 = ac.squaredNorm();
  const Eigen::Vector2d off((ac.y() * ab2 - ab.y() * ac2) / det, (ab.x() * ac2 - ac.x() * ab2) / det);
  *center = a + off;
  *radius = off.norm();
  return std::isfinite(*radius);
}

bool fitCircleAlgebraic(const std::vector<Eigen::Vector2d>& points, Eigen::Vector2d* center, double* radius)
{
  return fitCircleAlgebraicXY(points, center, radius);
}

bool fitCircleAlgebraicProjected(const std::vector<Eigen::Vector3d>& points, Eigen::Vector2d* center,
                                 double* radius)
{
  return fitCircleAlgebraicXY(points, center, radius);
}

int countCircleInliers(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& center, double radius,
                       double threshold)
{
  int inliers = 0;
  for (const auto& q : points)
    inliers += std::abs((q - center).norm() - radius) <= threshold;
  return inliers;
}

std::vector<Eigen::Vector2d> circleInliers(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& center,
                                           double radius, double threshold)
{
  std::vector<Eigen::Vector2d> in;
  in.reserve(points.size());
  for (const auto& q : points)
    if (std::abs((q - center).norm() - radius) <= threshold)
      in.push_back(q);
  return in;
}

double subtendedAngle(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& center)
{
  if (points.size() < 2)
    return 0.0;
  std::vector<double> a;
  a.reserve(points.size());
  for (const auto& q : points)
    a.push_back(std::atan2(q.y() - center.y(), q.x() - center.x()));
  std::sort(a.begin(), a.end());
  double widest_gap = a.front() + 2.0 * kPi - a.back();
  for (std::size_t i = 1; i < a.size(); ++i)
    widest_gap = std::max(widest_gap, a[i] - a[i - 1]);
  return 2.0 * kPi - widest_gap;
}

bool ransacCircle(const std::vector<Eigen::Vector2d>& points, const RansacCircleParams& params, Eigen::Vector2d* center,
                  double* radius)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->points.reserve(points.size());
  for (const auto& q : points)
    cloud->points.emplace_back(static_cast<float>(q.x()), static_cast<float>(q.y()), 0.0f);
  cloud->width = static_cast<std::uint32_t>(cloud->points.size());
  cloud->height = 1;
  // random = false: PCL seeds its sampler with a fixed value, so runs repeat.
  pcl::SampleConsensusModelCircle2D<pcl::PointXYZ>::Ptr model(
      new pcl::SampleConsensusModelCircle2D<pcl::PointXYZ>(cloud, false));
  model->setRadiusLimits(params.min_radius, params.max_radius);
  pcl::RandomSampleConsensus<pcl::PointXYZ> ransac(model, params.threshold);
  ransac.setMaxIterations(params.max_iterations);
  if (!ransac.computeModel())
    return false;
  Eigen::VectorXf coef;
  ransac.getModelCoefficients(coef);
  if (coef.size() != 3 || !coef.allFinite())
    return false;
  *center = Eigen::Vector2d(coef[0], coef[1]);
  *radius = coef[2];
  return true;
}

bool refineCircle(const std::vector<Eigen::Vector2d>& points, const CircleRefineParams& params, Eigen::Vector2d* center,
                  double* radius, Eigen::Matrix3d* covariance)
{
  Eigen::Vector3d x(center->x(), center->y(), *radius);
  const double prior_w = 1.0 / (params.radius_sigma * params.radius_sigma);
  const double sigma2 = params.range_sigma * params.range_sigma;
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  // Large clusters (near trunks) are thinned to about kRefineMaxPoints evenly spread points; each then stands for
  // `weight` points, so the information (and the covariance) stays that of all.
  const std::size_t stride = std::max<std::size_t>(1, points.size() / kRefineMaxPoints);
  const double weight =
      static_cast<double>(points.size()) / static_cast<double>((points.size() + stride - 1) / stride);
  for (int it = 0; it < kRefineIterations; ++it)
  {
    H.setZero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < points.size(); i += stride)
    {
      const Eigen::Vector2d d = points[i] - x.head<2>();
      const double n = d.norm();
      if (n < kMinDistance)
        continue;
      const double res = n - x.z();
      const Eigen::Vector3d J(-d.x() / n, -d.y() / n, -1.0);
      H += weight * J * J.transpose() / sigma2;
      g += weight * J * res / sigma2;
    }
    H(2, 2) += prior_w;
    g.z() += prior_w * (x.z() - params.radius_prior);
    const Eigen::Vector3d step = H.ldlt().solve(-g);
    if (!step.allFinite())
      return false;
    x += step.norm() > kRefineMaxStep ? (step * (kRefineMaxStep / step.norm())).eval() : step;
    if (step.norm() < kRefineConverged)
      break;
  }
  if (!x.allFinite() || x.z() <= 0.0)
    return false;
  // H is the information at the last iterate but one: the step from there is below the convergence limit, or the
  // iterations ran out and the covariance is approximate anyway.
  if (!circleCovariance(points, x.head<2>(), x.z(), H, params, covariance))
    return false;
  *center = x.head<2>();
  *radius = x.z();
  return true;
}

bool circleCovariance(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& center, double radius,
                      const Eigen::Matrix3d& information, const CircleRefineParams& params,
                      Eigen::Matrix3d* covariance)
{
  const double prior_w = 1.0 / (params.radius_sigma * params.radius_sigma);
  const double sigma2 = params.range_sigma * params.range_sigma;
  // Residual scale: the data's own spread if it exceeds the sensor noise.
  double ss = 0.0;
  for (const auto& q : points)
  {
    const double res = (q - center).norm() - radius;
    ss += res * res;
  }
  const double dof = std::max<double>(1.0, static_cast<double>(points.size()) - 3.0);
  const double scale = std::max(1.0, ss / dof / sigma2);
  Eigen::Matrix3d Hd = information;
  Hd(2, 2) -= prior_w;
  Hd *= 1.0 / scale;
  Hd(2, 2) += prior_w;
  const Eigen::Matrix3d cov = Hd.inverse();
  if (!cov.allFinite())
    return false;
  *covariance = cov;
  return true;
}

}  // namespace core
}  // namespace rbpf_slam
