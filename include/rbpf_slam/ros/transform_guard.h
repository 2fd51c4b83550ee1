#ifndef RBPF_SLAM_ROS_TRANSFORM_GUARD_H
#define RBPF_SLAM_ROS_TRANSFORM_GUARD_H

#include <map>
#include <mutex>
#include <string>
#include <utility>

#include <ros/ros.h>
#include <tf2_msgs/TFMessage.h>

namespace rbpf_slam
{
/**
 * @brief One publisher per transform: a SLAM node publishes map -> odom only when no other node does, and names the
 * other one when there is.
 * - In one process (nodelets in one manager, where every publisher carries the manager's name) the first nodelet to
 *   claim parent -> child owns it; a second one is told the owner's name and does not publish it.
 * - Across processes it listens on /tf and names every other node that publishes the same transform.
 */
class TransformGuard
{
public:
  /**
   * @brief Claims @p parent -> @p child for @p owner (a nodelet's name) in this process; "" when it is now
   * @p owner's, else the name of the nodelet that holds it.
   */
  static std::string claim(const std::string& parent, const std::string& child, const std::string& owner)
  {
    std::lock_guard<std::mutex> lock(mutex());
    const auto inserted = owners().emplace(key(parent, child), owner);
    return inserted.second || inserted.first->second == owner ? std::string() : inserted.first->second;
  }
  /** @brief Gives the transform back (a nodelet unloaded). */
  static void release(const std::string& parent, const std::string& child, const std::string& owner)
  {
    std::lock_guard<std::mutex> lock(mutex());
    const auto it = owners().find(key(parent, child));
    if (it != owners().end() && it->second == owner)
      owners().erase(it);
  }

  TransformGuard() = default;
  TransformGuard(const TransformGuard&) = delete;
  TransformGuard& operator=(const TransformGuard&) = delete;
  ~TransformGuard()
  {
    if (owned_)
      release(parent_, child_, owner_);
  }

  /**
   * @brief Claims @p parent -> @p child for the node @p owner and watches /tf for other publishers of it. Returns
   * whether this node may publish it; when not, the error names the owner.
   */
  bool start(ros::NodeHandle nh, const std::string& parent, const std::string& child, const std::string& owner)
  {
    parent_ = strip(parent);
    child_ = strip(child);
    owner_ = owner;
    const std::string other = claim(parent_, child_, owner_);
    owned_ = other.empty();
    if (!owned_)
      ROS_ERROR("%s: %s -> %s is already published by %s in this process; this node does not publish it (two "
                "publishers give the robot two poses: set publish_tf false or another map_frame on one of them)",
                owner_.c_str(), parent_.c_str(), child_.c_str(), other.c_str());
    sub_ = nh.subscribe("/tf", 100, &TransformGuard::onTf, this);
    return owned_;
  }
  bool owned() const { return owned_; }

private:
  static std::string strip(const std::string& frame) { return !frame.empty() && frame[0] == '/' ? frame.substr(1) : frame; }
  static std::string key(const std::string& parent, const std::string& child) { return parent + "\n" + child; }
  static std::mutex& mutex()
  {
    static std::mutex m;
    return m;
  }
  static std::map<std::string, std::string>& owners()
  {
    static std::map<std::string, std::string> m;
    return m;
  }

  void onTf(const ros::MessageEvent<tf2_msgs::TFMessage const>& event)
  {
    const std::string& publisher = event.getPublisherName();
    if (publisher == ros::this_node::getName())
      return;  // this process: the claims above
    for (const auto& t : event.getMessage()->transforms)
      if (strip(t.header.frame_id) == parent_ && strip(t.child_frame_id) == child_)
      {
        ROS_ERROR_THROTTLE(10.0, "%s: %s -> %s is also published by %s: two publishers give the robot two poses "
                           "(set publish_tf false on one of them)", owner_.c_str(), parent_.c_str(), child_.c_str(),
                           publisher.c_str());
        return;
      }
  }

  std::string parent_, child_, owner_;
  bool owned_ = false;
  ros::Subscriber sub_;
};

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_TRANSFORM_GUARD_H
