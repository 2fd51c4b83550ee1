#include <pcl/console/print.h>
#include <pluginlib/class_list_macros.hpp>

#include "rbpf_slam/ros/trunk_extraction.h"
#include "rbpf_slam/ros/nodelet_shell.h"

namespace rbpf_slam
{
/** @brief The nodelet of TrunkExtraction (trunk extraction from clouds and scans). */
class TrunkExtractionNodelet : public NodeletShell<TrunkExtraction>
{
public:
  // Built by the loader just before onInit(): PCL reports every failed RANSAC ("found no model") as an error.
  TrunkExtractionNodelet() { pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); }
};

}  // namespace rbpf_slam

PLUGINLIB_EXPORT_CLASS(rbpf_slam::TrunkExtractionNodelet, nodelet::Nodelet)
