#include "rbpf_slam/io/files.h"
#include "rbpf_slam/ros/grid_slam_node.h"
#include "rbpf_slam/ros/pose_msgs.h"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>

#include <sys/stat.h>

#include <boost/make_shared.hpp>
#include <geometry_msgs/PoseArray.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/MapMetaData.h>
#include <tf2/exceptions.h>

#include "rbpf_slam/io/grid_slam_config.h"
#include "rbpf_slam/io/map_image_file.h"
#include "rbpf_slam/ros/params.h"
#include "rbpf_slam/ros/ros_param_source.h"
#include "rbpf_slam/ros/scan_conversions.h"
#include "rbpf_slam/ros/tf_odometry.h"

namespace rbpf_slam
{
namespace
{
GridSlamRosConfig readRosConfig(const RosParamSource& params)
{
  GridSlamRosConfig c;
  const ros::NodeHandle& pnh = params.nodeHandle();
  readSlamRosConfig(params, &c);
  readKey(params, "map_update_interval", &c.map_update_interval);
  readKey(params, "map_path", &c.map_path);
  requireNonNegative(pnh, "map_update_interval", c.map_update_interval);
  return c;
}

/** @brief The maps' memory in one line (GridSlam::mapMemory()). */
std::string memoryReport(const core::GridSlam& filter)
{
  const core::GridMapMemory m = filter.mapMemory();
  char line[200];
  std::snprintf(line, sizeof(line),
                "%zu distinct tiles in %.2f MB; best map %zu tiles, %.0f m^2; %.3f MB per particle per 1000 m^2",
                m.tiles, m.megabytes(), m.best_tiles, m.best_area, m.megabytesPerParticlePer1000SquareMetres());
  return line;
}

}  // namespace

void toMsg(const core::OccupancyGrid& grid, nav_msgs::OccupancyGrid* msg)
{
  int w = 0, h = 0;
  core::MapOrigin origin;
  grid.exportProbabilities(&msg->data, &w, &h, &origin);
  msg->info.resolution = static_cast<float>(grid.resolution());
  msg->info.width = static_cast<std::uint32_t>(w);
  msg->info.height = static_cast<std::uint32_t>(h);
  msg->info.origin.position.x = origin.x;
  msg->info.origin.position.y = origin.y;
  msg->info.origin.orientation.w = 1.0;
}

GridSlamRos::GridSlamRos(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh), pnh_(pnh), name_(pnh.getNamespace())
{
  const RosParamSource params(pnh_);
  config_ = readRosConfig(params);
  filter_config_ = readCoreConfig<core::GridSlamConfig>(params, &io::readGridSlamConfig);
  filter_config_.keep_trajectory = false;  // the node never asks for it: memory stays flat on long runs
  warnUnknownKeys(params);
  core::PipelineTiming timing;
  timing.time_jump_threshold = config_.time_jump_threshold;
  timing.odometry_wait = config_.odom_timeout;  // wall seconds: the node's clock for waiting
  timing.max_pending = 50;
  pipeline_.reset(new core::GridSlamPipeline(filter_config_, timing));

  tf_buffer_.reset(new tf2_ros::Buffer());
  tf_listener_.reset(new tf2_ros::TransformListener(*tf_buffer_));
  odometry_.reset(new TfOdometry(tf_buffer_.get(), config_.odom_frame, config_.base_frame));

  path_.header.frame_id = config_.map_frame;
  map_pub_ = nh_.advertise<nav_msgs::OccupancyGrid>("map", 1, true);
  metadata_pub_ = nh_.advertise<nav_msgs::MapMetaData>("map_metadata", 1, true);
  pose_pub_ = nh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", 10);
  particles_pub_ = nh_.advertise<geometry_msgs::PoseArray>("particles", 2);
  path_pub_ = nh_.advertise<nav_msgs::Path>("path", 2);
  save_srv_ = pnh_.advertiseService("save_map", &GridSlamRos::onSaveMap, this);
  if (config_.publish_tf)
    tf_guard_.start(nh_, config_.map_frame, config_.odom_frame, name_);
  worker_ = std::thread(&GridSlamRos::work, this);
  // Deep queues: the callbacks only fill the inbox, and no message may be lost before it is there.
  tf_sub_ = nh_.subscribe("/tf", 1000, &GridSlamRos::onTf, this);
  scan_sub_ = nh_.subscribe("scan", 1000, &GridSlamRos::onScan, this);

  ROS_INFO("%s: grid SLAM (%s mode, %d particles, %s resampling, seed %llu, %.3f m cells) on %s; frames %s -> %s -> %s",
           name_.c_str(), core::gridSlamModeName(filter_config_.mode), filter_config_.particles,
           core::resamplingMethodName(filter_config_.resampling.method),
           static_cast<unsigned long long>(filter_config_.seed), filter_config_.grid.resolution,
           scan_sub_.getTopic().c_str(), config_.map_frame.c_str(), config_.odom_frame.c_str(),
           config_.base_frame.c_str());
}

GridSlamRos::~GridSlamRos()
{
  scan_sub_.shutdown();
  tf_sub_.shutdown();
  {
    std::lock_guard<std::mutex> lock(inbox_mutex_);
    stop_ = true;
  }
  inbox_cv_.notify_all();
  if (worker_.joinable())
    worker_.join();
}

namespace
{
std::string bareFrame(const std::string& frame)
{
  return !frame.empty() && frame[0] == '/' ? frame.substr(1) : frame;
}
}  // namespace

void GridSlamRos::onTf(const tf2_msgs::TFMessage::ConstPtr& msg)
{
  std::vector<OdometrySample> samples;
  for (const geometry_msgs::TransformStamped& t : msg->transforms)
    if (bareFrame(t.header.frame_id) == config_.odom_frame && bareFrame(t.child_frame_id) == config_.base_frame)
      samples.push_back({ t.header.stamp.toSec(), clockForStamps(),
                          core::Pose2(t.transform.translation.x, t.transform.translation.y,
                                      yawOf(t.transform.rotation)) });
  if (samples.empty())
    return;
  std::lock_guard<std::mutex> lock(inbox_mutex_);
  samples_ = true;
  inbox_odometry_.insert(inbox_odometry_.end(), samples.begin(), samples.end());
  if (inbox_odometry_.size() > 50 * kInboxScans)  // a filter that stopped: memory must not grow
    inbox_odometry_.erase(inbox_odometry_.begin(), inbox_odometry_.begin() + kInboxScans);
}

void GridSlamRos::onScan(const sensor_msgs::LaserScan::ConstPtr& msg)
{
  std::size_t waiting = 0, dropped = 0;
  double waited = 0.0, span = 0.0;
  const double now = ros::WallTime::now().toSec();
  {
    std::lock_guard<std::mutex> lock(inbox_mutex_);
    inbox_.push_back({ msg, clockForStamps(), now });
    while (inbox_.size() > kInboxScans)
    {
      inbox_.pop_front();
      ++inbox_dropped_;
    }
    waiting = inbox_.size();
    dropped = inbox_dropped_;
    waited = now - inbox_.front().arrival;  // how long the oldest scan has waited: how far behind the filter is
    span = msg->header.stamp.toSec() - inbox_.front().msg->header.stamp.toSec();
  }
  inbox_cv_.notify_one();
  if (dropped > 0 && waiting == kInboxScans)
    ROS_WARN_THROTTLE(5.0, "%s: the filter is %.1f s behind the scans and its inbox is full (%zu scans): the oldest "
                      "are dropped (%zu so far); fewer particles or travel thresholds make it keep up", name_.c_str(),
                      waited, kInboxScans, dropped);
  else if (waited > 1.0)
    ROS_WARN_THROTTLE(5.0, "%s: the filter is %.1f s behind the scans (%zu wait, %.1f s of scan time); none is lost "
                      "until %zu wait", name_.c_str(), waited, waiting, span, kInboxScans);
}

void GridSlamRos::work()
{
  std::unique_lock<std::mutex> inbox(inbox_mutex_);
  while (!stop_)
  {
    // Every 0.05 s at least: a scan that waits for odometry is processed once ~odom_timeout has passed.
    inbox_cv_.wait_for(inbox, std::chrono::milliseconds(50), [this] { return stop_ || !inbox_.empty(); });
    if (stop_)
      break;
    // All odometry that has come, then one scan: what arrived before the scan is there when it is processed.
    std::vector<OdometrySample> samples;
    samples.swap(inbox_odometry_);
    const bool use_samples = samples_;
    InboxScan scan;
    if (!inbox_.empty())
    {
      scan = std::move(inbox_.front());
      inbox_.pop_front();
    }
    inbox.unlock();
    try
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!samples.empty())  // onTf keeps only odom -> base_link transforms: the odometry is /tf's samples
        feedSamples(samples);
      if (scan.msg)
        admit(scan);
      processPending();
      // No scan anywhere (the scanner silent): as TF's buffer, odometry is kept 10 s back. A scan that comes later
      // than that after its odometry finds none at its stamp.
      if (use_samples && !scan.msg)
        pipeline_->forgetOdometryBefore(fed_until_ - 10.0);
    }
    catch (const std::exception& e)
    {
      ROS_ERROR_THROTTLE(5.0, "%s: %s", name_.c_str(), e.what());
    }
    inbox.lock();
  }
}

