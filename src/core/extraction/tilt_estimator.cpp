#include "rbpf_slam/core/extraction/tilt_estimator.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "rbpf_slam/core/extraction/circle_fit.h"

namespace rbpf_slam
{
namespace core
{
namespace
{
constexpr std::size_t kMinPoints = 20;         // [points] fewer do not constrain a cylinder's axis
constexpr std::size_t kMaxPointsPerTrunk = 200;  // [points] each candidate is thinned evenly to about this many
constexpr int kIterations = 8;                 // Gauss-Newton iterations at most
constexpr double kPriorSigma = 0.2;            // [-] (about rad) weak prior on each shear component, centred on 0
constexpr double kHuberSigmas = 2.0;           // [-] residuals beyond this many range sigmas are down-weighted
constexpr double kConverged = 1e-5;            // [-] a tilt step this small ends the iterations
constexpr double kRegularizer = 1e-9;          // added to each trunk's information so it stays invertible
constexpr double kMinDistance = 1e-9;          // [m] a point this close to the axis has no direction

/** One usable candidate in the joint fit: its (thinned) points about its height middle, its cylinder. */
struct TrunkState
{
  std::vector<Eigen::Vector3d> p;  // x, y, z - z_mid
  Eigen::Vector3d phi;             // cx, cy, r
};

/** A candidate is usable when it has enough points and its algebraic circle is a trunk's behind its points. */
bool isUsable(const TrunkCandidate& c, const TiltEstimatorParams& params)
{
  if (c.points.size() < kMinPoints)
    return false;
  Eigen::Vector2d kc;
  double kr = 0.0;
  return fitCircleAlgebraicProjected(c.points, &kc, &kr) && kr >= params.min_radius && kr <= params.max_radius &&
         kc.norm() > c.points.front().head<2>().norm() - params.max_radius;
}
}  // namespace

Eigen::Vector2d estimateTiltFromTrunks(const std::vector<TrunkCandidate>& candidates,
                                       const TiltEstimatorParams& params)
{
  std::vector<const TrunkCandidate*> usable;
  for (const auto& c : candidates)
    if (isUsable(c, params))
      usable.push_back(&c);
  if (usable.size() < 2)
    return Eigen::Vector2d::Zero();

  std::vector<TrunkState> ts;
  for (const TrunkCandidate* c : usable)
  {
    TrunkState t;
    const double z_mid = c->zMid();
    const std::size_t stride = std::max<std::size_t>(1, c->points.size() / kMaxPointsPerTrunk);
    t.p.reserve(c->points.size() / stride + 1);
    for (std::size_t i = 0; i < c->points.size(); i += stride)
      t.p.emplace_back(c->points[i].x(), c->points[i].y(), c->points[i].z() - z_mid);
    Eigen::Vector2d kc;
    double kr = 0.0;
    if (!fitCircleAlgebraicProjected(t.p, &kc, &kr))
      continue;
    t.phi = Eigen::Vector3d(kc.x(), kc.y(), kr);
    ts.push_back(std::move(t));
  }
  const double sigma = params.range_sigma;
  const double huber = kHuberSigmas * sigma;
  const double prior = 1.0 / (kPriorSigma * kPriorSigma);
  Eigen::Vector2d theta(0.0, 0.0);
  std::vector<Eigen::Matrix3d> Hff(ts.size()), Hff_inv(ts.size());
  std::vector<Eigen::Matrix<double, 2, 3>> Htf(ts.size());
  std::vector<Eigen::Vector3d> gf(ts.size());
  for (int it = 0; it < kIterations && ts.size() >= 2; ++it)
  {
    // Normal equations of (tilt, every trunk's cylinder), with the cylinders eliminated: S dtheta = rhs.
    Eigen::Matrix2d S = Eigen::Matrix2d::Identity() * prior * sigma * sigma;
    Eigen::Vector2d rhs = -prior * sigma * sigma * theta;
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
        if (n < kMinDistance)
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
      Hff[k].diagonal().array() += kRegularizer;
      Hff_inv[k] = Hff[k].inverse();
      const Eigen::Matrix3d& inv = Hff_inv[k];
      S += Htt - Htf[k] * inv * Htf[k].transpose();
      rhs += -gt + Htf[k] * inv * gf[k];
    }
    const Eigen::Vector2d dtheta = S.ldlt().solve(rhs);
    if (!dtheta.allFinite())
      break;
    theta += dtheta;
    for (std::size_t k = 0; k < ts.size(); ++k)
      ts[k].phi += Hff_inv[k] * (-gf[k] - Htf[k].transpose() * dtheta);
    if (theta.norm() > std::tan(params.max_tilt))
      return Eigen::Vector2d::Zero();  // implausible: keep the input's levelling
    if (dtheta.norm() < kConverged)
      break;
  }
  return theta;
}

}  // namespace core
}  // namespace rbpf_slam
