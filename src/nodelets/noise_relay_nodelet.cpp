#include <memory>

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include "rbpf_slam/ros/noise_relay.h"

namespace rbpf_slam
{
/** @brief Nodelet shell around NoiseRelay. */
class NoiseRelayNodelet : public nodelet::Nodelet
{
private:
  void onInit() override { relay_.reset(new NoiseRelay(getNodeHandle(), getPrivateNodeHandle())); }

  std::unique_ptr<NoiseRelay> relay_;
};

}  // namespace rbpf_slam

PLUGINLIB_EXPORT_CLASS(rbpf_slam::NoiseRelayNodelet, nodelet::Nodelet)
