#include "rbpf_slam/io/files.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <utility>

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

std::string withoutExtension(const std::string& path)
{
  const std::size_t dot = path.rfind('.'), slash = path.rfind('/');
  return dot != std::string::npos && (slash == std::string::npos || dot > slash + 1) ? path.substr(0, dot) : path;
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

AtomicFile::AtomicFile(std::string path)
  : path_(std::move(path)), temporary_(path_ + ".partial-" + std::to_string(static_cast<long>(::getpid())))
{
}

AtomicFile::AtomicFile(AtomicFile&& other) noexcept
  : path_(std::move(other.path_)), temporary_(std::move(other.temporary_)), pending_(other.pending_)
{
  other.pending_ = false;
}

AtomicFile::~AtomicFile()
{
  discard();
}

void AtomicFile::commit()
{
  if (!pending_)
    throw std::runtime_error(path_ + ": nothing to rename into place");
  if (std::rename(temporary_.c_str(), path_.c_str()) != 0)
  {
    const std::string reason = std::strerror(errno);
    discard();
    throw std::runtime_error(path_ + ": cannot rename the written file into place (" + reason + ")");
  }
  pending_ = false;
}

void AtomicFile::discard()
{
  if (pending_)
    std::remove(temporary_.c_str());
  pending_ = false;
}

void writeFilesAtomic(const std::vector<FileContent>& files)
{
  std::vector<AtomicFile> outputs;
  outputs.reserve(files.size());
  for (const auto& f : files)
  {
    outputs.emplace_back(f.first);
    std::ofstream out(outputs.back().temporary(), std::ios::binary | std::ios::trunc);
    if (!out)
      throw std::runtime_error(f.first + ": cannot write (" + std::strerror(errno) + ")");
    out.write(f.second.data(), static_cast<std::streamsize>(f.second.size()));
    out.close();
    if (!out)
      throw std::runtime_error(f.first + ": write error (disk full?)");
  }
  for (auto& o : outputs)
    o.commit();
}

std::string timingJson(int sweeps, int updates, double extraction, double filter, int particles, unsigned long long seed,
                       const std::string& extra)
{
  std::ostringstream timing;
  timing << "{\"sweeps\": " << sweeps << ", \"updates\": " << updates << ", \"seconds_extraction\": " << extraction
         << ", \"seconds_filter\": " << filter << ", \"particles\": " << particles << ", \"seed\": " << seed
         << (extra.empty() ? "" : ", ") << extra << "}\n";
  return timing.str();
}

}  // namespace io
}  // namespace rbpf_slam
