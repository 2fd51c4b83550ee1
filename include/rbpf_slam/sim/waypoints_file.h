#ifndef RBPF_SLAM_SIM_WAYPOINTS_FILE_H
#define RBPF_SLAM_SIM_WAYPOINTS_FILE_H

#include <string>
#include <vector>

#include <Eigen/Core>

namespace rbpf_slam
{
namespace sim
{
/**
 * @brief The waypoints of a drive file: `x y` per line [m, start frame], in driving order; '#' starts a
 * comment, blank lines are skipped.
 * @throws std::runtime_error naming the file: it cannot be read, it holds no waypoint, or (with the line
 * number) a line is not two finite numbers.
 */
std::vector<Eigen::Vector2d> readWaypoints(const std::string& path);

/**
 * @brief A drive by name, as the recorder, the benchmarks and the path follower node take it: "straight"
 * (sim::straightDrive), "loop" (sim::loopDrive) or a waypoint file (readWaypoints). Empty, with the reason
 * in @p error, when the name is neither and the file cannot be read or parsed.
 */
std::vector<Eigen::Vector2d> namedDrive(const std::string& name, std::string* error);

}  // namespace sim
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_SIM_WAYPOINTS_FILE_H
