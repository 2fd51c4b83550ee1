#ifndef RBPF_SLAM_ROS_GRID_SLAM_NODE_H
#define RBPF_SLAM_ROS_GRID_SLAM_NODE_H

#include <deque>
#include <memory>
#include <mutex>
#include <set>
#include <string>

#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include "rbpf_slam/ros/transform_guard.h"

#include "rbpf_slam/core/grid/grid_slam_pipeline.h"
#include "rbpf_slam/ros/params.h"
#include "rbpf_slam/ros/tf_odometry.h"

namespace rbpf_slam
{
/** @brief The parameters of GridSlamRos besides the filter's own (core::GridSlamConfig). */
struct GridSlamRosConfig : SlamRosConfig
{
  double map_update_interval = 2.0;   ///< [s] of scan time between publications of `map`
  std::string map_path = "~/.ros/grid_map.yaml";  ///< ~save_map writes here (and the .pgm beside it)
};

/** @brief The core's grid as a nav_msgs/OccupancyGrid (-1 unknown, 0..100), header left to the caller. */
void toMsg(const core::OccupancyGrid& grid, nav_msgs::OccupancyGrid* msg);

/**
 * @brief Grid SLAM (core::GridSlamPipeline, either method) on ROS topics, relative to @p nh:
 *
 * - subscribes `scan` (sensor_msgs/LaserScan, REP-117); odometry comes from TF `odom -> base_link` at
 *   the scan's stamp (TfOdometry into the pipeline: a scan waits up to `~odom_timeout` for it, then is processed
 *   with the newest odometry, as in the FastSLAM node), the scanner's mount from TF `base_link -> scan frame`.
 * - publishes `map` (nav_msgs/OccupancyGrid, latched, every `~map_update_interval` of scan time) and
 *   `map_metadata` (latched), TF `map -> odom` (REP-105), `pose` (PoseWithCovarianceStamped: the particles'
 *   weighted mean and covariance), `particles` (PoseArray, when subscribed), `path` (the mapping poses).
 * - service `~save_map` (std_srvs/Trigger): the map to `~map_path` in the map_server layout (YAML + PGM).
 *
 * Time going backwards (a looped bag) resets the filter, with one warning (the TF listener clears its buffer).
 */
class GridSlamRos
{
public:
  GridSlamRos(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~GridSlamRos();

private:
  void onScan(const sensor_msgs::LaserScan::ConstPtr& msg);
  void onTimer(const ros::WallTimerEvent& event);
  bool onSaveMap(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);
  /** @brief Gives the pipeline the odometry TF holds for its waiting scans, then processes what is ready. */
  void processPending();
  /** @brief The odometry at each waiting scan's stamp that TF has, in order, into the pipeline. */
  void feedOdometry();
  void publishMap(const ros::Time& stamp);
  void publishPoses(const ros::Time& stamp, const core::GridPipelineUpdate& update);
  /** @brief Planar transform parent <- child at @p stamp; false (no warning) when not available. */
  bool lookup(const std::string& parent, const std::string& child, const ros::Time& stamp, core::Pose2* pose,
              std::string* error);

  ros::NodeHandle nh_, pnh_;
  std::string name_;
  GridSlamRosConfig config_;
  core::GridSlamConfig filter_config_;
  /// The grid SLAM pipeline the bag runner runs too (stamps, odometry at each scan, filter).
  std::unique_ptr<core::GridSlamPipeline> pipeline_;
  std::mutex mutex_;

  std::unique_ptr<TfOdometry> odometry_;  ///< odom -> base_link from TF at the scans' stamps
  double fed_until_ = -1e300;  ///< [s] the stamp of the last odometry given to the pipeline
  ros::Time last_scan_stamp_;
  ros::Time last_map_stamp_;
  std::set<int> warned_verdicts_;  ///< kinds of dropped stamps said once already
  std::set<std::string> warned_reasons_;  ///< reasons for dropped scans said once already
  std::size_t updates_ = 0, skipped_ = 0, dropped_ = 0;

  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  TransformGuard tf_guard_;  ///< map -> odom: this node's to publish, or another's (named)
  /** @brief Saves the maps that restarts ended beside ~map_path (FILE.restartN.yaml + .pgm) and says where. */
  void saveEndedMaps();
  ros::Subscriber scan_sub_;
  ros::Publisher map_pub_, metadata_pub_, pose_pub_, particles_pub_, path_pub_;
  ros::ServiceServer save_srv_;
  ros::WallTimer timer_;
  nav_msgs::Path path_;
};

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_GRID_SLAM_NODE_H
