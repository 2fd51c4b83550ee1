#include "rbpf_slam/io/files.h"
#include "rbpf_slam/ros/pose_msgs.h"
#include "rbpf_slam/ros/fastslam_node.h"

#include "rbpf_slam/core/trunk_slam/trunk_slam_pipeline.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <sstream>

#include <sys/stat.h>
#include <unistd.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif

#include <boost/make_shared.hpp>
#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/PoseArray.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <tf2/exceptions.h>
#include <visualization_msgs/MarkerArray.h>

#include <Eigen/Eigenvalues>

#include "rbpf_slam/io/fastslam_config.h"
#include "rbpf_slam/io/run_output.h"
#include "rbpf_slam/ros/gnss_conversions.h"
#include "rbpf_slam/ros/params.h"
#include "rbpf_slam/ros/ros_param_source.h"
#include "rbpf_slam/ros/trunk_conversions.h"

namespace rbpf_slam
{
namespace
{
FastSlamRosConfig readRosConfig(const RosParamSource& params)
{
  FastSlamRosConfig c;
  readSlamRosConfig(params, &c);
  readKey(params, "inventory_path", &c.inventory_path);
  readKey(params, "run_folder", &c.run_folder);
  readKey(params, "map_file", &c.map_file);
  readKey(params, "initial_x", &c.initial_x);
  readKey(params, "initial_y", &c.initial_y);
  readKey(params, "initial_yaw", &c.initial_yaw);
  readKey(params, "map_path", &c.map_path);
  readKey(params, "relocalize", &c.relocalize);
  if (!std::isfinite(c.initial_x) || !std::isfinite(c.initial_y) || !std::isfinite(c.initial_yaw))
    throw invalidParameter(params.nodeHandle(), "initial_x", "initial_x, initial_y and initial_yaw must be finite");
  return c;
}

}  // namespace

FastSlamRos::FastSlamRos(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh), pnh_(pnh), name_(pnh.getNamespace())
{
  const RosParamSource params(pnh_);
  config_ = readRosConfig(params);
  core::TrunkSlamConfig filter_config = readCoreConfig<core::TrunkSlamConfig>(params, &io::readFastSlamConfig);
  // The run folder's tables and the best particle's history grow with every update: kept only when the node is to
  // write a run folder, so that a node without one holds memory that grows with the map alone.
  filter_config.keep_history = !config_.run_folder.empty();
  record_ = io::FastSlamRunRecord(!config_.run_folder.empty());
  warnUnknownKeys(params);
  core::PipelineTiming timing;
  timing.time_jump_threshold = config_.time_jump_threshold;
  timing.odometry_wait = config_.odom_timeout;  // wall seconds: the node's clock for waiting
  pipeline_.reset(new core::TrunkSlamPipeline(core::TrunkDetectorConfig(), filter_config, timing));
  io::MapStart start;
  start.map_file = config_.map_file.empty() ? "" : io::expandHome(config_.map_file);
  start.search = config_.relocalize;
  start.start = core::Pose2(config_.initial_x, config_.initial_y, config_.initial_yaw);
  try
  {
    session_.reset(new io::FastSlamMapSession(pipeline_.get(), start, [] { return !ros::ok(); }));
  }
  catch (const std::exception& e)
  {
    throw invalidParameter(pnh_, "map_file", e.what());
  }
  if (session_->fromSavedMap())
    ROS_INFO("%s: %s", name_.c_str(), session_->startDescription().c_str());

  tf_buffer_.reset(new tf2_ros::Buffer());
  tf_listener_.reset(new tf2_ros::TransformListener(*tf_buffer_));

  path_.header.frame_id = config_.map_frame;
  pose_pub_ = nh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", 10);
  particles_pub_ = nh_.advertise<geometry_msgs::PoseArray>("particles", 2);
  landmarks_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("landmark_markers", 2);
  change_markers_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("change_markers", 2);
  landmark_array_pub_ = nh_.advertise<rbpf_slam::TrunkArray>("landmark_array", 2);
  path_pub_ = nh_.advertise<nav_msgs::Path>("path", 2);
  odom_path_.header.frame_id = config_.map_frame;
  odom_path_pub_ = nh_.advertise<nav_msgs::Path>("odom_path", 2);
  scope_pub_ = nh_.advertise<visualization_msgs::Marker>("scope", 2);
  loops_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("loop_markers", 2, true);
  diagnostics_pub_ = nh_.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 10);
  save_srv_ = pnh_.advertiseService<std_srvs::Trigger::Request, std_srvs::Trigger::Response>(
      "save_inventory", [this](std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
        return onSave("inventory_path", config_.inventory_path, false, res);
      });
  save_run_srv_ = pnh_.advertiseService("save_run", &FastSlamRos::onSaveRun, this);
  save_map_srv_ = pnh_.advertiseService<std_srvs::Trigger::Request, std_srvs::Trigger::Response>(
      "save_map", [this](std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
        return onSave("map_path", config_.map_path, true, res);
      });
  if (config_.publish_tf)
    tf_guard_.start(nh_, config_.map_frame, config_.odom_frame, name_);
  gps_sub_ = nh_.subscribe("gps/fix", 10, &FastSlamRos::onFix, this);
  odom_sub_ = nh_.subscribe("odom", 200, &FastSlamRos::onOdometry, this);
  // A queue that holds several seconds of sweeps: an update that waits for a solve beside it (loop closure, at a
  // fixed later update) loses none.
  trunks_sub_ = nh_.subscribe("trunks", 200, &FastSlamRos::onTrunks, this);
  timer_ = nh_.createWallTimer(ros::WallDuration(0.05), &FastSlamRos::onTimer, this);

