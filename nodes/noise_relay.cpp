#include "rbpf_slam/ros/nodelet_main.h"

int main(int argc, char** argv)
{
  return rbpf_slam::runNodeletAsNode(argc, argv, "noise_relay", "rbpf_slam/NoiseRelayNodelet");
}
