#ifndef RBPF_SLAM_ROS_NODELET_MAIN_H
#define RBPF_SLAM_ROS_NODELET_MAIN_H

#include <string>

#include <nodelet/loader.h>
#include <ros/ros.h>

namespace rbpf_slam
{
/**
 * @brief Body of every node in nodes/: loads nodelet @p type in this process and spins, so a node
 * and a nodelet run exactly the same code.
 */
inline int runNodeletAsNode(int argc, char** argv, const std::string& default_name, const std::string& type)
{
  ros::init(argc, argv, default_name);
  nodelet::Loader loader;
  const nodelet::M_string remappings(ros::names::getRemappings());
  const nodelet::V_string nodelet_argv(argv + 1, argv + argc);
  if (!loader.load(ros::this_node::getName(), type, remappings, nodelet_argv))
  {
    ROS_FATAL("could not load nodelet %s", type.c_str());
    return 1;
  }
  ros::spin();
  return 0;
}

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_NODELET_MAIN_H