  ROS_INFO("%s: FastSLAM with %d particles (seed %llu) on %s and %s; frames %s -> %s -> %s", name_.c_str(),
           filter_config.particles, static_cast<unsigned long long>(filter_config.seed), odom_sub_.getTopic().c_str(),
           trunks_sub_.getTopic().c_str(), config_.map_frame.c_str(), config_.odom_frame.c_str(),
           config_.base_frame.c_str());
}

FastSlamRos::~FastSlamRos()
{
  // The run folder at shutdown, when one is configured and the filter ran (never throws out of here).
  std::lock_guard<std::mutex> lock(mutex_);
  if (config_.run_folder.empty() || record_.updates() == 0)
    return;
  std::string message;
  if (writeRunFolder(&message))
    ROS_INFO("%s: %s", name_.c_str(), message.c_str());
  else
    ROS_ERROR("%s: run folder: %s", name_.c_str(), message.c_str());
}

namespace
{
/** @brief Gives the memory a save's solve freed back to the system (glibc keeps freed pages otherwise). */
void releaseFreedMemory()
{
#ifdef __GLIBC__
  malloc_trim(0);
#endif
}
}  // namespace

core::SmoothedRun FastSlamRos::smoothBesideFilter(bool* same_timeline)
{
  std::function<core::SmoothedRun()> job;
  int timeline = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    job = pipeline_->smoothingJob();
    timeline = pipeline_->restarts();
  }
  // The solve works on copies: the filter goes on taking messages meanwhile.
  core::SmoothedRun run = job();
  job = nullptr;
  std::lock_guard<std::mutex> lock(mutex_);
  *same_timeline = pipeline_->restarts() == timeline;
  return run;
}

bool FastSlamRos::writeRunFolder(std::string* message, const core::SmoothedRun* smoothed)
{
  if (!record_.keepsTables())
  {
    *message = "no ~run_folder was set at the start (the node keeps the run's tables only then)";
    return false;
  }
  pnh_.getParam("run_folder", config_.run_folder);  // may have changed since the start
  if (config_.run_folder.empty())
  {
    *message = "no ~run_folder set";
    return false;
  }
  const std::string dir = io::expandHome(config_.run_folder);
  try
  {
    if (!io::makeDirectories(dir))
      throw std::runtime_error(dir + ": cannot create the folder (" + std::strerror(errno) + ")");
    // What slam_bag writes, the run smoothed at its end and timing.json included.
    io::writeFilesAtomic(
        record_.folder(dir, *pipeline_, static_cast<int>(sweeps_), static_cast<int>(updates_), smoothed));
  }
  catch (const std::exception& e)
  {
    *message = e.what();
    return false;
  }
  *message = "wrote the run folder " + dir + " (" + std::to_string(record_.updates()) + " updates)";
  return true;
}

