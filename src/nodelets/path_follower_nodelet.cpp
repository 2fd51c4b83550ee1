#include <pluginlib/class_list_macros.hpp>

#include "rbpf_slam/ros/path_follower_node.h"
#include "rbpf_slam/ros/nodelet_shell.h"

namespace rbpf_slam
{
/** @brief The nodelet of PathFollowerNode (the path follower). */
class PathFollowerNodelet : public NodeletShell<PathFollowerNode>
{
};

}  // namespace rbpf_slam

PLUGINLIB_EXPORT_CLASS(rbpf_slam::PathFollowerNodelet, nodelet::Nodelet)