void GridSlamRos::onRestart(double stamp)
{
  seen_restarts_ = pipeline_->restarts();
  // A looped bag or a restarted simulation: a new map rather than two timelines mixed. The TF listener clears its
  // own buffer when the clock jumps back; clearing it here as well could drop the bag's /tf_static, which is
  // published only once.
  if (last_scan_stamp_.isZero())
    ROS_WARN("%s: stamp %.3f, more than ~time_jump_threshold %.2f s before the odometry so far, with the clock: time "
             "jumped back; the map is restarted (reset %d)", name_.c_str(), stamp, config_.time_jump_threshold,
             pipeline_->restarts());
  else
    ROS_WARN("%s: stamp %.3f, %.3f s before the previous scan (more than ~time_jump_threshold %.2f s): time jumped "
             "back; the map is restarted (reset %d, %zu scans processed in all)", name_.c_str(), stamp,
             last_scan_stamp_.toSec() - stamp, config_.time_jump_threshold, pipeline_->restarts(), updates_);
  fed_until_ = -1e300;
  path_.poses.clear();
  last_map_stamp_ = ros::Time();
  saveEndedMaps();
}

void GridSlamRos::feedSamples(const std::vector<OdometrySample>& samples)
{
  for (const OdometrySample& s : samples)
  {
    if (s.stamp <= fed_until_ && s.stamp > fed_until_ - config_.time_jump_threshold)
      continue;  // a transform TF gave twice, or already read from TF at a scan's stamp
    const core::StampVerdict v = pipeline_->addOdometry(s.stamp, s.pose, s.clock);
    if (pipeline_->restarts() != seen_restarts_)
      onRestart(s.stamp);
    if (v == core::StampVerdict::kAccept || v == core::StampVerdict::kReset)
      fed_until_ = s.stamp;
    else
      ROS_WARN_THROTTLE(5.0, "%s: odometry (TF %s -> %s) at %.3f: %s; dropped", name_.c_str(),
                        config_.odom_frame.c_str(), config_.base_frame.c_str(), s.stamp,
                        core::stampVerdictName(v));
  }
}