bool FastSlamRos::onSaveRun(std_srvs::Trigger::Request& /*req*/, std_srvs::Trigger::Response& res)
{
  {
    bool same = false;
    const core::SmoothedRun smoothed = smoothBesideFilter(&same);
    std::lock_guard<std::mutex> lock(mutex_);
    res.success = writeRunFolder(&res.message, same ? &smoothed : nullptr);
  }
  releaseFreedMemory();
  if (res.success)
    ROS_INFO("%s: %s", name_.c_str(), res.message.c_str());
  else
    ROS_ERROR("%s: save_run: %s", name_.c_str(), res.message.c_str());
  return true;
}

void FastSlamRos::onOdometry(const nav_msgs::Odometry::ConstPtr& msg)
{
  std::lock_guard<std::mutex> lock(mutex_);
  const auto& p = msg->pose.pose;
  const std::string bad = quaternionProblem(p.orientation);
  if (!bad.empty())
  {
    const std::string so_far = dropped_.add("odometry orientation " + bad);
    ROS_WARN_THROTTLE(5.0, "%s: odometry stamped %.3f: orientation %s; dropped (%s)", name_.c_str(),
                      msg->header.stamp.toSec(), bad.c_str(), so_far.c_str());
    return;
  }
  const core::StampVerdict v = pipeline_->addOdometry(
      msg->header.stamp.toSec(), planarPose(p), clockForStamps());
  report(v, "odometry", msg->header.stamp);
  saveEndedMaps();
  processPending();
}

void FastSlamRos::onTrunks(const rbpf_slam::TrunkArray::ConstPtr& msg)
{
  std::lock_guard<std::mutex> lock(mutex_);
  core::TrunkSweep sweep;
  if (!toSweep(*msg, &sweep))
    return;
  const std::size_t dropped_before = pipeline_->droppedPending();
  const core::StampVerdict v = pipeline_->addTrunks(std::move(sweep), clockForStamps(),
                                                    ros::WallTime::now().toSec());
  report(v, "trunks", msg->header.stamp);
  if (v == core::StampVerdict::kAccept || v == core::StampVerdict::kReset)
    ++sweeps_;
  saveEndedMaps();
  if (pipeline_->droppedPending() > dropped_before)  // no odometry at all: the waiting arrays do not grow without bound
    ROS_WARN_THROTTLE(5.0, "%s: %zu trunk arrays wait for odometry on %s; dropping the oldest", name_.c_str(),
                      pipeline_->pending(), odom_sub_.getTopic().c_str());
  processPending();
}

bool FastSlamRos::toSweep(const rbpf_slam::TrunkArray& msg, core::TrunkSweep* sweep)
{
  core::Pose2 sensor;
  if (!sensorPose(msg.header.frame_id, &sensor))
    return false;
  const std::size_t bad = toTrunkSweep(msg, sensor, sensor_height_, sweep);
  if (bad > 0 && sweep->trunks.empty())
  {
    const std::string so_far = dropped_.add("trunk arrays with no readable trunk");
    ROS_WARN_THROTTLE(5.0, "%s: all %zu trunks of the array at %.3f have a centre, radius or covariance that is not "
                      "finite or out of range (a negative radius or variance, no covariance); the array is dropped "
                      "(not a look that saw no tree); messages: %s", name_.c_str(), bad, msg.header.stamp.toSec(),
                      so_far.c_str());
    return false;
  }
  if (bad > 0)
    ROS_WARN_THROTTLE(5.0, "%s: %zu trunks with a centre, radius or covariance not finite or out of range (a "
                      "negative radius or variance, no covariance) in the array at %.3f; dropped (the others are "
                      "used; no tree counts as missed in this array)", name_.c_str(), bad, msg.header.stamp.toSec());
  return true;
}

