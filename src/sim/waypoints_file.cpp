#include "rbpf_slam/sim/waypoints_file.h"

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "rbpf_slam/sim/path_follower.h"

namespace rbpf_slam
{
namespace sim
{
std::vector<Eigen::Vector2d> readWaypoints(const std::string& path)
{
  std::ifstream in(path);
  if (!in)
    throw std::runtime_error(path + ": cannot read the waypoint file");
  std::vector<Eigen::Vector2d> waypoints;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number)
  {
    if (!line.empty() && line.back() == '\r')  // CRLF line ends
      line.pop_back();
    const std::string body = line.substr(0, line.find('#'));
    if (body.find_first_not_of(" \t") == std::string::npos)
      continue;
    std::istringstream fields(body);
    double x = 0.0, y = 0.0;
    std::string rest;
    if (!(fields >> x >> y) || (fields >> rest) || !std::isfinite(x) || !std::isfinite(y))
      throw std::runtime_error(path + ":" + std::to_string(number) + ": expected 'x y', got '" + line + "'");
    waypoints.emplace_back(x, y);
  }
  if (waypoints.empty())
    throw std::runtime_error(path + ": no waypoints");
  return waypoints;
}

std::vector<Eigen::Vector2d> namedDrive(const std::string& name, std::string* error)
{
  if (name == "straight")
    return sim::straightDrive();
  if (name == "loop")
    return sim::loopDrive();
  if (!std::ifstream(name))
  {
    if (error)
      *error = "drive '" + name + "' is neither 'straight', 'loop' nor a readable waypoint file";
    return {};
  }
  try
  {
    return readWaypoints(name);
  }
  catch (const std::runtime_error& e)
  {
    if (error)
      *error = e.what();
    return {};
  }
}

}  // namespace sim
}  // namespace rbpf_slam