void GridSlamRos::admit(const InboxScan& in)
{
  const sensor_msgs::LaserScan::ConstPtr& msg = in.msg;
  // The stamp rule at arrival (the pipeline's, as offline): a late or future scan must not wait for its TF.
  const core::StampVerdict verdict = pipeline_->admitScan(msg->header.stamp.toSec(), in.clock);
  if (verdict == core::StampVerdict::kReset || pipeline_->restarts() != seen_restarts_)
    onRestart(msg->header.stamp.toSec());
  else if (verdict != core::StampVerdict::kAccept)
  {
    const std::string so_far = dropped_.add(core::stampVerdictName(verdict));
    // The first drop of each kind is always said; repeats at most every 5 s.
    if (warned_verdicts_.insert(static_cast<int>(verdict)).second)
      ROS_WARN("%s: scan stamped %.3f (previous %.3f, clock %.3f): %s; dropped (%s)", name_.c_str(),
               msg->header.stamp.toSec(), last_scan_stamp_.toSec(), in.clock, core::stampVerdictName(verdict),
               so_far.c_str());
    else
      ROS_WARN_THROTTLE(5.0, "%s: scan stamped %.3f (previous %.3f, clock %.3f): %s; dropped (%s)", name_.c_str(),
                        msg->header.stamp.toSec(), last_scan_stamp_.toSec(), in.clock,
                        core::stampVerdictName(verdict), so_far.c_str());
    return;
  }
  last_scan_stamp_ = msg->header.stamp;
  core::ScanData scan;
  const std::string why = toScanData(*msg, &scan);
  core::Pose2 sensor;
  std::string error;
  // The scanner's mount at the scan's stamp, or the newest (a mount that TF has not reached the stamp of yet).
  if (!why.empty() || (!lookup(config_.base_frame, msg->header.frame_id, msg->header.stamp, &sensor, &error) &&
                       !lookup(config_.base_frame, msg->header.frame_id, ros::Time(0), &sensor, &error)))
  {
    const std::string reason = why.empty() ? "no transform " + config_.base_frame + " -> " + msg->header.frame_id : why;
    const std::string so_far = dropped_.add(why.empty() ? reason : "unreadable scans");
    if (warned_reasons_.insert(reason).second)  // the first of each reason always, repeats at most every 5 s
      ROS_WARN("%s: scan at %.3f: %s: dropped (%s)", name_.c_str(), msg->header.stamp.toSec(), reason.c_str(),
               so_far.c_str());
    else
      ROS_WARN_THROTTLE(5.0, "%s: scan at %.3f: %s: dropped (%s)", name_.c_str(), msg->header.stamp.toSec(),
                        reason.c_str(), so_far.c_str());
    return;
  }
  const std::size_t before = pipeline_->droppedPending();
  pipeline_->enqueueScan(msg->header.stamp.toSec(), std::move(scan), sensor, in.arrival);
  if (pipeline_->droppedPending() > before)
    ROS_WARN_THROTTLE(5.0, "%s: %zu scans wait for odometry (TF %s -> %s); dropping the oldest", name_.c_str(),
                      pipeline_->pending(), config_.odom_frame.c_str(), config_.base_frame.c_str());
}