void FastSlamRos::report(core::StampVerdict verdict, const char* stream, const ros::Time& stamp)
{
  if (verdict == core::StampVerdict::kAccept)
    return;
  if (verdict == core::StampVerdict::kReset)
  {
    ROS_WARN("%s: %s stamped %.3f, more than ~time_jump_threshold %.2f s before the previous one: time jumped back; "
             "the filter restarts with a new map (the clock went back, or %d messages agreed; restart %d, after %zu "
             "updates)", name_.c_str(), stream, stamp.toSec(), config_.time_jump_threshold,
             core::TimelineGate::kJumpConfirmations, pipeline_->restarts(), updates_);
    return;
  }
  const char* why = verdict == core::StampVerdict::kInvalid ? "stamp or pose not finite" : core::stampVerdictName(verdict);
  const std::string so_far = dropped_.add(std::string(stream) + " " + why);
  if (warned_verdicts_.insert(static_cast<int>(verdict)).second)  // the first of each kind always, then every 5 s
    ROS_WARN("%s: %s stamped %.3f: %s; dropped (messages: %s)", name_.c_str(), stream, stamp.toSec(), why,
             so_far.c_str());
  else
    ROS_WARN_THROTTLE(5.0, "%s: %s stamped %.3f: %s; dropped (messages: %s)", name_.c_str(), stream, stamp.toSec(),
                      why, so_far.c_str());
}

void FastSlamRos::onTimer(const ros::WallTimerEvent& /*event*/)
{
  std::lock_guard<std::mutex> lock(mutex_);
  processPending();
}

void FastSlamRos::processPending()
{
  std::vector<core::PipelineUpdate> done;
  try
  {
    done = pipeline_->process(ros::WallTime::now().toSec());
  }
  catch (const std::exception& e)
  {
    ROS_ERROR_THROTTLE(5.0, "%s: update failed: %s", name_.c_str(), e.what());
    return;
  }
  for (const core::PipelineUpdate& u : done)
  {
    if (u.timeline != pipeline_->restarts())
      continue;  // the old timeline's last sweeps, flushed by a restart: its map is gone
    if (u.timeline != published_timeline_)  // the new timeline's first update: the old paths end here
    {
      path_.poses.clear();
      odom_path_.poses.clear();
      published_timeline_ = u.timeline;
    }
    if (!u.odometry_covered)
      ROS_WARN_THROTTLE(5.0, "%s: no odometry up to the trunks at %.3f within %.2f s (newest %.3f); used the newest",
                        name_.c_str(), u.stamp, config_.odom_timeout, pipeline_->odometry().latest());
    record_.addUpdate(u);
    if (u.relocalization.recovered)
      ROS_WARN("%s: tracking was lost (the health warned); the saved map searched again found the robot elsewhere: "
               "the particles moved there", name_.c_str());
    else if (u.relocalization.confirmed)
      ROS_INFO("%s: the saved map searched again (the health warned) found the robot where the estimate is",
               name_.c_str());
    else if (u.relocalization.found)
      ROS_INFO("%s: %s", name_.c_str(), record_.relocalizationSummary().c_str());
    if (!u.localized)
    {
      ROS_INFO_THROTTLE(2.0, "%s: searching the saved map: %s (%.1f m travelled)", name_.c_str(),
                        u.relocalization.reason.c_str(), u.relocalization.travel);
      continue;  // no estimate yet: no map -> odom
    }
    ++updates_;
    publishLoop(u);
    if (u.stats.map_full > 0)
      ROS_WARN_THROTTLE(10.0, "%s: the map holds max_landmarks (%d) landmarks: %d observations made no new landmark",
                        name_.c_str(), pipeline_->filter().config().max_landmarks, u.stats.map_full);
    if (pipeline_->gnssFixesRejected() > gnss_rejected_said_)
    {
      ROS_WARN_THROTTLE(10.0, "%s: %d satellite fixes so far were inconsistent with the anchor and the filter's pose "
                        "(beyond the innovation gate) and were not used", name_.c_str(),
                        pipeline_->gnssFixesRejected());
      gnss_rejected_said_ = pipeline_->gnssFixesRejected();
    }
    if (pipeline_->gnssAnchorOutliers() > gnss_outliers_said_)
    {
      ROS_WARN_THROTTLE(10.0, "%s: %d satellite fixes lie far from where the others put the map (a receiver's "
                        "fault?) and were left out of the map's anchor on the earth", name_.c_str(),
                        pipeline_->gnssAnchorOutliers());
      gnss_outliers_said_ = pipeline_->gnssAnchorOutliers();
    }
    ROS_DEBUG("%s: %d observations, %d matched, %d new, Neff %.1f%s", name_.c_str(), u.stats.observations,
              u.stats.matched, u.stats.created, u.stats.neff, u.stats.resampled ? ", resampled" : "");
    publishHealth(u);
    publish(ros::Time(u.stamp), u.odometry, u.estimate, u.covariance);
  }
}

