#ifndef RBPF_SLAM_ROS_FASTSLAM_NODE_H
#define RBPF_SLAM_ROS_FASTSLAM_NODE_H

#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <sensor_msgs/NavSatFix.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/MarkerArray.h>

#include "rbpf_slam/ros/drop_count.h"
#include "rbpf_slam/Trunk.h"
#include "rbpf_slam/TrunkArray.h"
#include "rbpf_slam/core/trunk_slam/trunk_slam_pipeline.h"
#include "rbpf_slam/io/forest_map_file.h"
#include "rbpf_slam/io/map_session.h"
#include "rbpf_slam/io/run_output.h"
#include "rbpf_slam/ros/params.h"
#include "rbpf_slam/ros/transform_guard.h"
#include "rbpf_slam/ros/trunk_conversions.h"

namespace rbpf_slam
{
/** @brief The parameters of FastSlamRos besides the filter's own (core::FastSlamConfig). */
struct FastSlamRosConfig : SlamRosConfig
{
  std::string inventory_path = "~/.ros/tree_inventory.csv";
  /// Folder of the run's files (io::FastSlamRunRecord, as slam_bag --out writes them), written on ~save_run and at
  /// shutdown; "" = none.
  std::string run_folder;
  /// Tree map file (io/forest_map_file.h) to start from; "" = a new map whose frame is the odometry frame at the
  /// first update.
  std::string map_file;
  /// With map_file: search the saved map for the start pose from the trunks seen (true), or start at initial_*.
  bool relocalize = true;
  /// [m, m, rad] base_link in the saved map's frame at the first update (with map_file and relocalize false).
  double initial_x = 0.0, initial_y = 0.0, initial_yaw = 0.0;
  /// Where ~save_map writes the tree map (~ = $HOME).
  std::string map_path = "~/.ros/forest_map.csv";
};

/**
 * @brief FastSLAM over tree trunks (core::FastSlam) on ROS topics, relative to @p nh:
 *
 * - subscribes `odom` (nav_msgs/Odometry, buffered by stamp) and `trunks` (rbpf_slam/TrunkArray in the
 *   sensor frame, e.g. from TrunkExtraction) and feeds them to core::TrunkSlamPipeline, the pipeline the bag
 *   runner runs too: an array is processed once odometry covers its sweep (or after `~odom_timeout` with a
 *   warning): prediction by the odometry increment since the previous array (interpolated at the sweep's
 *   middle), then the update with the trunks as range-bearing observations of the sensor, whose pose on
 *   `~base_frame` comes from TF.
 * - publishes TF `map -> odom` (REP-105), `pose` (PoseWithCovarianceStamped: the weighted mean and its
 *   covariance), `particles` (PoseArray), `path` (the best particle's poses), `landmark_array`
 *   (TrunkArray in the map frame, id = landmark id, method METHOD_GIVEN) and `landmarks` (MarkerArray,
 *   only when subscribed); for rviz also `odom_path` (the raw odometry in the map frame, anchored where the
 *   map starts) and `scope` (Marker: the visibility scope's rings on the ground around the sensor, only when subscribed).
 * - service `~save_inventory` (std_srvs/Trigger): the best particle's trees to `~inventory_path` (CSV);
 *   `~save_map` the same tree map file, with the anchor of a map it started from, to `~map_path` (beside it its
 *   GeoJSON when anchored, and the change report FILE_changes.csv since the saved map); `change_markers`
 *   (MarkerArray, only when subscribed): felled (red) and new (blue) trees since the saved map.
 * - with `~map_file` it starts from a saved tree map, the robot at `~initial_x`, `~initial_y`, `~initial_yaw`
 *   in that map's frame (which becomes the map frame).
 *
 * Each TrunkArray updates the filter at its sweep's middle: core::sweepObservations() carries every trunk
 * from its own instant in the sweep (sweep_period, sweep_start_angle, sweep_span) and corrects the lever arm of
 * the removed tilt (tilt_roll, tilt_pitch, the sensor's height on base_link from TF).
 */
class FastSlamRos
{
public:
  FastSlamRos(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~FastSlamRos();

private:
  void onOdometry(const nav_msgs::Odometry::ConstPtr& msg);
  void onTrunks(const rbpf_slam::TrunkArray::ConstPtr& msg);
  void onTimer(const ros::WallTimerEvent& event);
  /** @brief A satellite fix (gps/fix): to the pipeline with the antenna's position on base_link from TF. */
  void onFix(const sensor_msgs::NavSatFix::ConstPtr& msg);
  bool onSaveRun(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);
  /**
   * @brief save_map and save_inventory: the tree map to the path of the parameter @p key (read again: it may have
   * changed since the start; @p fallback otherwise); save_map (@p with_report) also writes its GeoJSON and the change
   * report beside it.
   */
  bool onSave(const std::string& key, const std::string& fallback, bool with_report, std_srvs::Trigger::Response& res);
  /** @brief Writes the run folder (~run_folder) atomically; false with @p message saying why. Lock held.
   * @p smoothed: the run smoothed already (else smoothed here, under the lock). */
  bool writeRunFolder(std::string* message, const core::SmoothedRun* smoothed = nullptr);
  /** @brief The run smoothed as it stands, solved without holding the lock (copies taken under it), so that no
   * message waits for a save; @p same_timeline: false when the filter restarted meanwhile. Lock not held. */
  core::SmoothedRun smoothBesideFilter(bool* same_timeline);

  /** @brief Runs the pipeline on what odometry covers (or what waited ~odom_timeout) and publishes. Lock held. */
  void processPending();
  /** @brief A TrunkArray as the pipeline's sweep (the sensor's mount from TF); false (warned) without TF. */
  bool toSweep(const rbpf_slam::TrunkArray& msg, core::TrunkSweep* sweep);
  /** @brief sensor -> base_link (planar) from TF, cached per frame; false when unavailable. */
  bool sensorPose(const std::string& frame, core::Pose2* pose);
  /** @brief The estimate @p estimate (map frame, its @p covariance) and odometry @p odom_pose at @p stamp: TF,
   * pose, path, map. */
  void publish(const ros::Time& stamp, const core::Pose2& odom_pose, const core::Pose2& estimate,
               const Eigen::Matrix3d& covariance);
  /** @brief The visibility scope (min and max range, field of view) as a marker on base_frame (when subscribed). */
  void publishScope(const ros::Time& stamp);
  /** @brief The map's files as the session names them (@p with_report: the GeoJSON and the changes beside it; else
   * the tree table alone, the inventory) at @p path. */
  bool writeMap(const std::string& path, bool with_report, std::string* message,
                const core::SmoothedRun* smoothed = nullptr);
  /** @brief Says what the pipeline's stamp rule made of a message: drops (the first of each kind, then throttled)
   * and restarts. Lock held. */
  void report(core::StampVerdict verdict, const char* stream, const ros::Time& stamp);

  ros::NodeHandle nh_, pnh_;
  std::string name_;
  FastSlamRosConfig config_;
  std::mutex mutex_;
  /// The FastSLAM pipeline the bag runner runs too (core::TrunkSlamPipeline): stamps, odometry, filter.
  std::unique_ptr<core::TrunkSlamPipeline> pipeline_;
  int published_timeline_ = 0;
  DropCount dropped_;  ///< messages dropped, per cause
  std::set<int> warned_verdicts_;  ///< kinds of dropped stamps said once already
  std::string sensor_frame_;
  core::Pose2 sensor_pose_;
  double sensor_height_ = 0.0;  ///< [m] of the sensor above base_link (lever arm of a tilted body)
  bool have_sensor_pose_ = false;
  std::size_t updates_ = 0;
  std::size_t sweeps_ = 0;  ///< trunk arrays the pipeline took

  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;

  ros::Subscriber odom_sub_, trunks_sub_, gps_sub_;
  std::string gps_frame_;           ///< frame of the last fix whose antenna position is cached
  Eigen::Vector2d gps_antenna_ = Eigen::Vector2d::Zero();  ///< [m] on base_link
  ros::Publisher pose_pub_, particles_pub_, landmarks_pub_, landmark_array_pub_, path_pub_, odom_path_pub_, scope_pub_;
  ros::Publisher diagnostics_pub_;  ///< /diagnostics: the filter's health (diagnostic_msgs, for rqt_robot_monitor)
  double last_diagnostics_ = -1.0;  ///< [s] stamp of the last diagnostics message
  core::HealthLevel last_level_ = core::HealthLevel::kOk;
  /** @brief Publishes the filter's health at 1 Hz of data time and at every change of level; warns on a change. */
  void publishHealth(const core::PipelineUpdate& u);
  /** @brief A loop found at @p u: logged, and shown on ~loop_markers. */
  void publishLoop(const core::PipelineUpdate& u);
  ros::ServiceServer save_srv_, save_run_srv_, save_map_srv_;
  /// The run's tree map: the saved map it started from, the current map and its files (as slam_bag's).
  std::unique_ptr<io::FastSlamMapSession> session_;
  ros::Publisher change_markers_pub_;
  /// ~loop_markers (latched): every loop found, a line from each recent tree to the old one (green closed, red refused)
  ros::Publisher loops_pub_;
  visualization_msgs::MarkerArray loop_markers_;
  io::FastSlamRunRecord record_;  ///< the run folder's content (its tables only with ~run_folder set at start)
  TransformGuard tf_guard_;       ///< map -> odom: this node's to publish, or another's (named)
  int gnss_rejected_said_ = 0;    ///< fixes refused by the innovation gate, said so far
  int gnss_outliers_said_ = 0;    ///< fixes left out of the anchor as far from the others, said so far
  /** @brief Saves the maps that restarts ended beside ~map_path (FILE.restartN.csv) and says where. */
  void saveEndedMaps();
  ros::WallTimer timer_;
  nav_msgs::Path path_;
  nav_msgs::Path odom_path_;  ///< raw odometry; the map frame starts at the odometry pose, so no transform
};

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_FASTSLAM_NODE_H