bool GridSlamRos::lookup(const std::string& parent, const std::string& child, const ros::Time& stamp,
                         core::Pose2* pose, std::string* error)
{
  try
  {
    const geometry_msgs::TransformStamped t = tf_buffer_->lookupTransform(parent, child, stamp);
    *pose = core::Pose2(t.transform.translation.x, t.transform.translation.y, yawOf(t.transform.rotation));
    return std::isfinite(pose->x) && std::isfinite(pose->y) && std::isfinite(pose->theta);
  }
  catch (const tf2::TransformException& e)
  {
    *error = e.what();
    return false;
  }
}

void GridSlamRos::feedOdometry()
{
  {
    // When TF holds odom -> base_link as one transform, its samples come on /tf as well (to onTf, perhaps a little
    // after TF's listener has them): the pose must not be taken from TF's interpolation meanwhile.
    std::string parent;
    const bool direct = tf_buffer_->_getParent(config_.base_frame, ros::Time(0), parent) &&
                        parent == config_.odom_frame;
    std::lock_guard<std::mutex> lock(inbox_mutex_);
    samples_ = samples_ || direct;
    if (samples_)
      return;  // the odometry comes as /tf's samples (feedSamples)
  }
  // The odometry at each waiting scan's stamp, from TF, into the pipeline: a scan is processed once odometry covers
  // it, or after ~odom_timeout with the newest odometry (as the FastSLAM node does).
  for (const double end : pipeline_->waitingEnds())
  {
    if (end <= fed_until_)
      continue;
    core::Pose2 pose;
    std::string error;
    const TfOdometry::Answer a = odometry_->at(ros::Time(end), &pose, &error);
    if (a == TfOdometry::Answer::kNotYet)
      break;
    if (a == TfOdometry::Answer::kNever)
    {
      ROS_WARN_THROTTLE(5.0, "%s: TF holds no odometry at the scan at %.3f (%s)", name_.c_str(), end, error.c_str());
      continue;
    }
    const core::StampVerdict v = pipeline_->addOdometry(end, pose);
    if (v != core::StampVerdict::kAccept)
      ROS_WARN_THROTTLE(5.0, "%s: odometry from TF at %.3f: %s", name_.c_str(), end, core::stampVerdictName(v));
    fed_until_ = end;
  }
}