void FastSlamRos::publishLoop(const core::PipelineUpdate& u)
{
  if (u.loop.kind == core::LoopEvent::Kind::kNone)
    return;
  if (u.loop.kind == core::LoopEvent::Kind::kClosed)
    ROS_INFO("%s: loop found at %.3f s closed at %.3f s: %d trees matched, the smoothed path moved the robot by %.2f m "
             "(solve %.3f s beside the filter, %d keyframes)", name_.c_str(), u.loop.found, u.stamp, u.loop.matched,
             u.loop.shift, u.loop.seconds, u.loop.keyframes);
  else
    ROS_WARN("%s: a loop found at %.3f s (%d trees matched) was refused: %s", name_.c_str(), u.loop.found,
             u.loop.matched, u.loop.reason.c_str());
  loop_markers_.markers.push_back(
      loopMarker(ros::Time(u.stamp), config_.map_frame, u.loop, static_cast<int>(loop_markers_.markers.size())));
  loops_pub_.publish(loop_markers_);
}

void FastSlamRos::publishHealth(const core::PipelineUpdate& u)
{
  const core::HealthStatus& h = u.health;
  if (h.level != last_level_)
  {
    if (h.level == core::HealthLevel::kWarn)
      ROS_WARN("%s: %s", name_.c_str(), h.message.c_str());
    else
      ROS_INFO("%s: health back to %s", name_.c_str(), h.message.c_str());
  }
  else if (h.level == core::HealthLevel::kWarn)
    ROS_WARN_THROTTLE(10.0, "%s: %s", name_.c_str(), h.message.c_str());
  const bool changed = h.level != last_level_;
  last_level_ = h.level;
  if (!changed && last_diagnostics_ >= 0.0 && u.stamp - last_diagnostics_ < 1.0 && u.stamp >= last_diagnostics_)
    return;
  last_diagnostics_ = u.stamp;
  diagnostic_msgs::DiagnosticArray array;
  array.header.stamp = ros::Time(u.stamp);
  diagnostic_msgs::DiagnosticStatus s;
  s.name = name_ + ": FastSLAM";
  s.hardware_id = config_.map_frame;
  s.level = h.level == core::HealthLevel::kWarn ? diagnostic_msgs::DiagnosticStatus::WARN
                                                : diagnostic_msgs::DiagnosticStatus::OK;
  s.message = h.message;
  const auto kv = [&s](const std::string& key, const std::string& value) {
    diagnostic_msgs::KeyValue k;
    k.key = key;
    k.value = value;
    s.values.push_back(k);
  };
  const auto num = [](double v) {
    char b[32];
    std::snprintf(b, sizeof(b), "%.3g", v);
    return std::string(b);
  };
  kv("cause", core::toString(h.cause));
  kv("updates in window", std::to_string(h.updates));
  kv("mean Neff / N", num(h.neff_ratio));
  kv("resampled share", num(h.resampled_share));
  kv("observations", std::to_string(h.observations));
  kv("matched to confirmed landmarks", num(h.matched_confirmed_share));
  kv("new landmarks", std::to_string(h.created));
  kv("re-created where deleted", std::to_string(h.recreated));
  kv("deleted", std::to_string(h.deleted));
  kv("relocalizing share", num(h.relocalizing_share));
  kv("pose spread [m]", num(h.pose_spread));
  kv("mean squared Mahalanobis distance of the matches", num(h.mean_nis));
  kv("landmarks", std::to_string(u.stats.landmarks));
  array.status.push_back(s);
  diagnostics_pub_.publish(array);
}

