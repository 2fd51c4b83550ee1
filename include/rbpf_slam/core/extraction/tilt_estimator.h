#ifndef RBPF_SLAM_CORE_EXTRACTION_TILT_ESTIMATOR_H
#define RBPF_SLAM_CORE_EXTRACTION_TILT_ESTIMATOR_H

#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/extraction/trunk_clustering.h"

namespace rbpf_slam
{
namespace core
{
/** @brief Settings of estimateTiltFromTrunks(). */
struct TiltEstimatorParams
{
  double min_radius = 0.04;   ///< [m] a candidate is used when its algebraic circle is a trunk's
  double max_radius = 0.6;    ///< [m]
  double range_sigma = 0.02;  ///< [m] sensor range noise (scales the Huber threshold and the prior)
  double max_tilt = 0.35;     ///< [rad] a larger estimate is implausible and gives no tilt
};

/**
 * @brief The sensor's residual tilt from the verticality of the trunks, as a shear (a, b): the levelled point is
 * (x + a z, y + b z) (small angles: pitch = atan a, roll = −atan b).
 *
 * Trunks grow straight up, so the tilt that makes every candidate's horizontal projection the thinnest circle is
 * the sensor's. Joint least squares: every usable candidate (enough points, an algebraic circle of a trunk's
 * radius behind its points) is a vertical cylinder with its own centre and radius in the frame sheared by the
 * shared tilt; residual |(x + a z − cx, y + b z − cy)| − r, z from the middle of the candidate's height span.
 * Gauss-Newton with the per-trunk parameters eliminated (Schur complement), Huber weights and a weak prior on
 * the tilt.
 * @return (0, 0) with fewer than two usable candidates or an implausible estimate.
 */
Eigen::Vector2d estimateTiltFromTrunks(const std::vector<TrunkCandidate>& candidates,
                                       const TiltEstimatorParams& params);

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_EXTRACTION_TILT_ESTIMATOR_H
