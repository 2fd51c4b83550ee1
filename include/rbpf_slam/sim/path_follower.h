#ifndef RBPF_SLAM_SIM_PATH_FOLLOWER_H
#define RBPF_SLAM_SIM_PATH_FOLLOWER_H

#include <string>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/filter/pose2.h"
#include "rbpf_slam/sim/velocity_noise.h"

namespace rbpf_slam
{
namespace core
{
struct PathFollowerConfig
{
  double speed = 1.0;           ///< [m/s]
  double lookahead = 2.0;       ///< [m] pure-pursuit look-ahead distance
  double max_angular = 0.8;     ///< [rad/s]
  double goal_tolerance = 0.3;  ///< [m] done within this of the last waypoint (on the last segment)
};

/**
 * @brief Pure pursuit along a polyline, steering on the robot's own odometry (as a robot without
 * SLAM does): path and pose are both in the odom frame, which starts at the robot's start pose.
 */
class PathFollower
{
public:
  PathFollower(std::vector<Eigen::Vector2d> path, const PathFollowerConfig& config);

  /** @brief The command for odometry pose @p pose; zero once done. */
  VelocityCommand command(const Pose2& pose);
  bool done() const { return done_; }
  double length() const { return cumulative_.back(); }
  /** @brief Arc length reached along the path [m]. */
  double progress() const { return progress_; }

private:
  Eigen::Vector2d pointAt(double s) const;

  std::vector<Eigen::Vector2d> path_;
  std::vector<double> cumulative_;
  PathFollowerConfig config_;
  std::size_t segment_ = 0;
  double progress_ = 0.0;
  bool done_ = false;
};

/** @brief The straight drive: straight ahead for @p length metres (start frame). */
std::vector<Eigen::Vector2d> straightDrive(double length = 30.0);

/**
 * @brief A loop that revisits trees, in the start frame: ahead 6.5 m, then 1.5 turns of a circle of
 * radius 8.5 m (counter-clockwise, centre 15 m ahead), then straight out to 30 m ahead. Started at
 * (0, 15) heading +x in the paper world, the circle (centre (15, 15)) keeps >= 1.2 m from every trunk.
 */
std::vector<Eigen::Vector2d> loopDrive();

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_SIM_PATH_FOLLOWER_H
