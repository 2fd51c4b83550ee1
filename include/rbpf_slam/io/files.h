#ifndef RBPF_SLAM_IO_FILES_H
#define RBPF_SLAM_IO_FILES_H

#include <string>
#include <utility>
#include <vector>

namespace rbpf_slam
{
namespace io
{
/** @brief @p path with a leading "~/" replaced by $HOME (unchanged without HOME or without "~/"). */
std::string expandHome(const std::string& path);

/** @brief Creates @p dir and its parents (mkdir -p); true when the folder exists afterwards. */
bool makeDirectories(const std::string& dir);

/** @brief A file's path and its whole content. */
using FileContent = std::pair<std::string, std::string>;

/**
 * @brief Writes every file so that none is ever seen half-written: each content goes to a temporary beside its
 * path first; only when all are written are they renamed into place, in the order given (so a file that names
 * another, a map YAML its image, comes after it). When any write fails every temporary is removed, nothing is
 * renamed, and std::runtime_error names the file and the reason.
 */
void writeFilesAtomic(const std::vector<FileContent>& files);
inline void writeFileAtomic(const std::string& path, const std::string& content)
{
  writeFilesAtomic({ { path, content } });
}

}  // namespace io
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_IO_FILES_H
