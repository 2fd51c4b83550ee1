#include "rbpf_slam/io/files.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include <unistd.h>

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

void writeFilesAtomic(const std::vector<FileContent>& files)
{
  std::vector<std::string> temps;
  const auto removeTemps = [&temps]() {
    for (const auto& t : temps)
      std::remove(t.c_str());
  };
  for (const auto& f : files)
  {
    const std::string tmp = f.first + ".partial-" + std::to_string(static_cast<long>(::getpid()));
    temps.push_back(tmp);
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out)
    {
      const std::string reason = std::strerror(errno);
      removeTemps();
      throw std::runtime_error(f.first + ": cannot write (" + reason + ")");
    }
    out.write(f.second.data(), static_cast<std::streamsize>(f.second.size()));
    out.close();
    if (!out)
    {
      removeTemps();
      throw std::runtime_error(f.first + ": write error (disk full?)");
    }
  }
  for (std::size_t i = 0; i < files.size(); ++i)
    if (std::rename(temps[i].c_str(), files[i].first.c_str()) != 0)
    {
      const std::string reason = std::strerror(errno);
      for (std::size_t j = i; j < temps.size(); ++j)
        std::remove(temps[j].c_str());
      throw std::runtime_error(files[i].first + ": cannot rename the written file into place (" + reason + ")");
    }
}

}  // namespace io
}  // namespace rbpf_slam
