#ifndef RBPF_SLAM_ROS_SIM_CONVERSIONS_H
#define RBPF_SLAM_ROS_SIM_CONVERSIONS_H

#include <string>

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Odometry.h>
#include <ros/time.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <visualization_msgs/MarkerArray.h>

#include "rbpf_slam/TrunkArray.h"
#include "rbpf_slam/sim/forest_simulator.h"
#include "rbpf_slam/core/grid/occupancy_image.h"

namespace rbpf_slam
{
/** @brief Simulated seconds to ROS time: sim time 0 is @p base (ROS treats time 0 as "unset"). */
ros::Time toRosTime(double sim_seconds, double base = 1000.0);

/** @brief Frame names used by the simulator's messages. */
struct SimFrames
{
  std::string map = "map";
  std::string odom = "odom";
  std::string base = "base_link";
  std::string truth_base = "base_link_truth";
  std::string lidar3d = "velodyne";
  std::string lidar2d = "laser";
  std::string gps = "gps";
};

/**
 * @brief A sweep as PointCloud2 with fields x, y, z, intensity (float32), ring (uint16) and time
 * (float32, seconds after header.stamp), unorganised (height 1), 24 bytes a point.
 */
sensor_msgs::PointCloud2::Ptr toPointCloud2(const sim::LidarSweep& sweep, const std::string& frame, double base);
sensor_msgs::LaserScan::Ptr toLaserScan(const sim::LaserScan2D& scan, const std::string& frame, double base);
/** @brief Wheel odometry with a covariance from the stated accuracy (sigma per metre travelled). */
nav_msgs::Odometry::Ptr toOdometry(const sim::OdometrySample& odom, const SimFrames& frames, double base);
geometry_msgs::TransformStamped toOdomTf(const sim::OdometrySample& odom, const SimFrames& frames, double base);
sensor_msgs::Imu::Ptr toImu(const sim::ImuSample& imu, const sim::ImuConfig& config, const std::string& frame,
                            double base);
/**
 * @brief Truth relative to the start pose (frame map, where a SLAM map starts), child truth_base: the full
 * 3D body pose (height, roll, pitch on the ground); the map frame sits at the start pose on the ground
 * (height @p start_ground_z in the world), level.
 */
nav_msgs::Odometry::Ptr toTruthOdometry(const sim::TruthSample& truth, const core::Pose2& start, double start_ground_z,
                                        const SimFrames& frames, double base);
/** @brief The true trunks at breast height (1.3 m above their foot) in that map frame; id = index in the world. */
rbpf_slam::TrunkArray::Ptr toTruthTrees(const sim::ForestWorld& world, const core::Pose2& start,
                                        const SimFrames& frames, double stamp, double base);
/** @brief An indoor world's occupancy image in that map frame (relative to the start pose), for rviz. */
nav_msgs::OccupancyGrid::Ptr toTruthMap(const core::OccupancyImage& image, const core::Pose2& start,
                                        const SimFrames& frames, double stamp, double base);
visualization_msgs::MarkerArray::Ptr toTreeMarkers(const rbpf_slam::TrunkArray& trees, const std::string& ns,
                                                   float r, float g, float b);
/** @brief The receiver's antenna on base_link as a mount (no rotation). */
inline sim::Mount gpsMount(const core::GnssConfig& gnss)
{
  sim::Mount m;
  m.x = gnss.antenna.x();
  m.y = gnss.antenna.y();
  m.z = gnss.antenna.z();
  return m;
}

geometry_msgs::TransformStamped toStaticTf(const sim::Mount& mount, const std::string& parent, const std::string& child,
                                           double stamp, double base);

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_SIM_CONVERSIONS_H
