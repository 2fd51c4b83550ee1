// Where a tool finds the package's own files (config/, config/worlds/): the path ROS reports for the package,
// the source tree in a devel space and share/rbpf_slam in an install space. Used for defaults only; every such
// file can also be given on the command line.
#pragma once

#include <ros/package.h>

#include <cstdio>
#include <cstdlib>
#include <string>

namespace rbpf_slam
{
namespace tools
{
/** @brief A file of the package, e.g. "config/worlds/paper_forest.yaml"; exits (2) naming the cause when the
 *         package cannot be found (no workspace sourced). */
inline std::string packageFile(const std::string& relative)
{
  static const std::string dir = ros::package::getPath("rbpf_slam");
  if (dir.empty())
  {
    std::fprintf(stderr, "rbpf_slam: cannot find the package's files (is a workspace's setup.bash sourced?)\n");
    std::exit(2);
  }
  return dir + "/" + relative;
}

/** @brief The directory of a data set: the given one, else $RBPF_SLAM_DATA/@p name; exits (2) naming both
 *         when neither is there. */
inline std::string dataDir(const std::string& given, const std::string& name, const char* tool)
{
  if (!given.empty())
    return given;
  const char* root = std::getenv("RBPF_SLAM_DATA");
  if (root == nullptr || *root == '\0')
  {
    std::fprintf(stderr, "%s: no data: give --data DIR or set RBPF_SLAM_DATA to the folder holding %s/\n", tool,
                 name.c_str());
    std::exit(2);
  }
  return std::string(root) + "/" + name;
}
}  // namespace tools
}  // namespace rbpf_slam
