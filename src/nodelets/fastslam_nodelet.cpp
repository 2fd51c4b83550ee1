#include <pluginlib/class_list_macros.hpp>

#include "rbpf_slam/ros/fastslam_node.h"
#include "rbpf_slam/ros/nodelet_shell.h"

namespace rbpf_slam
{
/** @brief The nodelet of FastSlamRos (FastSLAM over trunk observations). */
class FastSlamNodelet : public NodeletShell<FastSlamRos>
{
};

}  // namespace rbpf_slam

PLUGINLIB_EXPORT_CLASS(rbpf_slam::FastSlamNodelet, nodelet::Nodelet)
