#include "rbpf_slam/ros/sim_conversions.h"

#include <cmath>
#include <cstring>

#include <boost/make_shared.hpp>
#include <sensor_msgs/PointField.h>

namespace rbpf_slam
{
namespace
{
geometry_msgs::Quaternion yawToQuaternion(double yaw)
{
  geometry_msgs::Quaternion q;
  q.z = std::sin(0.5 * yaw);
  q.w = std::cos(0.5 * yaw);
  return q;
}

sensor_msgs::PointField field(const std::string& name, std::uint32_t offset, std::uint8_t type)
{
  sensor_msgs::PointField f;
  f.name = name;
  f.offset = offset;
  f.datatype = type;
  f.count = 1;
  return f;
}
}  // namespace

ros::Time toRosTime(double sim_seconds, double base)
{
  return ros::Time(base + sim_seconds);
}

sensor_msgs::PointCloud2::Ptr toPointCloud2(const sim::LidarSweep& sweep, const std::string& frame, double base)
{
  auto msg = boost::make_shared<sensor_msgs::PointCloud2>();
  msg->header.stamp = toRosTime(sweep.stamp, base);
  msg->header.frame_id = frame;
  msg->height = 1;
  msg->width = static_cast<std::uint32_t>(sweep.points.size());
  msg->fields = { field("x", 0, sensor_msgs::PointField::FLOAT32), field("y", 4, sensor_msgs::PointField::FLOAT32),
                  field("z", 8, sensor_msgs::PointField::FLOAT32),
                  field("intensity", 12, sensor_msgs::PointField::FLOAT32),
                  field("ring", 16, sensor_msgs::PointField::UINT16),
                  field("time", 20, sensor_msgs::PointField::FLOAT32) };
  msg->is_bigendian = false;
  msg->point_step = 24;
  msg->row_step = msg->point_step * msg->width;
  msg->is_dense = true;
  msg->data.assign(static_cast<std::size_t>(msg->row_step), 0);
  std::uint8_t* out = msg->data.data();
  for (const sim::LidarPoint& p : sweep.points)
  {
    std::memcpy(out + 0, &p.x, 4);
    std::memcpy(out + 4, &p.y, 4);
    std::memcpy(out + 8, &p.z, 4);
    std::memcpy(out + 12, &p.intensity, 4);
    std::memcpy(out + 16, &p.ring, 2);
    std::memcpy(out + 20, &p.time, 4);
    out += msg->point_step;
  }
  return msg;
}

sensor_msgs::LaserScan::Ptr toLaserScan(const sim::LaserScan2D& scan, const std::string& frame, double base)
{
  auto msg = boost::make_shared<sensor_msgs::LaserScan>();
  msg->header.stamp = toRosTime(scan.stamp, base);
  msg->header.frame_id = frame;
  msg->angle_min = static_cast<float>(scan.angle_min);
  msg->angle_increment = static_cast<float>(scan.angle_increment);
  msg->angle_max = static_cast<float>(scan.angle_min + scan.angle_increment * (scan.ranges.size() - 1));
  msg->time_increment = static_cast<float>(scan.time_increment);
  msg->scan_time = static_cast<float>(scan.scan_time);
  msg->range_min = static_cast<float>(scan.range_min);
  msg->range_max = static_cast<float>(scan.range_max);
  msg->ranges = scan.ranges;
  return msg;
}

nav_msgs::Odometry::Ptr toOdometry(const sim::OdometrySample& odom, const SimFrames& frames, double base)
{
  auto msg = boost::make_shared<nav_msgs::Odometry>();
  msg->header.stamp = toRosTime(odom.stamp, base);
  msg->header.frame_id = frames.odom;
  msg->child_frame_id = frames.base;
  msg->pose.pose.position.x = odom.pose.x;
  msg->pose.pose.position.y = odom.pose.y;
  msg->pose.pose.orientation = yawToQuaternion(odom.pose.theta);
  msg->twist.twist.linear.x = odom.linear;
  msg->twist.twist.angular.z = odom.angular;
  // Accumulated pose uncertainty is not tracked by wheel odometry; give the usual large diagonal so
  // that consumers (robot_localization, rviz) treat the pose as drifting, and z/roll/pitch as unused.
  for (int i : { 0, 7 })
    msg->pose.covariance[i] = 1.0;
  msg->pose.covariance[35] = 0.1;
  for (int i : { 14, 21, 28 })
    msg->pose.covariance[i] = 1e6;
  msg->twist.covariance[0] = 0.01;
  msg->twist.covariance[35] = 0.01;
  for (int i : { 7, 14, 21, 28 })
    msg->twist.covariance[i] = 1e6;
  return msg;
}

geometry_msgs::TransformStamped toOdomTf(const sim::OdometrySample& odom, const SimFrames& frames, double base)
{
  geometry_msgs::TransformStamped tf;
  tf.header.stamp = toRosTime(odom.stamp, base);
  tf.header.frame_id = frames.odom;
  tf.child_frame_id = frames.base;
  tf.transform.translation.x = odom.pose.x;
  tf.transform.translation.y = odom.pose.y;
  tf.transform.rotation = yawToQuaternion(odom.pose.theta);
  return tf;
}

sensor_msgs::Imu::Ptr toImu(const sim::ImuSample& imu, const sim::ImuConfig& config, const std::string& frame,
                            double base)
{
  auto msg = boost::make_shared<sensor_msgs::Imu>();
  msg->header.stamp = toRosTime(imu.stamp, base);
  msg->header.frame_id = frame;
  msg->orientation_covariance[0] = -1.0;  // no orientation estimate (REP-145)
  msg->angular_velocity.x = imu.angular_velocity.x();
  msg->angular_velocity.y = imu.angular_velocity.y();
  msg->angular_velocity.z = imu.angular_velocity.z();
  msg->linear_acceleration.x = imu.linear_acceleration.x();
  msg->linear_acceleration.y = imu.linear_acceleration.y();
  msg->linear_acceleration.z = imu.linear_acceleration.z();
  const double g2 = config.gyro_sigma * config.gyro_sigma, a2 = config.accel_sigma * config.accel_sigma;
  for (int i : { 0, 4, 8 })
  {
    msg->angular_velocity_covariance[i] = g2;
    msg->linear_acceleration_covariance[i] = a2;
  }
  return msg;
}

namespace
{
/** The map frame of the truth: at the start pose, on the ground there, level (REP-103: z up). */
Eigen::Isometry3d truthMapInWorld(const core::Pose2& start, double start_ground_z)
{
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  m.linear() = Eigen::AngleAxisd(start.theta, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  m.translation() = Eigen::Vector3d(start.x, start.y, start_ground_z);
  return m;
}
}  // namespace

nav_msgs::Odometry::Ptr toTruthOdometry(const sim::TruthSample& truth, const core::Pose2& start, double start_ground_z,
                                        const SimFrames& frames, double base)
{
  // The full 3D body pose (height, roll and pitch on the undulating ground), relative to the start.
  const Eigen::Isometry3d rel = truthMapInWorld(start, start_ground_z).inverse() * truth.body;
  const Eigen::Quaterniond q(rel.linear());
  auto msg = boost::make_shared<nav_msgs::Odometry>();
  msg->header.stamp = toRosTime(truth.stamp, base);
  msg->header.frame_id = frames.map;
  msg->child_frame_id = frames.truth_base;
  msg->pose.pose.position.x = rel.translation().x();
  msg->pose.pose.position.y = rel.translation().y();
  msg->pose.pose.position.z = rel.translation().z();
  msg->pose.pose.orientation.x = q.x();
  msg->pose.pose.orientation.y = q.y();
  msg->pose.pose.orientation.z = q.z();
  msg->pose.pose.orientation.w = q.w();
  return msg;
}

rbpf_slam::TrunkArray::Ptr toTruthTrees(const sim::ForestWorld& world, const core::Pose2& start,
                                        const SimFrames& frames, double stamp, double base)
{
  auto msg = boost::make_shared<rbpf_slam::TrunkArray>();
  msg->header.stamp = toRosTime(stamp, base);
  msg->header.frame_id = frames.map;
  const sim::Ground ground(world.ground);
  const Eigen::Isometry3d to_map = truthMapInWorld(start, ground.height(start.x, start.y)).inverse();
  for (std::size_t i = 0; i < world.trunks.size(); ++i)
  {
    const sim::TrunkSpec& t = world.trunks[i];
    rbpf_slam::Trunk trunk;
    // The trunk's centre at breast height (1.3 m above the ground at its foot), where extraction
    // measures it; the axis is (lean_x, lean_y, 1) normalised, the radius shrinks by taper per metre.
    double radius = 0.0;
    const Eigen::Vector3d c = to_map * sim::trunkAxisAt(t, ground.height(t.x, t.y), 1.3, &radius);
    trunk.center.x = c.x();
    trunk.center.y = c.y();
    trunk.center.z = c.z();
    trunk.radius = radius;
    trunk.range = std::hypot(trunk.center.x, trunk.center.y);
    trunk.bearing = std::atan2(trunk.center.y, trunk.center.x);
    trunk.score = 1.0f;
    trunk.method = rbpf_slam::Trunk::METHOD_GIVEN;
    trunk.id = static_cast<std::int32_t>(i);
    msg->trunks.push_back(trunk);
  }
  return msg;
}

nav_msgs::OccupancyGrid::Ptr toTruthMap(const core::OccupancyImage& image, const core::Pose2& start,
                                        const SimFrames& frames, double stamp, double base)
{
  auto msg = boost::make_shared<nav_msgs::OccupancyGrid>();
  msg->header.stamp = toRosTime(stamp, base);
  msg->header.frame_id = frames.map;
  msg->info.map_load_time = msg->header.stamp;
  msg->info.resolution = static_cast<float>(image.resolution());
  msg->info.width = static_cast<std::uint32_t>(image.width());
  msg->info.height = static_cast<std::uint32_t>(image.height());
  const core::MapOrigin& o = image.origin();
  const core::Pose2 origin = start.inverse() * core::Pose2(o.x, o.y, o.yaw);
  msg->info.origin.position.x = origin.x;
  msg->info.origin.position.y = origin.y;
  msg->info.origin.orientation = yawToQuaternion(origin.theta);
  msg->data = image.cells();  // the same convention: row-major, row 0 at the bottom, 100 / 0 / -1
  return msg;
}

visualization_msgs::MarkerArray::Ptr toTreeMarkers(const rbpf_slam::TrunkArray& trees, const std::string& ns,
                                                   float r, float g, float b)
{
  auto msg = boost::make_shared<visualization_msgs::MarkerArray>();
  for (const auto& t : trees.trunks)
  {
    visualization_msgs::Marker m;
    m.header = trees.header;
    m.ns = ns;
    m.id = t.id;
    m.type = visualization_msgs::Marker::CYLINDER;
    m.action = visualization_msgs::Marker::ADD;
    m.pose.position.x = t.center.x;
    m.pose.position.y = t.center.y;
    // Taller than the estimate's (2 m) and translucent: in rviz the true trunk stands out above the landmark
    // drawn at the same place.
    m.pose.position.z = 1.5;
    m.pose.orientation.w = 1.0;
    m.scale.x = m.scale.y = std::max(0.05, 2.0 * t.radius);
    m.scale.z = 3.0;
    m.color.r = r;
    m.color.g = g;
    m.color.b = b;
    m.color.a = 0.5f;
    msg->markers.push_back(m);
  }
  return msg;
}

geometry_msgs::TransformStamped toStaticTf(const sim::Mount& mount, const std::string& parent, const std::string& child,
                                           double stamp, double base)
{
  const Eigen::Isometry3d t = mount.transform();
  const Eigen::Quaterniond q(t.linear());
  geometry_msgs::TransformStamped tf;
  tf.header.stamp = toRosTime(stamp, base);
  tf.header.frame_id = parent;
  tf.child_frame_id = child;
  tf.transform.translation.x = mount.x;
  tf.transform.translation.y = mount.y;
  tf.transform.translation.z = mount.z;
  tf.transform.rotation.x = q.x();
  tf.transform.rotation.y = q.y();
  tf.transform.rotation.z = q.z();
  tf.transform.rotation.w = q.w();
  return tf;
}

}  // namespace rbpf_slam
