#include "rbpf_slam/ros/nodelet_main.h"

int main(int argc, char** argv)
{
  return rbpf_slam::runNodeletAsNode(argc, argv, "path_follower", "rbpf_slam/PathFollowerNodelet");
}
