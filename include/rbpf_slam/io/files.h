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

/** @brief @p path without its file name's extension ("a/map.csv" -> "a/map"; "a.b/map" stays). */
std::string withoutExtension(const std::string& path);

/** @brief Creates @p dir and its parents (mkdir -p); true when the folder exists afterwards. */
bool makeDirectories(const std::string& dir);

/**
 * @brief The one temporary-then-rename of the package's C++ writers: an output file is written to temporary(),
 * beside path() in the same folder, and renamed into place by commit(), so path() never holds half a file.
 * Until then path() keeps what it had; an AtomicFile destroyed without commit() (an exception, an early
 * return) removes its temporary. For writers that need a file name (rosbag); whole contents in memory go
 * through writeFilesAtomic().
 */
class AtomicFile
{
public:
  explicit AtomicFile(std::string path);
  ~AtomicFile();
  AtomicFile(AtomicFile&& other) noexcept;
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  AtomicFile& operator=(AtomicFile&&) = delete;

  const std::string& path() const { return path_; }
  /** @brief Where to write: path() + ".partial-" + the process id. */
  const std::string& temporary() const { return temporary_; }
  /** @brief Renames temporary() to path(). @throws std::runtime_error naming path() and the reason. */
  void commit();
  /** @brief Removes the temporary now (the destructor does it too when commit() did not succeed). */
  void discard();

private:
  std::string path_;
  std::string temporary_;
  bool pending_ = true;
};

/** @brief A file's path and its whole content. */
using FileContent = std::pair<std::string, std::string>;

/**
 * @brief Writes every file so that none is ever seen half-written: each content goes to its AtomicFile's
 * temporary first; only when all are written are they renamed into place, in the order given (so a file that
 * names another, a map YAML its image, comes after it). When any write fails every temporary is removed,
 * nothing is renamed, and std::runtime_error names the file and the reason.
 */
void writeFilesAtomic(const std::vector<FileContent>& files);
inline void writeFileAtomic(const std::string& path, const std::string& content)
{
  writeFilesAtomic({ { path, content } });
}

/**
 * @brief A run's timing.json (the offline runners' and the FastSLAM node's run folders; evaluate_bag_run reads it):
 * the counts and processing seconds; @p extra, when given, are further `"key": value` pairs.
 */
std::string timingJson(int sweeps, int updates, double extraction, double filter, int particles, unsigned long long seed,
                       const std::string& extra = std::string());

}  // namespace io
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_IO_FILES_H
