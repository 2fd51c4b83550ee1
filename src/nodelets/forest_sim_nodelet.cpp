#include <pluginlib/class_list_macros.hpp>

#include "rbpf_slam/ros/forest_sim.h"
#include "rbpf_slam/ros/nodelet_shell.h"

namespace rbpf_slam
{
/** @brief The nodelet of ForestSim (the forest simulator). */
class ForestSimNodelet : public NodeletShell<ForestSim, true>
{
};

}  // namespace rbpf_slam

PLUGINLIB_EXPORT_CLASS(rbpf_slam::ForestSimNodelet, nodelet::Nodelet)
