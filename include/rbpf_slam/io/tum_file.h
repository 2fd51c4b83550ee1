#ifndef RBPF_SLAM_IO_TUM_FILE_H
#define RBPF_SLAM_IO_TUM_FILE_H

#include <ostream>
#include <string>
#include <vector>

#include "rbpf_slam/core/filter/pose2.h"

namespace rbpf_slam
{
namespace io
{
/**
 * @brief A stamp [s] as the files write it: fixed, nine decimals (nanoseconds, as ros::Time holds them), so that
 * Unix-epoch stamps keep their sub-millisecond part; empty for a non-finite one.
 */
std::string stampText(double stamp);
/** @brief One pose as a TUM trajectory line: t x y z qx qy qz qw (planar: z = 0, rotation about z). */
void writeTumLine(std::ostream& out, double stamp, const core::Pose2& pose);

/** @brief A whole trajectory in the TUM format (evo reads it). @throws std::runtime_error naming the file. */
void writeTum(const std::string& path, const std::vector<double>& stamps, const std::vector<core::Pose2>& poses);

/**
 * @brief Reads a TUM trajectory (t x y z qx qy qz qw; '#' comments) as planar poses (yaw from the quaternion).
 * @throws std::runtime_error naming the file and line when it cannot be read or a line is malformed.
 */
void readTum(const std::string& path, std::vector<double>* stamps, std::vector<core::Pose2>* poses);

}  // namespace io
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_IO_TUM_FILE_H
