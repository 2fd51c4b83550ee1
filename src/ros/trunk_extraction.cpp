#include "rbpf_slam/ros/trunk_extraction.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <sstream>

#include <boost/make_shared.hpp>
#include <std_msgs/String.h>
#include <std_msgs/UInt64.h>
#include <tf2/exceptions.h>
#include <visualization_msgs/MarkerArray.h>

#include "rbpf_slam/io/trunk_detector_config.h"
#include "rbpf_slam/ros/cloud_conversions.h"
#include "rbpf_slam/ros/params.h"
#include "rbpf_slam/ros/ros_param_source.h"
#include "rbpf_slam/ros/scan_conversions.h"
#include "rbpf_slam/ros/trunk_conversions.h"

namespace rbpf_slam
{
namespace
{
/** @brief The detector's configuration (io::readTrunkDetectorConfig); the defaults, and an error naming the key,
 * if invalid. */
/** @brief The run-time tunable subset (cfg/TrunkExtraction.cfg) of @p c. */
rbpf_slam::TrunkExtractionConfig toDynamic(const core::TrunkDetectorConfig& c)
{
  rbpf_slam::TrunkExtractionConfig d = rbpf_slam::TrunkExtractionConfig::__getDefault__();
  d.method = core::trunkMethodName(c.method);
  d.min_height = c.min_height;
  d.max_height = c.max_height;
  d.cluster_tolerance = c.cluster_tolerance;
  d.min_points = c.min_points;
  d.min_radius = c.min_radius;
  d.max_radius = c.max_radius;
  d.ransac_threshold = c.ransac_threshold;
  d.min_inlier_ratio = c.min_inlier_ratio;
  d.min_vertical_extent = c.min_vertical_extent;
  d.max_range = c.max_range;
  d.level_by_trunks = c.level_by_trunks;
  d.voxel_size = c.voxel_size;
  d.scan_min_beams = c.scan_min_beams;
  d.scan_min_jump = c.scan_min_jump;
  d.detection_probability = c.detection_probability;
  return d;
}

/** @brief Sets the tunable fields of @p c from @p d; empty string when @p c is then valid, else the error. */
std::string fromDynamic(const rbpf_slam::TrunkExtractionConfig& d, core::TrunkDetectorConfig* c)
{
  if (!core::parseTrunkMethod(d.method, &c->method))
    return "method must be centroid or circle, not \"" + d.method + "\"";
  c->min_height = d.min_height;
  c->max_height = d.max_height;
  c->cluster_tolerance = d.cluster_tolerance;
  c->min_points = d.min_points;
  c->min_radius = d.min_radius;
  c->max_radius = d.max_radius;
  c->ransac_threshold = d.ransac_threshold;
  c->min_inlier_ratio = d.min_inlier_ratio;
  c->min_vertical_extent = d.min_vertical_extent;
  c->max_range = d.max_range;
  c->level_by_trunks = d.level_by_trunks;
  c->voxel_size = d.voxel_size;
  c->scan_min_beams = d.scan_min_beams;
  c->scan_min_jump = d.scan_min_jump;
  c->detection_probability = d.detection_probability;
  return c->validate();
}

}  // namespace

TrunkExtraction::TrunkExtraction(ros::NodeHandle nh, ros::NodeHandle pnh)
  : nh_(nh), pnh_(pnh), name_(pnh.getNamespace())
{
  const RosParamSource params(pnh_);
  core::TrunkDetectorConfig config = readCoreConfig<core::TrunkDetectorConfig>(params, &io::readTrunkDetectorConfig);
  readKey(params, "level_frame", &level_frame_);
  readKey(params, "base_frame", &base_frame_);
  readKey(params, "tf_timeout", &tf_timeout_);
  readKey(params, "debug_report_address", &debug_report_address_);
  requireNonNegative(pnh_, "tf_timeout", tf_timeout_);
  warnUnknownKeys(params);
  detector_.reset(new core::TrunkDetector(config));
  // TF: levelling (~level_frame) and, while ~sensor_height is 0 (unknown), the sensor's height on ~base_frame.
  tf_buffer_.reset(new tf2_ros::Buffer());
  tf_listener_.reset(new tf2_ros::TransformListener(*tf_buffer_));

  // The server loads (and clamps) the parameters itself; give it exactly the configuration read above,
  // so the YAML values win over the .cfg defaults, before the callback is attached.
  reconfigure_.reset(new dynamic_reconfigure::Server<rbpf_slam::TrunkExtractionConfig>(reconfigure_mutex_, pnh_));
  reconfigure_->updateConfig(toDynamic(config));
  reconfigure_->setCallback(boost::bind(&TrunkExtraction::onReconfigure, this, boost::placeholders::_1,
                                        boost::placeholders::_2));

  trunks_pub_ = nh_.advertise<rbpf_slam::TrunkArray>("trunks", 10);
  markers_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("trunk_markers", 2);
  stats_pub_ = pnh_.advertise<std_msgs::String>("stats", 10);
  if (debug_report_address_)
    address_pub_ = pnh_.advertise<std_msgs::UInt64>("input_address", 10);
  cloud_sub_ = nh_.subscribe("points", 5, &TrunkExtraction::onCloud, this);
  scan_sub_ = nh_.subscribe("scan", 10, &TrunkExtraction::onScan, this);

  ROS_INFO("%s: trunks from %s and %s -> %s; method %s, band %.2f..%.2f m, radius %.2f..%.2f m, range <= %.1f m, "
           "levelled by %s%s",
           name_.c_str(), cloud_sub_.getTopic().c_str(), scan_sub_.getTopic().c_str(), trunks_pub_.getTopic().c_str(),
           core::trunkMethodName(config.method), config.min_height, config.max_height, config.min_radius,
           config.max_radius, config.max_range, level_frame_.empty() ? "nothing (no ~level_frame)" : level_frame_.c_str(),
           config.level_by_trunks ? " and the trunks' verticality" : "");
}

TrunkExtraction::~TrunkExtraction() = default;

void TrunkExtraction::onReconfigure(rbpf_slam::TrunkExtractionConfig& dyn, std::uint32_t /*level*/)
{
  std::lock_guard<std::mutex> lock(detector_mutex_);
  core::TrunkDetectorConfig config = detector_->config();
  const std::string error = fromDynamic(dyn, &config);
  if (!error.empty())
  {
    ROS_ERROR("%s: dynamic_reconfigure: invalid parameter: %s; keeping the previous configuration", name_.c_str(),
              error.c_str());
    dyn = toDynamic(detector_->config());  // the server then shows what is in force
    return;
  }
  detector_->setConfig(config);
  ROS_DEBUG("%s: reconfigured: method %s, band %.2f..%.2f m", name_.c_str(), core::trunkMethodName(config.method),
            config.min_height, config.max_height);
}

bool TrunkExtraction::anyOutputSubscribed() const
{
  return trunks_pub_.getNumSubscribers() > 0 || markers_pub_.getNumSubscribers() > 0 ||
         stats_pub_.getNumSubscribers() > 0;
}

void TrunkExtraction::takeSensorHeightFromTf(const std::string& frame)
{
  if (detector_->config().sensor_height > 0.0 || base_frame_.empty() || frame == sensor_height_frame_)
    return;
  geometry_msgs::TransformStamped t;
  try
  {
    t = tf_buffer_->lookupTransform(base_frame_, frame, ros::Time(0));
  }
  catch (const tf2::TransformException& e)
  {
    ROS_DEBUG_THROTTLE(5.0, "%s: no transform %s -> %s yet (%s); sensor height unknown", name_.c_str(), frame.c_str(),
                       base_frame_.c_str(), e.what());
    return;
  }
  sensor_height_frame_ = frame;  // asked once per frame: a mount below base_link leaves the height unknown
  const core::TrunkDetectorConfig config = core::withMountHeight(detector_->config(), t.transform.translation.z);
  if (config.sensor_height == detector_->config().sensor_height)
    return;
  detector_->setConfig(config);
  ROS_INFO("%s: sensor height %.2f m (%s on %s from TF; ~sensor_height 0 = unknown)", name_.c_str(),
           config.sensor_height, frame.c_str(), base_frame_.c_str());
}

Eigen::Matrix3d TrunkExtraction::levelRotation(const std::string& frame, const ros::Time& stamp)
{
  if (level_frame_.empty())
    return Eigen::Matrix3d::Identity();
  geometry_msgs::TransformStamped t;
  try
  {
    t = tf_buffer_->lookupTransform(level_frame_, frame, stamp, ros::Duration(tf_timeout_));
  }
  catch (const tf2::TransformException& e)
  {
    ROS_WARN_THROTTLE(5.0, "%s: no transform %s -> %s at %.3f (%s); not levelling", name_.c_str(), frame.c_str(),
                      level_frame_.c_str(), stamp.toSec(), e.what());
    return Eigen::Matrix3d::Identity();
  }
  const auto& q = t.transform.rotation;
  Eigen::Quaterniond rotation(q.w, q.x, q.y, q.z);
  if (!rotation.coeffs().allFinite() || !(rotation.norm() > 0.5))
  {
    ROS_WARN_THROTTLE(5.0, "%s: transform %s -> %s has an invalid rotation; not levelling", name_.c_str(),
                      frame.c_str(), level_frame_.c_str());
    return Eigen::Matrix3d::Identity();
  }
  // Sensor -> level_frame, without the heading between them: turned back about z so that the sensor's x axis
  // keeps its direction. The trunks then stay in the sensor frame (the TrunkArray's header), only levelled.
  const Eigen::Matrix3d r = rotation.normalized().toRotationMatrix();
  const double yaw = std::atan2(r(1, 0), r(0, 0));
  return Eigen::AngleAxisd(-yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * r;
}

void TrunkExtraction::onCloud(const sensor_msgs::PointCloud2::ConstPtr& msg)
{
  if (debug_report_address_)
  {
    std_msgs::UInt64::Ptr address = boost::make_shared<std_msgs::UInt64>();
    address->data = static_cast<std::uint64_t>(reinterpret_cast<std::uintptr_t>(msg.get()));
    address_pub_.publish(std_msgs::UInt64::ConstPtr(address));
  }
  ++inputs_;
  if (!anyOutputSubscribed())
    return;

  CloudPoints cloud;
  const std::string why = readCloud(*msg, &cloud);
  if (!why.empty())
  {
    // Dropped: no TrunkArray, so that no consumer takes an unreadable cloud for a look that saw no tree.
    const std::string so_far = dropped_.add("unreadable clouds");
    ROS_WARN_THROTTLE(5.0, "%s: cloud on %s (frame '%s', stamp %.3f): %s; dropped (%s)", name_.c_str(),
                      cloud_sub_.getTopic().c_str(), msg->header.frame_id.c_str(), msg->header.stamp.toSec(),
                      why.c_str(), so_far.c_str());
    publishDropped(msg->header, "cloud", why);
    return;
  }
  std::vector<core::TrunkObservation> trunks;
  core::TrunkDetectorStats stats;
  stats.input_points = static_cast<int>(std::min<std::uint64_t>(cloud.total, std::numeric_limits<int>::max()));
  const Eigen::Matrix3d level = levelRotation(msg->header.frame_id, msg->header.stamp);
  double band_height = 1.0;
  core::SensorScope scope;
  {
    std::lock_guard<std::mutex> lock(detector_mutex_);
    takeSensorHeightFromTf(msg->header.frame_id);
    band_height = detector_->config().max_height - detector_->config().min_height;
    try
    {
      trunks = detector_->detect(cloud.points, level, &stats);
      scope = core::sweepScope(detector_->config(), stats.reach);
      warnShortReach(core::reachShortfall(detector_->config(), stats));
    }
    catch (const std::exception& e)
    {
      const std::string so_far = dropped_.add("detection failures");
      ROS_ERROR_THROTTLE(5.0, "%s: trunk detection failed: %s; cloud dropped (%s)", name_.c_str(), e.what(),
                         so_far.c_str());
      publishDropped(msg->header, "cloud", std::string("detection failed: ") + e.what());
      return;
    }
  }
  // The sweep's duration from the per-point times (VLP-16 drivers and the simulator give a float32 "time"
  // after the stamp), so that consumers can carry each trunk to one instant.
  publish(msg->header, trunks, stats, band_height, "cloud", cloud.sweep_period, scope);
}

void TrunkExtraction::onScan(const sensor_msgs::LaserScan::ConstPtr& msg)
{
  ++inputs_;
  if (!anyOutputSubscribed())
    return;

  core::PlanarScan scan;
  const std::string why = toPlanarScan(*msg, &scan);
  if (!why.empty())
  {
    const std::string so_far = dropped_.add("unreadable scans");
    ROS_WARN_THROTTLE(5.0, "%s: scan on %s (frame '%s', stamp %.3f): %s; dropped (%s)", name_.c_str(),
                      scan_sub_.getTopic().c_str(), msg->header.frame_id.c_str(), msg->header.stamp.toSec(),
                      why.c_str(), so_far.c_str());
    publishDropped(msg->header, "scan", why);
    return;
  }
  std::vector<core::TrunkObservation> trunks;
  core::TrunkDetectorStats stats;
  stats.input_points = static_cast<int>(msg->ranges.size());
  double band_height = 1.0;
  core::SensorScope scope;
  {
    std::lock_guard<std::mutex> lock(detector_mutex_);
    band_height = detector_->config().max_height - detector_->config().min_height;
    try
    {
      trunks = detector_->detectScan(scan, &stats);
      scope = core::scanScope(scan, detector_->config());
    }
    catch (const std::exception& e)
    {
      const std::string so_far = dropped_.add("detection failures");
      ROS_ERROR_THROTTLE(5.0, "%s: trunk detection failed: %s; scan dropped (%s)", name_.c_str(), e.what(),
                         so_far.c_str());
      publishDropped(msg->header, "scan", std::string("detection failed: ") + e.what());
      return;
    }
  }
  const core::SweepGeometry geometry = core::scanGeometry(scan);
  publish(msg->header, trunks, stats, band_height, "scan", scanPeriod(*msg), scope, &geometry);
}

void TrunkExtraction::warnShortReach(const std::string& why)
{
  if (why.empty())
    return;
  if (!reach_warned_)
    ROS_WARN("%s: %s", name_.c_str(), why.c_str());
  else
    ROS_WARN_THROTTLE(60.0, "%s: %s", name_.c_str(), why.c_str());
  reach_warned_ = true;
}

void TrunkExtraction::publishDropped(const std_msgs::Header& header, const char* input, const std::string& why)
{
  if (stats_pub_.getNumSubscribers() == 0)
    return;
  std::ostringstream s;
  s << "input=" << input << " stamp=" << header.stamp << " dropped=" << dropped_.total() << " inputs=" << inputs_
    << " reason=" << why;
  auto text = boost::make_shared<std_msgs::String>();
  text->data = s.str();
  stats_pub_.publish(std_msgs::String::ConstPtr(text));
}

void TrunkExtraction::publish(const std_msgs::Header& header, const std::vector<core::TrunkObservation>& trunks,
                              const core::TrunkDetectorStats& stats, double band_height, const char* input,
                              double sweep_period, const core::SensorScope& scope,
                              const core::SweepGeometry* geometry)
{
  const rbpf_slam::TrunkArray::Ptr out =
      toSweepMsg(header, trunks, scope, sweep_period, geometry, stats.tilt_roll, stats.tilt_pitch);

  if (markers_pub_.getNumSubscribers() > 0)
  {
    markers_pub_.publish(visualization_msgs::MarkerArray::ConstPtr(trunkMarkers(*out, band_height)));
    ++markers_published_;
  }
  if (stats_pub_.getNumSubscribers() > 0)
  {
    std::ostringstream s;
    s << "input=" << input << " stamp=" << header.stamp << " input_points=" << stats.input_points
      << " finite_points=" << stats.finite_points << " band_points=" << stats.band_points
      << " clusters=" << stats.clusters << " rejected_size=" << stats.rejected_size
      << " rejected_radius=" << stats.rejected_radius << " rejected_inliers=" << stats.rejected_inliers
      << " rejected_shape=" << stats.rejected_shape << " trunks=" << out->trunks.size()
      << " tilt_roll=" << stats.tilt_roll << " tilt_pitch=" << stats.tilt_pitch
      << " tilt_from=" << (stats.tilt_from_ground ? "ground" : "stems") << " ground_roll=" << stats.ground_roll
      << " ground_pitch=" << stats.ground_pitch << " inputs=" << inputs_
      << " markers_published=" << markers_published_ << " dropped=" << dropped_.total();
    auto text = boost::make_shared<std_msgs::String>();
    text->data = s.str();
    stats_pub_.publish(std_msgs::String::ConstPtr(text));
  }
  trunks_pub_.publish(rbpf_slam::TrunkArray::ConstPtr(out));
}

}  // namespace rbpf_slam
