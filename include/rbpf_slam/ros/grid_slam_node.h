#ifndef RBPF_SLAM_ROS_GRID_SLAM_NODE_H
#define RBPF_SLAM_ROS_GRID_SLAM_NODE_H

#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>

#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <std_srvs/Trigger.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include "rbpf_slam/ros/drop_count.h"
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
 * - subscribes `scan` (sensor_msgs/LaserScan, REP-117); odometry comes from TF `odom -> base_link`: when `/tf`
 *   carries it as one transform (as an odometry publisher broadcasts it), those transforms as they come, into the
 *   pipeline as slam_bag gives it a bag's odometry messages (the same interpolation at each scan, whenever TF
 *   arrives); through a chain of frames, TF's pose at each scan's stamp (TfOdometry). A scan waits up to
 *   `~odom_timeout` for odometry that covers it, then is processed with the newest, as in the FastSLAM node. The
 *   scanner's mount from TF `base_link -> scan frame`.
 * - scans are taken into an inbox and processed in order on the node's own thread, so none is lost while the
 *   filter works; when the filter falls behind, it says by how much, and beyond kInboxScans the oldest are dropped
 *   with a count.
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

  /// Scans the inbox holds while the filter works on older ones (at 40 Hz, 50 s); beyond, the oldest are dropped.
  static constexpr std::size_t kInboxScans = 2000;

private:
  /** @brief A scan as it arrived: the clock and wall time of its arrival go with it to the pipeline. */
  struct InboxScan
  {
    sensor_msgs::LaserScan::ConstPtr msg;
    double clock, arrival;
  };
  /** @brief One odometry transform as /tf carried it. */
  struct OdometrySample
  {
    double stamp, clock;
    core::Pose2 pose;
  };
  void onScan(const sensor_msgs::LaserScan::ConstPtr& msg);
  void onTf(const tf2_msgs::TFMessage::ConstPtr& msg);
  /** @brief The node's thread: the inbox's scans and odometry into the pipeline, in order, until the node stops. */
  void work();
  /** @brief One scan from the inbox: the stamp rule, the mount, into the pipeline. */
  void admit(const InboxScan& scan);
  /** @brief Odometry transforms from /tf into the pipeline (samples mode). */
  void feedSamples(const std::vector<OdometrySample>& samples);
  /** @brief What the node keeps of a timeline, dropped when the pipeline restarted. */
  void onRestart(double stamp);
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
  int seen_restarts_ = 0;      ///< the pipeline's restarts the node has acted on

  // The inbox (onScan, onTf -> work()); its own lock, so that arrivals never wait for the filter.
  std::mutex inbox_mutex_;
  std::condition_variable inbox_cv_;
  std::deque<InboxScan> inbox_;
  std::vector<OdometrySample> inbox_odometry_;
  bool samples_ = false;  ///< /tf carries odom -> base_link as one transform: its samples are the odometry
  bool stop_ = false;
  std::size_t inbox_dropped_ = 0;
  std::thread worker_;
  ros::Time last_scan_stamp_;
  ros::Time last_map_stamp_;
  std::set<int> warned_verdicts_;  ///< kinds of dropped stamps said once already
  std::set<std::string> warned_reasons_;  ///< reasons for dropped scans said once already
  std::size_t updates_ = 0, skipped_ = 0;
  DropCount dropped_;  ///< scans dropped, per cause

  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  TransformGuard tf_guard_;  ///< map -> odom: this node's to publish, or another's (named)
  /** @brief Saves the maps that restarts ended beside ~map_path (FILE.restartN.yaml + .pgm) and says where. */
  void saveEndedMaps();
  ros::Subscriber scan_sub_, tf_sub_;
  ros::Publisher map_pub_, metadata_pub_, pose_pub_, particles_pub_, path_pub_;
  ros::ServiceServer save_srv_;
  nav_msgs::Path path_;
};

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_GRID_SLAM_NODE_H
