#include "rbpf_slam/ros/forest_sim.h"

#include <chrono>
#include <cmath>
#include <exception>

#include <boost/make_shared.hpp>
#include <rosgraph_msgs/Clock.h>
#include <std_msgs/Bool.h>

#include "rbpf_slam/core/grid/occupancy_image.h"
#include "rbpf_slam/io/map_image_file.h"
#include "rbpf_slam/sim/sim_config.h"
#include "rbpf_slam/sim/world_file.h"
#include "rbpf_slam/ros/gnss_conversions.h"
#include "rbpf_slam/ros/params.h"
#include "rbpf_slam/ros/ros_param_source.h"

namespace rbpf_slam
{
ForestSim::ForestSim(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh), pnh_(pnh)
{
  sim::SimulatorConfig config;
  std::string world_path, indoor_map;
  std::shared_ptr<const core::OccupancyImage> indoor_image;
  std::vector<std::string> lockstep_topics;
  try
  {
    const RosParamSource params(pnh_);
    sim::readSimulatorConfig(params, &config);
    params.get("world", &world_path);
    params.get("indoor_map", &indoor_map);
    params.get("real_time_factor", &real_time_factor_);
    params.get("duration", &duration_);
    params.get("lockstep", &lockstep_);
    params.get("lockstep_timeout", &lockstep_timeout_);
    params.get("publish_clock", &publish_clock_);
    params.get("time_base", &time_base_);
    params.get("frames/map", &frames_.map);
    params.get("frames/odom", &frames_.odom);
    params.get("frames/base", &frames_.base);
    params.get("frames/truth_base", &frames_.truth_base);
    params.get("frames/lidar3d", &frames_.lidar3d);
    params.get("frames/lidar2d", &frames_.lidar2d);
    params.get("frames/gps", &frames_.gps);
    params.get("lockstep_topics", &lockstep_topics);
    // The offline recorder's keys of the same file (its in-process follower and relay, its time-out): known, but
    // not this node's; the launch's path_follower and noise_relay nodes take their own parameters.
    std::string recorder_keys;
    for (const char* key : { "follower", "relay", "timeout" })
      if (pnh_.hasParam(key))
      {
        params.markUsed(key);
        recorder_keys += std::string(recorder_keys.empty() ? "" : ", ") + key;
      }
    if (!recorder_keys.empty())
      ROS_INFO("%s: %s: record_scenario's keys (its in-process follower and relay), not used here: the path_follower "
               "and noise_relay nodes take their own parameters",
               pnh_.getNamespace().c_str(), recorder_keys.c_str());
    warnUnknownKeys(params);
    if (world_path.empty() && indoor_map.empty())
      throw std::runtime_error("set ~world (a forest world file) or ~indoor_map (a map_server YAML)");
    if (!(real_time_factor_ >= 0.0))
      throw std::runtime_error("~real_time_factor must be >= 0 (0: as fast as possible)");
    if (indoor_map.empty())
    {
      sim_.reset(new sim::ForestSimulator(sim::loadForestWorld(world_path), config));
    }
    else
    {
      indoor_image = std::make_shared<const core::OccupancyImage>(io::loadMapImage(indoor_map));
      sim::ForestWorld flat;
      flat.ground.amplitude = 0.0;
      config.lidar3d.enabled = false;
      sim_.reset(new sim::ForestSimulator(flat, config, indoor_image));
    }
  }
  catch (const std::exception& e)
  {
    throw std::runtime_error(std::string(e.what()) + "; the simulator does not start");
  }

  clock_pub_ = nh_.advertise<rosgraph_msgs::Clock>("/clock", 10);
  cloud_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("points", 5);
  scan_pub_ = nh_.advertise<sensor_msgs::LaserScan>("scan", 10);
  odom_pub_ = nh_.advertise<nav_msgs::Odometry>("odom", 50);
  imu_pub_ = nh_.advertise<sensor_msgs::Imu>("imu/data", 100);
  if (sim_->config().gnss.enabled)
  {
    gps_pub_ = nh_.advertise<sensor_msgs::NavSatFix>("gps/fix", 10);
    gps_truth_pub_ = nh_.advertise<sensor_msgs::NavSatFix>("ground_truth/fix", 10);
  }
  truth_pub_ = nh_.advertise<nav_msgs::Odometry>("ground_truth/odom", 50);
  truth_path_pub_ = nh_.advertise<nav_msgs::Path>("ground_truth/path", 1, true);
  trees_pub_ = nh_.advertise<rbpf_slam::TrunkArray>("ground_truth/trees", 1, true);
  tree_markers_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("ground_truth/tree_markers", 1, true);
  done_pub_ = nh_.advertise<std_msgs::Bool>("sim_done", 1, true);
  if (indoor_image)
  {
    truth_map_pub_ = nh_.advertise<nav_msgs::OccupancyGrid>("ground_truth/map", 1, true);
    truth_map_pub_.publish(
        nav_msgs::OccupancyGrid::ConstPtr(toTruthMap(*indoor_image, sim_->config().start, frames_, 0.0, time_base_)));
  }
  cmd_sub_ = nh_.subscribe("cmd_vel", 10, &ForestSim::onCommand, this);
  ack_stamps_.assign(lockstep_topics.size(), ros::Time(0));
  for (std::size_t i = 0; i < lockstep_topics.size(); ++i)
    ack_subs_.push_back(nh_.subscribe<AnyStamped>(
        lockstep_topics[i], 10, boost::bind(&ForestSim::onAck, this, boost::placeholders::_1, i)));

  const sim::SimulatorConfig& c = sim_->config();
  std::vector<geometry_msgs::TransformStamped> statics{ toStaticTf(c.lidar3d.mount, frames_.base, frames_.lidar3d, 0.0,
                                                                   time_base_),
                                                        toStaticTf(c.lidar2d.mount, frames_.base, frames_.lidar2d, 0.0,
                                                                   time_base_) };
  if (c.gnss.enabled)
    statics.push_back(toStaticTf(gpsMount(c.gnss), frames_.base, frames_.gps, 0.0, time_base_));
  static_tf_.sendTransform(statics);
  const auto trees = toTruthTrees(sim_->world(), c.start, frames_, 0.0, time_base_);
  trees_pub_.publish(rbpf_slam::TrunkArray::ConstPtr(trees));
  tree_markers_pub_.publish(visualization_msgs::MarkerArray::ConstPtr(toTreeMarkers(*trees, "true_trees", 0.55f, 0.35f, 0.15f)));
  truth_path_.header.frame_id = frames_.map;
  start_ground_z_ = sim::Ground(sim_->world().ground).height(c.start.x, c.start.y);

  ROS_INFO("%s: %s, %zu trunks, start (%.2f, %.2f, %.1f deg), seed %llu, %s%s", pnh_.getNamespace().c_str(),
           indoor_map.empty() ? world_path.c_str() : indoor_map.c_str(), sim_->world().trunks.size(), c.start.x,
           c.start.y, c.start.theta * 180.0 / M_PI, static_cast<unsigned long long>(c.seed),
           lockstep_ ? "lockstep" : (real_time_factor_ > 0.0 ? "real time" : "as fast as possible"),
           real_time_factor_ > 0.0 && real_time_factor_ != 1.0 ? " (scaled)" : "");
  running_ = true;
  thread_ = std::thread(&ForestSim::run, this);
}

ForestSim::~ForestSim()
{
  running_ = false;
  cv_.notify_all();
  if (thread_.joinable())
    thread_.join();
}

void ForestSim::onCommand(const geometry_msgs::Twist::ConstPtr& msg)
{
  if (!std::isfinite(msg->linear.x) || !std::isfinite(msg->angular.z))
  {
    ROS_WARN_THROTTLE(5.0, "%s: ignoring a NaN/Inf velocity command", cmd_sub_.getTopic().c_str());
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    command_ = { msg->linear.x, msg->angular.z };
    ++commands_received_;
  }
  cv_.notify_all();
}

void ForestSim::onAck(const boost::shared_ptr<const AnyStamped>& msg, std::size_t index)
{
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ack_stamps_[index] = std::max(ack_stamps_[index], msg->header.stamp);
  }
  cv_.notify_all();
}

