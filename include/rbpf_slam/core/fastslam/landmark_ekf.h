#ifndef RBPF_SLAM_CORE_FASTSLAM_LANDMARK_EKF_H
#define RBPF_SLAM_CORE_FASTSLAM_LANDMARK_EKF_H

#include <Eigen/Core>

#include "rbpf_slam/core/fastslam/landmark_map.h"
#include "rbpf_slam/core/fastslam/landmark_observation.h"
#include "rbpf_slam/core/filter/pose2.h"

namespace rbpf_slam
{
namespace core
{
/**
 * @brief EKF update of one landmark's position by a matched range-bearing observation: gain
 * K = P H^T S^-1, mean += K v, covariance in the Joseph form (I - K H) P (I - K H)^T + K R K^T.
 * @param H Jacobian of the predicted observation with respect to the landmark
 * @param s_inv inverse of the innovation covariance S (H P H^T + R, plus the pose's part if any)
 * @param v innovation (range [m], bearing [rad]): observed minus predicted
 * @param R observation noise of (range, bearing)
 */
void updateLandmarkPosition(Landmark* l, const Eigen::Matrix2d& H, const Eigen::Matrix2d& s_inv,
                            const Eigen::Vector2d& v, const Eigen::Matrix2d& R);

/**
 * @brief Fuses an observed trunk radius into @p l (scalar Kalman update, i.e. inverse-variance weighting); the
 * first known radius replaces an unknown one. Observations without a radius variance leave @p l unchanged.
 */
void fuseLandmarkRadius(Landmark* l, const LandmarkObservation& o);

/**
 * @brief A new landmark from observation @p o (noise @p R) by the sensor at pose @p sensor (map frame): its
 * position, the covariance G R G^T with G the Jacobian of the position with respect to (range, bearing), and
 * the observed radius. Evidence, observation count, state and id are left at their defaults for the caller.
 */
Landmark landmarkFromObservation(const LandmarkObservation& o, const Pose2& sensor, const Eigen::Matrix2d& R);

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FASTSLAM_LANDMARK_EKF_H
