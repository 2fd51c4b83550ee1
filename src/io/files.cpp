#include "rbpf_slam/io/files.h"

#include <cerrno>
#include <cstdlib>

#include <sys/stat.h>

namespace rbpf_slam
{
namespace io
{
std::string expandHome(const std::string& path)
{
  if (path.size() >= 2 && path[0] == '~' && path[1] == '/')
  {
    const char* home = std::getenv("HOME");
    if (home != nullptr)
      return std::string(home) + path.substr(1);
  }
  return path;
}

bool makeDirectories(const std::string& dir)
{
  std::size_t pos = 0;
  while (pos != std::string::npos)
  {
    pos = dir.find('/', pos + 1);
    const std::string partial = dir.substr(0, pos);
    if (!partial.empty() && ::mkdir(partial.c_str(), 0755) != 0 && errno != EEXIST)
      return false;
  }
  return true;
}

}  // namespace io
}  // namespace rbpf_slam