void ForestSim::waitLockstep(double sensor_stamp)
{
  const ros::Time stamp = toRosTime(sensor_stamp, time_base_);
  std::unique_lock<std::mutex> lock(mutex_);
  const bool ok = cv_.wait_for(lock, std::chrono::duration<double>(lockstep_timeout_), [&] {
    if (!running_)
      return true;
    if (commands_received_ < odometry_published_ && cmd_sub_.getNumPublishers() > 0)
      return false;
    for (std::size_t i = 0; i < ack_stamps_.size(); ++i)
      if (sensor_stamp >= 0.0 && ack_stamps_[i] < stamp && ack_subs_[i].getNumPublishers() > 0)
        return false;
    return true;
  });
  if (!ok)
  {
    ROS_WARN_THROTTLE(5.0, "%s: lockstep: no answer within %.1f s (commands %llu of %llu); going on",
                      pnh_.getNamespace().c_str(), lockstep_timeout_, static_cast<unsigned long long>(commands_received_),
                      static_cast<unsigned long long>(odometry_published_));
    commands_received_ = std::max(commands_received_, odometry_published_);
  }
}

void ForestSim::run()
{
  sim::SimulatorOutput out;
  const auto wall_start = std::chrono::steady_clock::now();
  bool done = false;
  while (running_ && ros::ok())
  {
    if (duration_ > 0.0 && sim_->time() >= duration_)
    {
      if (!done)
      {
        std_msgs::Bool msg;
        msg.data = true;
        done_pub_.publish(msg);
        ROS_INFO("%s: simulated %.1f s; stopping", pnh_.getNamespace().c_str(), sim_->time());
        done = true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      continue;
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      sim_->setCommand(command_);
    }
    out.clear();
    const bool had_collided = sim_->collision() != nullptr;
    sim_->step(&out);
    if (!had_collided && sim_->collision())
    {
      const sim::Collision& c = *sim_->collision();
      ROS_ERROR("%s: COLLISION at %.2f s: the robot touched %s at true pose (%.2f, %.2f, %.1f deg) in the world; it "
                "stays there (the sensors go on)",
                pnh_.getNamespace().c_str(), c.stamp, c.what(sim_->world()).c_str(), c.pose.x, c.pose.y,
                c.pose.theta * 180.0 / M_PI);
    }
    if (publish_clock_)
    {
      rosgraph_msgs::Clock clock;
      clock.clock = toRosTime(sim_->time(), time_base_);
      clock_pub_.publish(clock);
    }
    publish(out);
    if (lockstep_)
    {
      double sensor_stamp = -1.0;
      for (const auto& s : out.sweeps)
        sensor_stamp = std::max(sensor_stamp, s.stamp);
      for (const auto& s : out.scans)
        sensor_stamp = std::max(sensor_stamp, s.stamp);
      if (!out.odometry.empty() || sensor_stamp >= 0.0)
        waitLockstep(sensor_stamp);
    }
    else if (real_time_factor_ > 0.0)
    {
      const auto due = wall_start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                        std::chrono::duration<double>(sim_->time() / real_time_factor_));
      std::this_thread::sleep_until(due);
    }
  }
}

