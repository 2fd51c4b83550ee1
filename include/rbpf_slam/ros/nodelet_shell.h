#ifndef RBPF_SLAM_ROS_NODELET_SHELL_H
#define RBPF_SLAM_ROS_NODELET_SHELL_H

#include <exception>
#include <memory>
#include <stdexcept>
#include <string>

#include <nodelet/nodelet.h>

namespace rbpf_slam
{
/**
 * @brief The nodelet around a ROS class @p Node (constructed from the node handles). A construction that fails
 * (an invalid parameter names its key) is logged and reported to the nodelet loader as a std::runtime_error: the
 * load fails, so a node in nodes/ exits non-zero (`required="true"` and supervisors see it) and `nodelet load`
 * into a manager fails, while the manager and its other nodelets stay up. With @p kMultiThreaded the class gets
 * the multi-threaded callback queue.
 */
template <typename Node, bool kMultiThreaded = false>
class NodeletShell : public nodelet::Nodelet
{
private:
  void onInit() override
  {
    try
    {
      node_.reset(kMultiThreaded ? new Node(getMTNodeHandle(), getMTPrivateNodeHandle()) :
                                   new Node(getNodeHandle(), getPrivateNodeHandle()));
    }
    catch (const std::exception& e)
    {
      NODELET_FATAL("%s: does not start: %s", getName().c_str(), e.what());
      throw std::runtime_error(getName() + ": " + e.what());
    }
    catch (...)
    {
      NODELET_FATAL("%s: does not start (unknown error)", getName().c_str());
      throw std::runtime_error(getName() + ": unknown error at start");
    }
  }

  std::unique_ptr<Node> node_;
};

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_NODELET_SHELL_H
