#ifndef RBPF_SLAM_SIM_DRIVE_CHECK_H
#define RBPF_SLAM_SIM_DRIVE_CHECK_H

#include <string>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/sim/forest_world.h"
#include "rbpf_slam/sim/scenario.h"

namespace rbpf_slam
{
namespace sim
{
/** @brief The distance from (x, y) to the polyline @p path (to its one point when it has one; infinity when empty). */
double distanceToPolyline(const std::vector<Eigen::Vector2d>& path, double x, double y);

/**
 * @brief Whether the robot of @p config can follow its drive in @p world before it starts: false, with the reason
 * in @p error, for a drive with fewer than two distinct waypoints or a non-finite one, that leaves the ground (the
 * stand bounds widened by the ground's margin), or that passes nearer a trunk (at the ground) or a box than the
 * robot's footprint reaches sideways (the diff drive's footprint radius, half the car's width) plus the planner's
 * clearance, with the drive laid from config.sim.start in the world. With the planner on, every point of the drive
 * must be reachable within max_departure of it, round the trunks, boxes and the clutter the planner steers round
 * (what rises into its obstacle band for the 3D lidar, or the 2D scanner's plane: bushes, rocks, saplings, low
 * branches). A drive it passes can still meet a collision or not be finished: the follower steers on odometry, which
 * drifts, and sees only what its lidar sees (follower_benchmark measures that).
 */
bool checkDrive(const ForestWorld& world, const ScenarioConfig& config, std::string* error);

}  // namespace sim
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_SIM_DRIVE_CHECK_H