void ForestSim::publish(const sim::SimulatorOutput& out)
{
  for (const auto& o : out.odometry)
  {
    odom_pub_.publish(nav_msgs::Odometry::ConstPtr(toOdometry(o, frames_, time_base_)));
    tf_.sendTransform(toOdomTf(o, frames_, time_base_));
    std::lock_guard<std::mutex> lock(mutex_);
    ++odometry_published_;
  }
  for (const auto& s : out.imu)
    imu_pub_.publish(sensor_msgs::Imu::ConstPtr(toImu(s, sim_->config().imu, frames_.base, time_base_)));
  for (const auto& s : out.sweeps)
    cloud_pub_.publish(sensor_msgs::PointCloud2::ConstPtr(toPointCloud2(s, frames_.lidar3d, time_base_)));
  for (const auto& s : out.scans)
    scan_pub_.publish(sensor_msgs::LaserScan::ConstPtr(toLaserScan(s, frames_.lidar2d, time_base_)));
  for (const auto& g : out.gnss)
  {
    const ros::Time stamp = toRosTime(g.fix.stamp, time_base_);
    const double vertical = sim_->config().gnss.vertical_factor;
    gps_pub_.publish(sensor_msgs::NavSatFix::ConstPtr(toNavSatFix(g.fix, frames_.gps, stamp, vertical)));
    gps_truth_pub_.publish(sensor_msgs::NavSatFix::ConstPtr(toNavSatFix(g.truth, frames_.gps, stamp, vertical)));
  }
  for (const auto& t : out.truth)
  {
    const auto msg = toTruthOdometry(t, sim_->config().start, start_ground_z_, frames_, time_base_);
    truth_pub_.publish(nav_msgs::Odometry::ConstPtr(msg));
    geometry_msgs::PoseStamped pose;
    pose.header = msg->header;
    pose.pose = msg->pose.pose;
    truth_path_.poses.push_back(pose);
    if (truth_path_.poses.size() % 25 == 1)  // the path at 2 Hz is enough for rviz
    {
      truth_path_.header.stamp = msg->header.stamp;
      truth_path_pub_.publish(truth_path_);
    }
  }
}

}  // namespace rbpf_slam
