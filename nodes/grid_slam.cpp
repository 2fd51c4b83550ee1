#include "rbpf_slam/ros/nodelet_main.h"

int main(int argc, char** argv)
{
  return rbpf_slam::runNodeletAsNode(argc, argv, "grid_slam", "rbpf_slam/GridSlamNodelet");
}
