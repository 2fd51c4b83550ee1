#include <pluginlib/class_list_macros.hpp>

#include "rbpf_slam/ros/trunk_extraction.h"
#include "rbpf_slam/ros/nodelet_shell.h"

namespace rbpf_slam
{
/** @brief The nodelet of TrunkExtraction (trunk extraction from clouds and scans). */
class TrunkExtractionNodelet : public NodeletShell<TrunkExtraction>
{
};

}  // namespace rbpf_slam

PLUGINLIB_EXPORT_CLASS(rbpf_slam::TrunkExtractionNodelet, nodelet::Nodelet)
