// Files for the io tests: a fresh folder, whole-file reads and writes, a folder's listing.
#ifndef RBPF_SLAM_TEST_IO_TEMP_FILES_H
#define RBPF_SLAM_TEST_IO_TEMP_FILES_H

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <dirent.h>
#include <stdlib.h>

namespace temp_files
{
/** @brief A new empty folder /tmp/PREFIX_XXXXXX. */
inline std::string makeDir(const std::string& prefix)
{
  std::string pattern = "/tmp/" + prefix + "_XXXXXX";
  if (mkdtemp(&pattern[0]) == nullptr)
    throw std::runtime_error("mkdtemp failed");
  return pattern;
}

/** @brief Writes @p text to @p path; returns @p path. */
inline std::string writeFile(const std::string& path, const std::string& text)
{
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

/** @brief The whole content of @p path ("" when it cannot be read). */
inline std::string readFile(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

/** @brief The names in @p dir, "." and ".." left out, in the order readdir gives them. */
inline std::vector<std::string> listDir(const std::string& dir)
{
  std::vector<std::string> names;
  DIR* d = opendir(dir.c_str());
  if (d == nullptr)
    return names;
  while (const dirent* e = readdir(d))
  {
    const std::string name = e->d_name;
    if (name != "." && name != "..")
      names.push_back(name);
  }
  closedir(d);
  return names;
}
}  // namespace temp_files

#endif  // RBPF_SLAM_TEST_IO_TEMP_FILES_H
