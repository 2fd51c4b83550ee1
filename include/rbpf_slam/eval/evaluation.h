#ifndef RBPF_SLAM_EVAL_EVALUATION_H
#define RBPF_SLAM_EVAL_EVALUATION_H

#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/filter/pose2.h"

namespace rbpf_slam
{
namespace eval
{
/** @brief Optimal one-to-one assignment (Hungarian) minimising the sum of costs; -1 = unassigned. */
std::vector<int> optimalAssignment(const std::vector<std::vector<double>>& cost, double forbidden);

/** @brief A tree or an estimated feature in the map frame. */
struct MapPoint
{
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  double radius = 0.0;
};

/**
 * @brief The map counted against the true trees: features matched to true trees one-to-one (optimal assignment,
 * 0.5 m gate); recall over the trees that came inside the visibility scope (1-12 m in the simulated runs: only
 * trees seen count), reported beside the duplicates and the spurious features; duplicates
 * = unmatched features within 1.0 m of a matched tree that are not closer to another tree; spurious = the
 * other unmatched features (provisional ones count too).
 */
struct MapScore
{
  int trees_seen = 0;
  int matched = 0;
  int duplicates = 0;
  int spurious = 0;
  double recall = 0.0;
  double mean_distance = 0.0;  ///< [m] tree to matched feature
  double radius_rms = 0.0;     ///< [m] fused radius error of matched features
};

MapScore scoreMap(const std::vector<MapPoint>& trees, const std::vector<bool>& tree_seen,
                  const std::vector<MapPoint>& features, double gate = 0.5, double duplicate_radius = 1.0);

/**
 * @brief RMS of position differences of two equally long trajectories (no alignment: the start is known), for
 * the in-process simulator runs. Runs on bags are scored by the package's one evaluator, rbpf_slam.evaluate
 * (evaluate_bag_run, trajectory_eval: ATE after a rigid fit, RPE).
 */
double absoluteTrajectoryRmse(const std::vector<core::Pose2>& estimate, const std::vector<core::Pose2>& truth);

}  // namespace eval
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_EVAL_EVALUATION_H
