#ifndef RBPF_SLAM_IO_FILES_H
#define RBPF_SLAM_IO_FILES_H

#include <string>

namespace rbpf_slam
{
namespace io
{
/** @brief @p path with a leading "~/" replaced by $HOME (unchanged without HOME or without "~/"). */
std::string expandHome(const std::string& path);

/** @brief Creates @p dir and its parents (mkdir -p); true when the folder exists afterwards. */
bool makeDirectories(const std::string& dir);

}  // namespace io
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_IO_FILES_H
