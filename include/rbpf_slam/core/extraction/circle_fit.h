#ifndef RBPF_SLAM_CORE_EXTRACTION_CIRCLE_FIT_H
#define RBPF_SLAM_CORE_EXTRACTION_CIRCLE_FIT_H

#include <vector>

#include <Eigen/Core>

namespace rbpf_slam
{
namespace core
{
/**
 * @brief Algebraic (Kasa) circle fit: least squares on x² + y² + D x + E y + F = 0, about the points' mean.
 *
 * Fast and closed-form, but biased towards small circles on short noisy arcs; a start for refineCircle().
 * @return false for fewer than 3 points or when the solution is no real circle. Collinear points are not caught
 * (they give some circle through their spread): callers check the inliers and the radius.
 */
bool fitCircleAlgebraic(const std::vector<Eigen::Vector2d>& points, Eigen::Vector2d* center, double* radius);

/** @brief The circle through three points; false when they are (nearly) collinear. */
bool circleThrough(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c, Eigen::Vector2d* center,
                   double* radius);

/** @brief fitCircleAlgebraic() on the points' horizontal projection (z ignored). */
bool fitCircleAlgebraicProjected(const std::vector<Eigen::Vector3d>& points, Eigen::Vector2d* center,
                                 double* radius);

/** @brief Number of points whose distance to the circle, |‖p − c‖ − r|, is at most @p threshold [m]. */
int countCircleInliers(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& center, double radius,
                       double threshold);

/** @brief The points within @p threshold [m] of the circle, in their order. */
std::vector<Eigen::Vector2d> circleInliers(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& center,
                                           double radius, double threshold);

/** @brief Angle the points subtend at @p center [rad]: 2π minus the widest angular gap between them. */
double subtendedAngle(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& center);

/** @brief Settings of ransacCircle(). */
struct RansacCircleParams
{
  double min_radius = 0.04;  ///< [m] circles outside the radius limits count no inliers
  double max_radius = 0.6;   ///< [m]
  double threshold = 0.04;   ///< [m] inlier distance
  int max_iterations = 100;  ///< cap on the samples drawn
};

/**
 * @brief RANSAC circle through three sampled points, the one with the most inliers.
 *
 * Repeatable: the sampler starts from the same fixed state on every call.
 * @return false when no sample gave a circle within the radius limits.
 */
bool ransacCircle(const std::vector<Eigen::Vector2d>& points, const RansacCircleParams& params, Eigen::Vector2d* center,
                  double* radius);

/** @brief Noise and radius prior of refineCircle() and circleCovariance(). */
struct CircleRefineParams
{
  double range_sigma = 0.02;   ///< [m] standard deviation of a point's distance to the true circle
  double radius_prior = 0.15;  ///< [m] weak prior on the radius, so that short arcs stay well posed
  double radius_sigma = 0.08;  ///< [m] its standard deviation
};

/**
 * @brief Geometric least squares for (cx, cy, r) by Gauss-Newton from the given circle, with the radius prior.
 *
 * Clusters of more than a few hundred points are thinned evenly for the iterations, each kept point weighted for
 * those it stands for, so the information stays that of all points.
 * @param[in,out] center, radius start on input, estimate on output (unchanged on failure)
 * @param[out] covariance of (cx, cy, r), from circleCovariance()
 * @return false when the iterations diverge or the radius is not positive.
 */
bool refineCircle(const std::vector<Eigen::Vector2d>& points, const CircleRefineParams& params, Eigen::Vector2d* center,
                  double* radius, Eigen::Matrix3d* covariance);

/**
 * @brief Covariance of a fitted circle (cx, cy, r): the inverse of its information, whose data part is scaled down
 * by the residuals' own variance where it exceeds the sensor's (clutter or a non-circular trunk), the prior's not.
 * @param information Gauss-Newton information JᵀJ/σ² of the fit, with the radius prior's 1/σr² included.
 * @return false when the covariance is not finite.
 */
bool circleCovariance(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& center, double radius,
                      const Eigen::Matrix3d& information, const CircleRefineParams& params,
                      Eigen::Matrix3d* covariance);

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_EXTRACTION_CIRCLE_FIT_H
