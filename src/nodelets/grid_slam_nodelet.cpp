#include <exception>
#include <memory>

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include "rbpf_slam/ros/grid_slam_node.h"

namespace rbpf_slam
{
/** @brief Nodelet shell around GridSlamRos. */
class GridSlamNodelet : public nodelet::Nodelet
{
private:
  void onInit() override
  {
    try
    {
      slam_.reset(new GridSlamRos(getNodeHandle(), getPrivateNodeHandle()));
    }
    catch (const std::exception& e)  // never take the manager down
    {
      NODELET_ERROR("grid SLAM could not start: %s", e.what());
    }
  }

  std::unique_ptr<GridSlamRos> slam_;
};

}  // namespace rbpf_slam

PLUGINLIB_EXPORT_CLASS(rbpf_slam::GridSlamNodelet, nodelet::Nodelet)