void GridSlamRos::processPending()
{
  feedOdometry();
  std::vector<core::GridPipelineUpdate> done;
  try
  {
    done = pipeline_->process(ros::WallTime::now().toSec());
  }
  catch (const std::exception& e)
  {
    ROS_ERROR_THROTTLE(5.0, "%s: update failed: %s", name_.c_str(), e.what());
    return;
  }
  for (const core::GridPipelineUpdate& u : done)
  {
    if (u.timeline != pipeline_->restarts())
      continue;  // the old timeline's last scans, flushed by a restart: its map is gone
    if (!u.error.empty())
    {
      const std::string so_far = dropped_.add(u.error);
      ROS_WARN_THROTTLE(5.0, "%s: scan at %.3f: %s: dropped (%s)", name_.c_str(), u.stamp, u.error.c_str(),
                        so_far.c_str());
      continue;
    }
    if (u.outage_began)
      ROS_WARN("%s: the odometry (TF %s -> %s) stopped at %.3f; the scans from %.3f are left out of the map (kept "
               "as it is) until it returns", name_.c_str(), config_.odom_frame.c_str(), config_.base_frame.c_str(),
               pipeline_->outage().since, u.stamp);
    if (u.outage_scans > 0)
      ROS_WARN("%s: the odometry returned at %.3f after %.3f s; %d scans were left out of the map", name_.c_str(),
               u.stamp, u.outage_seconds, u.outage_scans);
    if (!u.odometry_covered && !u.odometry_stopped)
      ROS_WARN_THROTTLE(5.0, "%s: no odometry (TF %s -> %s) up to the scan at %.3f within %.2f s (newest %.3f); used "
                        "the newest", name_.c_str(), config_.odom_frame.c_str(), config_.base_frame.c_str(), u.stamp,
                        config_.odom_timeout, pipeline_->odometry().latest());
    if (u.step.skipped)
      ++skipped_;  // below the travel thresholds: only the pose moves on with the odometry
    else
    {
      ++updates_;
      ROS_DEBUG("%s: scan %zu: Neff %.1f%s, best correlation %d", name_.c_str(), updates_, u.step.neff,
                u.step.resampled ? ", resampled" : "", u.step.best_correlation);
    }
    const ros::Time t(u.stamp);
    publishPoses(t, u);
    if (!u.step.skipped &&
        (last_map_stamp_.isZero() || (t - last_map_stamp_).toSec() >= config_.map_update_interval))
    {
      publishMap(t);
      last_map_stamp_ = t;
      // The report walks every particle's tile table: only when debug output is on (the arguments are evaluated
      // only then).
      ROS_DEBUG("%s: map memory after %zu processed scans: %s", name_.c_str(), updates_,
                memoryReport(pipeline_->filter()).c_str());
    }
  }
}

