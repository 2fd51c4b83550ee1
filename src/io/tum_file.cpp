#include "rbpf_slam/io/tum_file.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "rbpf_slam/io/files.h"

namespace rbpf_slam
{
namespace io
{
std::string stampText(double stamp)
{
  if (!std::isfinite(stamp))
    return "";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.9f", stamp);
  return buf;
}

void writeTumLine(std::ostream& out, double stamp, const core::Pose2& p)
{
  out << stampText(stamp) << ' ' << p.x << ' ' << p.y << " 0 0 0 " << std::sin(0.5 * p.theta) << ' ' << std::cos(0.5 * p.theta)
      << '\n';
}

void writeTum(const std::string& path, const std::vector<double>& stamps, const std::vector<core::Pose2>& poses)
{
  std::ostringstream out;
  out.precision(12);
  for (std::size_t i = 0; i < poses.size() && i < stamps.size(); ++i)
    writeTumLine(out, stamps[i], poses[i]);
  writeFileAtomic(path, out.str());
}

void readTum(const std::string& path, std::vector<double>* stamps, std::vector<core::Pose2>* poses)
{
  std::ifstream in(path);
  if (!in)
    throw std::runtime_error(path + ": cannot read");
  stamps->clear();
  poses->clear();
  std::string line;
  int n = 0;
  while (std::getline(in, line))
  {
    ++n;
    if (line.empty() || line[0] == '#')
      continue;
    std::istringstream ss(line);
    double t, x, y, z, qx, qy, qz, qw;
    if (!(ss >> t >> x >> y >> z >> qx >> qy >> qz >> qw))
      throw std::runtime_error(path + ":" + std::to_string(n) + ": expected t x y z qx qy qz qw");
    stamps->push_back(t);
    poses->emplace_back(x, y, std::atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz)));
  }
}

}  // namespace io
}  // namespace rbpf_slam
