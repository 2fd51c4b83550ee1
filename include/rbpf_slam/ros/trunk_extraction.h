#ifndef RBPF_SLAM_ROS_TRUNK_EXTRACTION_H
#define RBPF_SLAM_ROS_TRUNK_EXTRACTION_H

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <boost/thread/recursive_mutex.hpp>
#include <dynamic_reconfigure/server.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/Header.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include "rbpf_slam/ros/drop_count.h"
#include "rbpf_slam/TrunkArray.h"
#include "rbpf_slam/TrunkExtractionConfig.h"
#include "rbpf_slam/core/extraction/trunk_detector.h"
#include "rbpf_slam/core/trunk_slam/trunk_slam_pipeline.h"

namespace rbpf_slam
{
/**
 * @brief Tree-trunk extraction from a 3D lidar (`points`, sensor_msgs/PointCloud2 with float32 fields
 * x, y, z) or a 2D scanner (`scan`, sensor_msgs/LaserScan), both relative to @p nh; whichever has a
 * publisher is used (both may be). Publishes per input message:
 *
 * - `trunks` (rbpf_slam/TrunkArray) always, with the input's header, also when the input was empty or
 *   malformed (then with no trunks), so consumers that step in lockstep with the sensor still advance.
 *   The trunks are in the input's frame, levelled (z up) when `~level_frame` is set or when
 *   `~level_by_trunks` estimates the tilt (3D only).
 * - `trunk_markers` (visualization_msgs/MarkerArray) and `~stats` (std_msgs/String, "key=value ...")
 *   only while someone subscribes to them.
 * - `~input_address` (std_msgs/UInt64): the address of each received cloud, only with
 *   `~debug_report_address` (a test of zero-copy transport inside one nodelet manager).
 *
 * Parameters: every field of core::TrunkDetectorConfig under its own name (`method` as "centroid" or
 * "circle"), `seed`, `level_frame`, `tf_timeout`, `debug_report_address`. The thresholds of
 * cfg/TrunkExtraction.cfg can be changed at run time with dynamic_reconfigure; an invalid set is
 * refused with an error naming the key and the previous configuration stays in force.
 *
 * 2D scans go to the core as a core::PlanarScan (REP-117 ranges): the core projects them itself, so
 * laser_geometry is not needed (and there is no `~use_laser_geometry`).
 */
class TrunkExtraction
{
public:
  /** @brief Reads `~` parameters from @p pnh; invalid ones are reported and their defaults used. */
  TrunkExtraction(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~TrunkExtraction();

private:
  void onCloud(const sensor_msgs::PointCloud2::ConstPtr& msg);
  void onScan(const sensor_msgs::LaserScan::ConstPtr& msg);
  void onReconfigure(rbpf_slam::TrunkExtractionConfig& dyn, std::uint32_t level);
  /** @brief Rotation from @p frame to a level frame with the sensor's heading; identity if unavailable. */
  Eigen::Matrix3d levelRotation(const std::string& frame, const ros::Time& stamp);
  /** @brief While the sensor height is unknown (0), the z of @p frame on ~base_frame from TF, as the bag runner
   * takes it (core::withMountHeight). Detector lock held. */
  void takeSensorHeightFromTf(const std::string& frame);
  bool anyOutputSubscribed() const;
  /** @brief Reports a dropped input on ~stats (no TrunkArray is published for it). */
  void publishDropped(const std_msgs::Header& header, const char* input, const std::string& why);
  /** @brief Says why the reach fell short of max_range (reachShortfall): when it first does, then every minute. */
  void warnShortReach(const std::string& why);
  void publish(const std_msgs::Header& header, const std::vector<core::TrunkObservation>& trunks,
               const core::TrunkDetectorStats& stats, double band_height, const char* input, double sweep_period,
               const core::SensorScope& scope, const core::SweepGeometry* geometry = nullptr);

  ros::NodeHandle nh_, pnh_;
  std::string name_;  ///< for log messages: the private namespace
  std::string level_frame_;
  std::string base_frame_ = "base_link";
  std::string sensor_height_frame_;  ///< the frame whose mount was looked up for the sensor height
  double tf_timeout_ = 0.05;
  bool debug_report_address_ = false;

  /** @brief Guards detector_ (and its configuration): the input callbacks and reconfiguration take it. */
  std::mutex detector_mutex_;
  std::unique_ptr<core::TrunkDetector> detector_;

  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<rbpf_slam::TrunkExtractionConfig>> reconfigure_;

  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;

  ros::Subscriber cloud_sub_, scan_sub_;
  ros::Publisher trunks_pub_, markers_pub_, stats_pub_, address_pub_;
  std::uint64_t markers_published_ = 0;
  std::uint64_t inputs_ = 0;
  DropCount dropped_;  ///< inputs that could not be read (no TrunkArray published for them), per cause
  bool reach_warned_ = false;  ///< the reach fell short of max_range and that was said
};

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_TRUNK_EXTRACTION_H