void GridSlamRos::publishMap(const ros::Time& stamp)
{
  auto map = boost::make_shared<nav_msgs::OccupancyGrid>();
  toMsg(pipeline_->filter().map(), map.get());
  map->header.stamp = stamp;
  map->header.frame_id = config_.map_frame;
  map->info.map_load_time = stamp;
  map_pub_.publish(nav_msgs::OccupancyGrid::ConstPtr(map));
  metadata_pub_.publish(boost::make_shared<nav_msgs::MapMetaData>(map->info));
}

void GridSlamRos::publishPoses(const ros::Time& stamp, const core::GridPipelineUpdate& u)
{
  const core::GridSlam& filter = pipeline_->filter();
  if (config_.publish_tf && tf_guard_.owned())
    tf_broadcaster_.sendTransform(planarTransform(stamp + ros::Duration(config_.transform_tolerance),
                                                  config_.map_frame, config_.odom_frame, u.map_to_odom));
  // The particles carried by the odometry since the last processed scan (to this scan's odometry).
  const core::PoseMoments moments = filter.cloudMoments(u.odometry);
  pose_pub_.publish(boost::make_shared<geometry_msgs::PoseWithCovarianceStamped>(
      poseWithCovariance(stamp, config_.map_frame, moments.mean, moments.covariance)));
  if (particles_pub_.getNumSubscribers() > 0)
    particles_pub_.publish(
        boost::make_shared<geometry_msgs::PoseArray>(particleCloud(stamp, config_.map_frame, filter.particles())));
  appendToPath(&path_, stamp, config_.map_frame, u.estimate, config_.max_path_poses);
  if (path_pub_.getNumSubscribers() > 0)
    path_pub_.publish(boost::make_shared<nav_msgs::Path>(path_));
}

void GridSlamRos::saveEndedMaps()
{
  // Beside ~map_path (FILE.yaml): FILE.restartN.yaml + .pgm, the map that restart N ended.
  for (const core::GridTimelineMap& ended : pipeline_->takeEndedMaps())
  {
    const std::string target = io::expandHome(config_.map_path);
    const std::size_t slash = target.rfind('/');
    const std::string file = io::endedMapPath(target, ended.timeline);
    try
    {
      if (slash != std::string::npos && slash > 0 && !io::makeDirectories(target.substr(0, slash)))
        throw std::runtime_error("cannot create the directory of " + target + ": " + std::strerror(errno));
      io::saveMapImage(ended.map, file);
      ROS_WARN("%s: the map before restart %d is saved to %s", name_.c_str(), ended.timeline + 1, file.c_str());
    }
    catch (const std::exception& e)
    {
      ROS_ERROR("%s: the map before restart %d could not be saved: %s", name_.c_str(), ended.timeline + 1, e.what());
    }
  }
}

bool GridSlamRos::onSaveMap(std_srvs::Trigger::Request& /*req*/, std_srvs::Trigger::Response& res)
{
  std::lock_guard<std::mutex> lock(mutex_);
  const std::string target = io::expandHome(config_.map_path);
  const core::GridSlam& filter = pipeline_->filter();
  if (!filter.initialised() || filter.map().tileCount() == 0)
  {
    res.success = false;
    res.message = "no map yet (no scan processed)";
    return true;
  }
  const std::size_t slash = target.rfind('/');
  if (slash != std::string::npos && slash > 0 && !io::makeDirectories(target.substr(0, slash)))
  {
    res.success = false;
    res.message = "cannot create the directory of " + target + ": " + std::strerror(errno);
    return true;
  }
  try
  {
    io::saveMapImage(filter.map().toImage(), target);
    res.success = true;
    res.message = "map saved to " + target;
    ROS_INFO("%s: %s", name_.c_str(), res.message.c_str());
  }
  catch (const std::exception& e)
  {
    res.success = false;
    res.message = e.what();
  }
  return true;
}

}  // namespace rbpf_slam
