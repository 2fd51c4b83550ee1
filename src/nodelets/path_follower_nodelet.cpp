#include <memory>

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include "rbpf_slam/ros/path_follower_node.h"

namespace rbpf_slam
{
/** @brief Nodelet shell around PathFollowerNode. */
class PathFollowerNodelet : public nodelet::Nodelet
{
private:
  void onInit() override { follower_.reset(new PathFollowerNode(getNodeHandle(), getPrivateNodeHandle())); }

  std::unique_ptr<PathFollowerNode> follower_;
};

}  // namespace rbpf_slam

PLUGINLIB_EXPORT_CLASS(rbpf_slam::PathFollowerNodelet, nodelet::Nodelet)