bool FastSlamRos::sensorPose(const std::string& frame, core::Pose2* pose)
{
  if (have_sensor_pose_ && frame == sensor_frame_)
  {
    *pose = sensor_pose_;
    return true;
  }
  geometry_msgs::TransformStamped t;
  try
  {
    t = tf_buffer_->lookupTransform(config_.base_frame, frame, ros::Time(0));
  }
  catch (const tf2::TransformException& e)
  {
    ROS_WARN_THROTTLE(5.0, "%s: no transform %s -> %s (%s); skipping the trunks", name_.c_str(), frame.c_str(),
                      config_.base_frame.c_str(), e.what());
    return false;
  }
  // The planar part: the trunks are levelled in the sensor frame, so x, y and the heading matter, and the
  // height for the lever arm of a tilted body.
  sensor_pose_ = core::Pose2(t.transform.translation.x, t.transform.translation.y, yawOf(t.transform.rotation));
  sensor_height_ = t.transform.translation.z;
  sensor_frame_ = frame;
  have_sensor_pose_ = true;
  *pose = sensor_pose_;
  return true;
}

void FastSlamRos::publishScope(const ros::Time& stamp)
{
  if (scope_pub_.getNumSubscribers() > 0)
    scope_pub_.publish(visualization_msgs::Marker::ConstPtr(
        scopeMarker(stamp, config_.base_frame, pipeline_->filter().scope(), sensor_pose_)));
}

void FastSlamRos::publish(const ros::Time& stamp, const core::Pose2& odom_pose, const core::Pose2& estimate,
                          const Eigen::Matrix3d& covariance)
{
  const core::FastSlam& filter = pipeline_->filter();
  const core::Particle& best = filter.best();
  // The pipeline's estimate: the latest smoothing of the run carried on by the filter's motion since (with loop
  // closure), else the filter's (the weighted mean, or the best particle chosen before resampling) at an update,
  // followed by the odometry from it at a sweep that waited for a new view; never the first of an equal-weight set,
  // so that the pose and map -> odom do not jump at a resampling.
  publishScope(stamp);

  if (config_.publish_tf && tf_guard_.owned())
    tf_broadcaster_.sendTransform(planarTransform(stamp + ros::Duration(config_.transform_tolerance),
                                                  config_.map_frame, config_.odom_frame,
                                                  estimate * odom_pose.inverse()));

  pose_pub_.publish(boost::make_shared<geometry_msgs::PoseWithCovarianceStamped>(
      poseWithCovariance(stamp, config_.map_frame, estimate, covariance)));
  if (particles_pub_.getNumSubscribers() > 0)
    particles_pub_.publish(
        boost::make_shared<geometry_msgs::PoseArray>(particleCloud(stamp, config_.map_frame, filter.particles())));
  appendToPath(&path_, stamp, config_.map_frame, estimate, config_.max_path_poses);
  if (path_pub_.getNumSubscribers() > 0)
    path_pub_.publish(boost::make_shared<nav_msgs::Path>(path_));
  appendToPath(&odom_path_, stamp, config_.map_frame, odom_pose, config_.max_path_poses);
  if (odom_path_pub_.getNumSubscribers() > 0)
    odom_path_pub_.publish(boost::make_shared<nav_msgs::Path>(odom_path_));

  landmark_array_pub_.publish(rbpf_slam::TrunkArray::ConstPtr(toLandmarkArray(stamp, config_.map_frame, best.map)));
  if (!session_->saved().trees.empty() && change_markers_pub_.getNumSubscribers() > 0)
    change_markers_pub_.publish(visualization_msgs::MarkerArray::ConstPtr(
        changeMarkers(stamp, config_.map_frame, session_->changes(filter.bestTrees()))));
  if (landmarks_pub_.getNumSubscribers() > 0)
    landmarks_pub_.publish(
        visualization_msgs::MarkerArray::ConstPtr(landmarkMarkers(stamp, config_.map_frame, best.map)));
}

