#include <exception>
#include <memory>

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include "rbpf_slam/ros/fastslam_node.h"

namespace rbpf_slam
{
/** @brief Nodelet shell around FastSlamRos. */
class FastSlamNodelet : public nodelet::Nodelet
{
private:
  void onInit() override
  {
    try
    {
      slam_.reset(new FastSlamRos(getNodeHandle(), getPrivateNodeHandle()));
    }
    catch (const std::exception& e)  // never take the manager down
    {
      NODELET_ERROR("FastSLAM could not start: %s", e.what());
    }
  }

  std::unique_ptr<FastSlamRos> slam_;
};

}  // namespace rbpf_slam

PLUGINLIB_EXPORT_CLASS(rbpf_slam::FastSlamNodelet, nodelet::Nodelet)
