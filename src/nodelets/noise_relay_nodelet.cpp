#include <pluginlib/class_list_macros.hpp>

#include "rbpf_slam/ros/noise_relay.h"
#include "rbpf_slam/ros/nodelet_shell.h"

namespace rbpf_slam
{
/** @brief The nodelet of NoiseRelay (Gaussian noise on velocity commands). */
class NoiseRelayNodelet : public NodeletShell<NoiseRelay>
{
};

}  // namespace rbpf_slam

PLUGINLIB_EXPORT_CLASS(rbpf_slam::NoiseRelayNodelet, nodelet::Nodelet)
