#include <memory>

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include "rbpf_slam/ros/forest_sim.h"

namespace rbpf_slam
{
/** @brief Nodelet shell around ForestSim. */
class ForestSimNodelet : public nodelet::Nodelet
{
private:
  void onInit() override { sim_.reset(new ForestSim(getMTNodeHandle(), getMTPrivateNodeHandle())); }

  std::unique_ptr<ForestSim> sim_;
};

}  // namespace rbpf_slam

PLUGINLIB_EXPORT_CLASS(rbpf_slam::ForestSimNodelet, nodelet::Nodelet)
