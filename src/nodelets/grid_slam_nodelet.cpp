#include <pluginlib/class_list_macros.hpp>

#include "rbpf_slam/ros/grid_slam_node.h"
#include "rbpf_slam/ros/nodelet_shell.h"

namespace rbpf_slam
{
/** @brief The nodelet of GridSlamRos (occupancy-grid SLAM). */
class GridSlamNodelet : public NodeletShell<GridSlamRos>
{
};

}  // namespace rbpf_slam

PLUGINLIB_EXPORT_CLASS(rbpf_slam::GridSlamNodelet, nodelet::Nodelet)
