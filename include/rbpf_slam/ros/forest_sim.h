#ifndef RBPF_SLAM_ROS_FOREST_SIM_H
#define RBPF_SLAM_ROS_FOREST_SIM_H

#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <geometry_msgs/Twist.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include "rbpf_slam/sim/forest_simulator.h"
#include "rbpf_slam/ros/any_stamped.h"
#include "rbpf_slam/ros/sim_conversions.h"

namespace rbpf_slam
{
/**
 * @brief The forest simulator in a ROS graph. Runs the core simulator in its own thread, in real
 * time (scaled by `~real_time_factor`), as fast as possible (0), or in lockstep with its consumers
 * (`~lockstep`): after each odometry message it waits for the command that answers it, and after
 * each sweep or scan for a message stamped at or after it on every `~lockstep_topics` topic. It
 * publishes /clock, so the graph runs on simulated time (use_sim_time).
 */
class ForestSim
{
public:
  ForestSim(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~ForestSim();

private:
  void run();
  void publish(const sim::SimulatorOutput& out);
  void waitLockstep(double sensor_stamp);
  void onCommand(const geometry_msgs::Twist::ConstPtr& msg);
  void onAck(const boost::shared_ptr<const AnyStamped>& msg, std::size_t index);

  ros::NodeHandle nh_, pnh_;
  std::unique_ptr<sim::ForestSimulator> sim_;
  SimFrames frames_;
  double start_ground_z_ = 0.0;  ///< ground height under the start pose (origin of the truth map frame)
  double time_base_ = 1000.0;
  double real_time_factor_ = 1.0;
  double duration_ = 0.0;
  bool lockstep_ = false;
  double lockstep_timeout_ = 5.0;
  bool publish_clock_ = true;

  ros::Publisher clock_pub_, cloud_pub_, scan_pub_, odom_pub_, imu_pub_, truth_pub_, truth_path_pub_, trees_pub_,
      tree_markers_pub_, truth_map_pub_, done_pub_, gps_pub_, gps_truth_pub_;
  ros::Subscriber cmd_sub_;
  std::vector<ros::Subscriber> ack_subs_;
  tf2_ros::TransformBroadcaster tf_;
  tf2_ros::StaticTransformBroadcaster static_tf_;
  nav_msgs::Path truth_path_;

  std::mutex mutex_;
  std::condition_variable cv_;
  sim::VelocityCommand command_;
  std::uint64_t commands_received_ = 0;
  std::uint64_t odometry_published_ = 0;
  std::vector<ros::Time> ack_stamps_;
  std::atomic<bool> running_{ false };
  std::thread thread_;
};

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_FOREST_SIM_H