bool FastSlamRos::onSave(const std::string& key, const std::string& fallback, bool with_report,
                         std_srvs::Trigger::Response& res)
{
  {
    bool same = false;
    const core::SmoothedRun smoothed = smoothBesideFilter(&same);
    std::lock_guard<std::mutex> lock(mutex_);
    std::string path = fallback;
    pnh_.getParam(key, path);  // may have changed since the start
    res.success = writeMap(path, with_report, &res.message, same ? &smoothed : nullptr);
  }
  releaseFreedMemory();
  if (res.success)
    ROS_INFO("%s: %s", name_.c_str(), res.message.c_str());
  else
    ROS_ERROR("%s: %s: %s", name_.c_str(), with_report ? "save_map" : "save_inventory", res.message.c_str());
  return true;
}

void FastSlamRos::onFix(const sensor_msgs::NavSatFix::ConstPtr& msg)
{
  std::lock_guard<std::mutex> lock(mutex_);
  if (msg->status.status < sensor_msgs::NavSatStatus::STATUS_FIX)
    return;  // an outage: the receiver says so; nothing to use
  if (msg->header.frame_id != gps_frame_)
  {
    // The antenna on base_link from TF; at base_link itself when the fix names no frame or TF does not know it.
    gps_antenna_.setZero();
    if (!msg->header.frame_id.empty() && msg->header.frame_id != config_.base_frame)
    {
      try
      {
        const auto t = tf_buffer_->lookupTransform(config_.base_frame, msg->header.frame_id, ros::Time(0));
        gps_antenna_ = Eigen::Vector2d(t.transform.translation.x, t.transform.translation.y);
      }
      catch (const tf2::TransformException& e)
      {
        ROS_WARN_THROTTLE(10.0, "%s: no transform %s -> %s (%s); the fix is not used until there is", name_.c_str(),
                          msg->header.frame_id.c_str(), config_.base_frame.c_str(), e.what());
        return;
      }
    }
    gps_frame_ = msg->header.frame_id;
  }
  const std::string why = pipeline_->addFix(toGnssFix(*msg, kUnknownGpsSigma), gps_antenna_);
  if (!why.empty())
    ROS_WARN_THROTTLE(10.0, "%s: fix at %.3f dropped: %s", name_.c_str(), msg->header.stamp.toSec(), why.c_str());
}

void FastSlamRos::saveEndedMaps()
{
  std::string path = config_.map_path;
  pnh_.getParam("map_path", path);
  const std::string target = io::expandHome(path);
  for (const io::MapFile& f : session_->endedMapFiles(target))
  {
    try
    {
      const std::size_t slash = target.rfind('/');
      if (slash != std::string::npos && !io::makeDirectories(target.substr(0, slash)))
        throw std::runtime_error("cannot create the directory of " + target + ": " + std::strerror(errno));
      io::writeFileAtomic(f.path, f.content);
      ROS_WARN("%s: the map before restart %d (%zu trees) is saved to %s", name_.c_str(), f.restart, f.trees,
               f.path.c_str());
    }
    catch (const std::exception& e)
    {
      ROS_ERROR("%s: the map before restart %d (%zu trees) could not be saved to %s: %s", name_.c_str(), f.restart,
                f.trees, f.path.c_str(), e.what());
    }
  }
}

bool FastSlamRos::writeMap(const std::string& path, bool with_report, std::string* message,
                           const core::SmoothedRun* smoothed)
{
  const std::string target = io::expandHome(path);
  const std::size_t slash = target.rfind('/');
  try
  {
    if (slash != std::string::npos && !io::makeDirectories(target.substr(0, slash)))
      throw std::runtime_error("cannot create the directory of " + target + ": " + std::strerror(errno));
    if (with_report && pipeline_->localized())
    {
      io::writeFilesAtomic(session_->mapFiles(target, message, smoothed));
      return true;
    }
    // The inventory: the tree table (and the anchor) alone.
    io::ForestMap inventory = session_->currentMap(smoothed);
    inventory.viewpoints.clear();
    io::writeForestMap(target, inventory);
    *message = std::to_string(inventory.trees.size()) + " trees written to " + target;
  }
  catch (const std::exception& e)
  {
    *message = e.what();
    return false;
  }
  return true;
}

}  // namespace rbpf_slam
