// The offline runner for bags, for both filters: the same core classes as the nodelets, as fast as they
// compute (no roscore, no real-time wait). Reads only the sensor topics named here and /tf_static: never
// the truth.
//
//   rosrun rbpf_slam slam_bag --filter fastslam --bag FILE [--points /points | --scan /scan | --landmarks TOPIC]
//       [--odom /odom]
//       [--base-frame base_link] [--extraction-config YAML] [--config YAML] [--particles N] [--seed S]
//       [--method circle|centroid] [--out DIR] [--quiet]
//   rosrun rbpf_slam slam_bag --filter grid --bag FILE [--scan /scan] [--odom /odom] [--base-frame base_link]
//       [--particles N] [--seed S] [--config config/grid_slam.yaml] [--resampling low_variance|multinomial]
//       [--every-scan] [--wheels /wheel_ticks [--wheel-radius 0.127] [--track 0.7283] [--imu /imu/data --imu-weight W]]
//       [--out DIR] [--quiet]
//
// --config is the filter's YAML (config/fastslam.yaml or config/grid_slam.yaml layout; repeated, each file overrides
// the ones before it, e.g. config/fastslam.yaml then an odometry class of config/odometry/), --extraction-config the
// trunk extraction's (config/trunk_extraction.yaml layout); one pair per sensor type, e.g. config/lego/;
// --particles, --seed, --method and --every-scan override them (--every-scan: grid SLAM processes every scan, its
// travel thresholds linear_update, angular_update and temporal_update all 0, whatever the files say; for benchmarks).
// FastSLAM reads point clouds, or 2D scans when --scan is given, or the detections of any landmark detector
// (rbpf_slam/TrunkArray in the sensor frame) when --landmarks is given.
//
// Every output file is written at the end, atomically (to a temporary, then renamed): a run that fails or is
// interrupted (SIGINT, SIGTERM, SIGHUP) leaves no output behind. Messages whose stamps go back by more than a second
// restart the filter (a looped bag), as the nodes do; unreadable messages are dropped and counted.
//
// Both write DIR/timing.json (processing seconds; evaluate_bag_run reads it). fastslam writes DIR/estimate.tum (the
// online estimate after each update, as the node publishes it), DIR/estimate_best_history.tum (the final best
// particle's own trajectory), DIR/odometry.tum (TUM: t x y z qx qy qz qw; evo reads them), DIR/updates.csv (per
// update: Neff, resampled, landmarks, observations, matched, new, deleted) and DIR/map.csv; grid writes DIR/estimate.tum and DIR/odometry.tum (one pose per scan), DIR/odometry_all.tum
// (every odometry pose), DIR/map.yaml + DIR/map.pgm (map_server layout) and DIR/timing.txt; its timing files also
// hold the maps' memory (distinct tiles, MB, the best map's area, MB per particle per 1000 m^2).
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <csignal>
#include <limits>
#include <map>
#include <memory>
#include <sstream>

#include <sys/stat.h>
#include <unistd.h>

#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/JointState.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/NavSatFix.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_msgs/TFMessage.h>

#ifndef RBPF_SLAM_BAG_GRID_ONLY
#include <pcl/console/print.h>
#endif

#include "rbpf_slam/core/grid/grid_slam_pipeline.h"
#include "rbpf_slam/core/filter/odometry_buffer.h"
#include "rbpf_slam/core/filter/skid_steer_odometry.h"
#include "rbpf_slam/core/filter/stamp_gate.h"
#ifndef RBPF_SLAM_BAG_GRID_ONLY
#include "rbpf_slam/core/fastslam/trunk_slam_pipeline.h"
#endif
#include "rbpf_slam/io/grid_slam_config.h"
#include "rbpf_slam/io/map_image_file.h"
#include "rbpf_slam/io/param_source.h"
#include "rbpf_slam/io/files.h"
#include "rbpf_slam/io/tum_file.h"
#include "rbpf_slam/TrunkArray.h"
#ifndef RBPF_SLAM_BAG_GRID_ONLY
#include "rbpf_slam/io/fastslam_config.h"
#include "rbpf_slam/io/forest_map_file.h"
#include "rbpf_slam/io/map_session.h"
#include "rbpf_slam/io/run_output.h"
#include "rbpf_slam/io/trunk_detector_config.h"
#include "rbpf_slam/ros/cloud_conversions.h"
#include "rbpf_slam/ros/fastslam_node.h"
#include "rbpf_slam/ros/gnss_conversions.h"
#endif
#include "rbpf_slam/ros/pose_msgs.h"
#include "rbpf_slam/ros/scan_conversions.h"

using namespace rbpf_slam;

namespace
{

struct Options
{
  std::string filter = "fastslam";
  std::string bag_path, points_topic = "/points", scan_topic = "/scan", odom_topic = "/odom";
  std::string base_frame = "base_link", out_dir, method, extraction_config_path, resampling;
  std::vector<std::string> config_paths;  // the filter's YAML files, each overriding the ones before
  bool scan_given = false;  // fastslam: 2D scans instead of point clouds
  std::string landmarks_topic;  // fastslam: a detector's TrunkArrays instead of clouds or scans
  std::string map_path, save_map_path;  // fastslam: the tree map to start from, the tree map to write
  double initial_x = 0.0, initial_y = 0.0, initial_yaw = 0.0;  // fastslam: base_link in that map at the start
  bool initial_given = false;
  std::string wheels_topic, imu_topic = "/imu/data";
  std::string gps_topic = "/gps/fix";  // fastslam: satellite fixes, used when the bag has them
  bool gps_given = false, no_gps = false;
  int particles = -1;  // the filter's default
  long seed = -1;  // the configuration's (0 by default)
  bool quiet = false;
  bool odometry_only = false;  // grid: a bag without scans (wheel odometry, with and without the gyro)
  bool every_scan = false;  // grid: travel thresholds off (every scan processed), over the config files
  double wheel_radius = 0.127, track = 0.7283, imu_weight = 0.0;
};

void usage(const char* argv0)
{
  std::fprintf(stderr,
               "usage: %s [--filter fastslam|grid] --bag FILE [--odom TOPIC] [--base-frame FRAME] [--particles N]\n"
               "          [--seed S] [--out DIR] [--quiet]\n"
               "          [--config YAML (the filter's; given again, e.g. an odometry class of config/odometry/, it\n"
               "           overrides the files before it)]\n"
               "  fastslam: [--points TOPIC | --scan TOPIC | --landmarks TOPIC (rbpf_slam/TrunkArray, sensor frame)]\n"
               "            [--extraction-config YAML] [--method circle|centroid]\n"
               "            [--map FILE (a tree map to start from; its frame is the map frame) [--initial-pose X Y\n"
               "             YAW_DEG (base_link in that map at the first update; without it the start is searched\n"
               "             from the trunks seen)]] [--save-map FILE.csv (+ FILE.geojson when anchored; with --map,\n"
               "             the felled, new and changed trees since that map in FILE_changes.csv (+ .geojson))]\n"
               "            [--gps TOPIC (sensor_msgs/NavSatFix; default /gps/fix, used when the bag\n"
               "             has it: the map's anchor on the earth and a weak prior on the pose) | --no-gps]\n"
               "  grid:     [--scan TOPIC] [--resampling low_variance|multinomial]\n"
               "            [--every-scan (process every scan: linear_update, angular_update and temporal_update\n"
               "             set to 0 over any --config; the defaults are 1 m, 0.5 rad, off; for benchmarks)]\n"
               "            [--wheels TOPIC [--wheel-radius M] [--track M] [--imu TOPIC] [--imu-weight W]]\n"
               "            [--odometry-only (a bag without scans: the odometry outputs only)]\n"
               "Runs a SLAM filter on a bag offline (fastslam: trunk extraction + FastSLAM on point clouds; grid:\n"
               "occupancy-grid SLAM on laser scans); writes DIR/estimate.tum, DIR/odometry.tum and the map.\n"
               "examples: %s --bag paper1.bag --out results/paper1\n"
               "          %s --filter grid --bag intel.bag --particles 30 --out results/intel\n",
               argv0, argv0, argv0);
}

/** @brief The transform base_frame -> child on /tf_static (planar part), if present. */
bool staticMount(rosbag::Bag& bag, const std::string& base_frame, const std::string& child, core::SensorMount* mount)
{
  if (child == base_frame)
    return true;
  bool found = false;
  rosbag::View statics(bag, rosbag::TopicQuery("/tf_static"));
  for (const auto& m : statics)
  {
    const auto tf = m.instantiate<tf2_msgs::TFMessage>();
    if (!tf)
      continue;
    for (const auto& t : tf->transforms)
      if (t.header.frame_id == base_frame && t.child_frame_id == child)
      {
        mount->x = t.transform.translation.x;
        mount->y = t.transform.translation.y;
        mount->z = t.transform.translation.z;
        mount->yaw = yawOf(t.transform.rotation);
        found = true;
      }
  }
  return found;
}

volatile std::sig_atomic_t g_signal = 0;
void onSignal(int signum) { g_signal = signum; }

/** @brief Throws when SIGINT, SIGTERM or SIGHUP arrived: nothing has been written yet, and nothing will be. */
void checkInterrupted()
{
  if (g_signal != 0)
    throw std::runtime_error("interrupted by signal " + std::to_string(static_cast<int>(g_signal)) +
                             "; no output written");
}

/** @brief Fails early (before a long run) when the output folder cannot be made or written. */
void checkOutputDir(const std::string& dir)
{
  if (dir.empty())
    return;
  struct stat st;
  std::string probe = dir;
  while (::stat(probe.c_str(), &st) != 0)
  {
    const std::size_t slash = probe.find_last_of('/');
    probe = slash == std::string::npos ? "." : slash == 0 ? "/" : probe.substr(0, slash);
  }
  if (!S_ISDIR(st.st_mode))
    throw std::runtime_error(probe + ": not a folder (--out " + dir + ")");
  if (::access(probe.c_str(), W_OK | X_OK) != 0)
    throw std::runtime_error(probe + ": cannot write in this folder (--out " + dir + ")");
}

/** @brief The run's output files, held until the run completes, then written at once, atomically. */
class Outputs
{
public:
  explicit Outputs(std::string dir) : dir_(std::move(dir)) {}
  bool enabled() const { return !dir_.empty(); }
  std::ostringstream& stream(const std::string& name)
  {
    auto& s = streams_[name];
    if (!s)
    {
      s.reset(new std::ostringstream);
      s->precision(12);
      order_.push_back(name);
    }
    return *s;
  }
  void add(const std::string& path, const std::string& content) { extra_.emplace_back(path, content); }
  const std::string& dir() const { return dir_; }
  void commit()
  {
    if (!enabled() && extra_.empty())
      return;
    checkInterrupted();
    if (enabled() && !io::makeDirectories(dir_))
      throw std::runtime_error(dir_ + ": cannot create the folder (" + std::strerror(errno) + ")");
    std::vector<io::FileContent> files = extra_;
    for (const auto& name : order_)
      files.emplace_back(dir_ + "/" + name, streams_[name]->str());
    io::writeFilesAtomic(files);
  }

private:
  std::string dir_;
  std::map<std::string, std::unique_ptr<std::ostringstream>> streams_;
  std::vector<std::string> order_;
  std::vector<io::FileContent> extra_;
};

/** @brief Opens a bag for reading; the error names the file. */
void openBag(const std::string& path, rosbag::Bag* bag)
{
  try
  {
    bag->open(path, rosbag::bagmode::Read);
  }
  catch (const rosbag::BagException& e)
  {
    throw std::runtime_error(path + ": not a readable bag (" + e.what() + ")");
  }
}

/** @brief The topics of the bag with their types. */
std::map<std::string, std::string> bagTopics(rosbag::Bag& bag)
{
  std::map<std::string, std::string> topics;
  rosbag::View all(bag);
  for (const rosbag::ConnectionInfo* c : all.getConnections())
    topics[c->topic] = c->datatype;
  return topics;
}

/** @brief Throws, listing what the bag holds, unless @p topic is in it with type @p type. */
void requireTopic(const std::map<std::string, std::string>& topics, const std::string& bag, const std::string& topic,
                  const std::string& type, const char* option)
{
  const auto it = topics.find(topic);
  if (it != topics.end() && it->second == type)
    return;
  std::string list;
  for (const auto& t : topics)
    list += (list.empty() ? "" : ", ") + t.first + " [" + t.second + "]";
  throw std::runtime_error(bag + ": " +
                           (it == topics.end() ? "no topic " + topic : topic + " is " + it->second + ", not " + type) +
                           " (" + option + "); the bag holds: " + (list.empty() ? "nothing" : list));
}

/** @brief Counts dropped messages; the first few are explained on stderr, all of them in the summary. */
class DropLog
{
public:
  void drop(const std::string& topic, double stamp, const std::string& why)
  {
    ++count_;
    ++per_topic_[topic];
    if (count_ <= 5)
      std::fprintf(stderr, "slam_bag: warning: %s at %.3f: %s; dropped%s\n", topic.c_str(), stamp, why.c_str(),
                   count_ == 5 ? " (further drops are only counted)" : "");
  }
  int count() const { return count_; }
  int count(const std::string& topic) const
  {
    const auto it = per_topic_.find(topic);
    return it == per_topic_.end() ? 0 : it->second;
  }

private:
  int count_ = 0;
  std::map<std::string, int> per_topic_;
};

/**
 * @brief What the pipeline made of one message's stamp (its core::TimelineGate, as in the nodes): true when the
 * message was used; a drop is counted, a restart said.
 */
bool admitted(core::StampVerdict v, const std::string& topic, double stamp, DropLog* drops)
{
  if (v == core::StampVerdict::kReset)
  {
    std::fprintf(stderr, "slam_bag: warning: %s at %.3f: time jumped back; the filter restarts (as the node does)\n",
                 topic.c_str(), stamp);
    return true;
  }
  if (v == core::StampVerdict::kAccept)
    return true;
  drops->drop(topic, stamp, v == core::StampVerdict::kInvalid ? "stamp or pose not finite" : core::stampVerdictName(v));
  return false;
}

/** @brief An odometry message's planar pose. */
core::Pose2 odometryPose(const nav_msgs::Odometry& od)
{
  return core::Pose2(od.pose.pose.position.x, od.pose.pose.position.y, yawOf(od.pose.pose.orientation));
}

/**
 * @brief The one bag loop of both filters: every message of @p topics in record order goes to @p feed, then
 * @p process runs with the record time as the clock (so a sensor message waits for odometry exactly as long as
 * the bag says it did); at the end @p process flushes.
 */
void replay(rosbag::Bag& bag, const std::vector<std::string>& topics,
            const std::function<void(const rosbag::MessageInstance&, double clock)>& feed,
            const std::function<void(double clock, bool flush)>& process)
{
  rosbag::View view(bag, rosbag::TopicQuery(topics));
  for (const auto& m : view)
  {
    checkInterrupted();
    const double clock = m.getTime().toSec();
    feed(m, clock);
    process(clock, false);
  }
  process(NAN, true);
}

/** @brief timing.json: the counts and times; @p extra, when given, are further `"key": value` pairs. */
/** @brief This process's peak resident memory [MB] (VmHWM of /proc/self/status); 0 where it cannot be read. */
double peakResidentMegabytes()
{
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.compare(0, 6, "VmHWM:") == 0)
      return std::atof(line.c_str() + 6) / 1024.0;
  return 0.0;
}

std::string timingJson(int sweeps, int updates, double extraction, double filter, int particles, std::uint64_t seed,
                       const std::string& extra = std::string())
{
  std::ostringstream timing;
  timing << "{\"sweeps\": " << sweeps << ", \"updates\": " << updates << ", \"seconds_extraction\": " << extraction
         << ", \"seconds_filter\": " << filter << ", \"particles\": " << particles << ", \"seed\": " << seed
         << (extra.empty() ? "" : ", ") << extra << "}\n";
  return timing.str();
}


/** @brief Reads a YAML file with @p reader (if a path is given); errors name the file, unknown keys are warned. */
template <typename Reader>
void loadYaml(const std::string& path, const Reader& reader)
{
  if (path.empty())
    return;
  const io::YamlParamSource yaml(path);
  try
  {
    reader(yaml);
  }
  catch (const std::exception& e)
  {
    throw std::runtime_error(path + ": " + e.what());
  }
  for (const auto& key : yaml.unusedKeys())
    if (std::find(io::nodeOnlyKeys().begin(), io::nodeOnlyKeys().end(), key) == io::nodeOnlyKeys().end())
      std::fprintf(stderr, "slam_bag: warning: %s: key '%s' is not one of this filter's (misspelt?); ignored\n",
                   path.c_str(), key.c_str());
}

#ifndef RBPF_SLAM_BAG_GRID_ONLY
/** @brief The frame the first message on @p topic names (clouds, scans, trunk arrays). @throws when none does. */
std::string firstFrame(rosbag::Bag& bag, const std::string& bag_path, const std::string& topic)
{
  rosbag::View first(bag, rosbag::TopicQuery(topic));
  for (const auto& m : first)
  {
    std::string frame;
    if (const auto cloud = m.instantiate<sensor_msgs::PointCloud2>())
      frame = cloud->header.frame_id;
    else if (const auto scan = m.instantiate<sensor_msgs::LaserScan>())
      frame = scan->header.frame_id;
    else if (const auto array = m.instantiate<rbpf_slam::TrunkArray>())
      frame = array->header.frame_id;
    if (!frame.empty())
      return frame;
  }
  throw std::runtime_error(bag_path + ": the messages on " + topic + " name no frame");
}
#endif

/** @brief The detector's and the filter's configuration from the files and options, as the node reads them. */
#ifndef RBPF_SLAM_BAG_GRID_ONLY
void readFastSlamConfigs(const Options& o, core::TrunkDetectorConfig* dc, core::FastSlamConfig* fc)
{
  // sensor height 0 (unknown): the pipeline takes the mount's, as the nodelet does
  loadYaml(o.extraction_config_path, [&](const io::ParamSource& p) { io::readTrunkDetectorConfig(p, dc); });
  for (const std::string& path : o.config_paths)
    loadYaml(path, [&](const io::ParamSource& p) { io::readFastSlamConfig(p, fc); });
  if (!o.method.empty() && !core::parseTrunkMethod(o.method, &dc->method))
    throw std::runtime_error("--method must be circle or centroid, not '" + o.method + "'");
  if (o.particles > 0)
    fc->particles = o.particles;
  if (o.seed >= 0)
  {
    fc->seed = static_cast<std::uint64_t>(o.seed);
    dc->seed = static_cast<std::uint64_t>(o.seed);
  }
}

/**
 * @brief The satellite fixes' topic: the bag's --gps topic (default /gps/fix when it is there; "" for none or
 * --no-gps), the antenna on base_link from /tf_static into @p antenna.
 */
std::string gpsSource(const Options& o, rosbag::Bag& bag, const std::map<std::string, std::string>& topics,
                      const core::FastSlamConfig& fc, core::SensorMount* antenna)
{
  if (o.no_gps || !fc.gnss.enabled)
    return "";
  if (o.gps_given)
    requireTopic(topics, o.bag_path, o.gps_topic, "sensor_msgs/NavSatFix", "--gps");
  const auto it = topics.find(o.gps_topic);
  if (it == topics.end() || it->second != "sensor_msgs/NavSatFix")
    return "";
  std::string gps_frame;  // the first fix's (none: the antenna at base_link)
  rosbag::View first(bag, rosbag::TopicQuery(o.gps_topic));
  for (const auto& m : first)
    if (const auto fix = m.instantiate<sensor_msgs::NavSatFix>())
    {
      gps_frame = fix->header.frame_id;
      break;
    }
  if (!gps_frame.empty() && gps_frame != o.base_frame && !staticMount(bag, o.base_frame, gps_frame, antenna))
    std::fprintf(stderr, "slam_bag: warning: no %s -> %s transform on /tf_static: the antenna is taken at %s\n",
                 o.base_frame.c_str(), gps_frame.c_str(), o.base_frame.c_str());
  return o.gps_topic;
}

/** @brief Gives the bag's messages to the FastSLAM pipeline as the node does, counting what it used and dropped. */
struct FastSlamFeed
{
  core::TrunkSlamPipeline* pipeline = nullptr;
  core::SensorMount mount, antenna;
  std::string sensor_frame;
  int sweeps = 0, gps_outages = 0;
  DropLog drops;
  core::PlanarScan planar;
  CloudPoints cloud_points;

  void operator()(const rosbag::MessageInstance& m, double clock)
  {
    if (const auto od = m.instantiate<nav_msgs::Odometry>())
    {
      const std::string bad = quaternionProblem(od->pose.pose.orientation);
      if (!bad.empty())
        return drops.drop(m.getTopic(), od->header.stamp.toSec(), "orientation " + bad);
      admitted(pipeline->addOdometry(od->header.stamp.toSec(), odometryPose(*od), clock), m.getTopic(),
               od->header.stamp.toSec(), &drops);
    }
    else if (const auto scan = m.instantiate<sensor_msgs::LaserScan>())
    {
      const double stamp = scan->header.stamp.toSec();
      const std::string why = toPlanarScan(*scan, &planar);
      if (!why.empty())
        return drops.drop(m.getTopic(), stamp, why);
      // The beams' own times, as the extraction nodelet gives them (TrunkArray.sweep_period).
      if (admitted(pipeline->addScan(stamp, scanPeriod(*scan), planar, mount, clock, clock), m.getTopic(), stamp,
                   &drops))
        ++sweeps;
    }
    else if (const auto cloud = m.instantiate<sensor_msgs::PointCloud2>())
    {
      const double stamp = cloud->header.stamp.toSec();
      const std::string why = readCloud(*cloud, &cloud_points);
      if (!why.empty())
        return drops.drop(m.getTopic(), stamp, why);
      if (admitted(pipeline->addSweep(stamp, cloud_points.sweep_period, cloud_points.points, mount, clock, clock),
                   m.getTopic(), stamp, &drops))
        ++sweeps;
    }
    else if (const auto nav = m.instantiate<sensor_msgs::NavSatFix>())
    {
      if (nav->status.status < sensor_msgs::NavSatStatus::STATUS_FIX)
      {
        ++gps_outages;  // the receiver says it has no fix: an outage, not a bad message
        return;
      }
      const std::string why = pipeline->addFix(toGnssFix(*nav, kUnknownGpsSigma), Eigen::Vector2d(antenna.x, antenna.y));
      if (!why.empty())
        drops.drop(m.getTopic(), nav->header.stamp.toSec(), why);
    }
    else if (const auto array = m.instantiate<rbpf_slam::TrunkArray>())
      feedTrunks(m.getTopic(), *array, clock);
  }

  void feedTrunks(const std::string& topic, const rbpf_slam::TrunkArray& array, double clock)
  {
    const double stamp = array.header.stamp.toSec();
    if (array.header.frame_id != sensor_frame)
      return drops.drop(topic, stamp, "frame '" + array.header.frame_id + "', not the first array's '" + sensor_frame +
                                          "'");
    core::TrunkSweep sweep;
    const std::size_t bad = toTrunkSweep(array, core::Pose2(mount.x, mount.y, mount.yaw), mount.z, &sweep);
    if (bad > 0 && sweep.trunks.empty())
      return drops.drop(topic, stamp, "all " + std::to_string(bad) +
                                          " detections with a non-finite value (not a look that saw no tree)");
    if (bad > 0)
      drops.drop(topic, stamp, std::to_string(bad) + " detections with a non-finite value (left out; no tree counts "
                                                     "as missed in this array)");
    if (admitted(pipeline->addTrunks(std::move(sweep), clock, clock), topic, stamp, &drops))
      ++sweeps;
  }
};

/** @brief What a FastSLAM run did, on stdout. */
void printFastSlamSummary(const Options& o, const core::FastSlamConfig& fc, const core::TrunkSlamPipeline& pipeline,
                          const io::FastSlamMapSession& session, const io::FastSlamRunRecord& record,
                          const FastSlamFeed& feed, const std::string& gps_topic, int updates, int map_full,
                          const std::string& map_summary)
{
  std::printf("slam_bag fastslam: %s: %d clouds, %d filter updates, %d messages dropped (unreadable, stamps going "
              "backwards or not finite), %d restarts (time jumped back)\n",
              o.bag_path.c_str(), feed.sweeps, updates, feed.drops.count(), pipeline.restarts());
  const core::Pose2 estimate = pipeline.localized() ? pipeline.filter().estimate() : core::Pose2(NAN, NAN, NAN);
  std::printf("  final estimate (%s; map frame = %s): %.3f %.3f %.1f deg; "
              "%zu landmarks in the best particle's map\n",
              core::toString(fc.estimate),
              session.fromSavedMap() ? "the frame of the map it started from" : "the odometry frame at the first update",
              estimate.x, estimate.y, estimate.theta * 180.0 / M_PI, pipeline.filter().best().map.size());
  std::printf("  %s\n", record.healthSummary().c_str());
  if (map_full > 0)
    std::printf("  the map reached max_landmarks (%d): %d observations made no new landmark\n", fc.max_landmarks,
                map_full);
  if (!record.relocalizationSummary().empty())
    std::printf("  %s\n", record.relocalizationSummary().c_str());
  if (!record.lostSummary().empty())
    std::printf("  %s\n", record.lostSummary().c_str());
  if (!record.loopSummary().empty())
    std::printf("  %s\n", record.loopSummary().c_str());
  const io::MapAnchor anchor = pipeline.anchor();
  if (!gps_topic.empty())
  {
    if (anchor.valid)
      std::printf("  satellite fixes on %s: %d used, %d without a fix, %d weighed the particles; map anchor (%s): "
                  "latitude %.9f, longitude %.9f, heading of x %.3f deg from east, sigma %.2f m\n",
                  gps_topic.c_str(), pipeline.gnssFixesUsed(), feed.gps_outages, pipeline.gnssFixesWeighed(),
                  session.saved().anchor.valid ? "the saved map's, refined by the fixes" : "fitted to the fixes",
                  anchor.latitude, anchor.longitude, anchor.yaw * 180.0 / M_PI, anchor.sigma);
    else
      std::printf("  satellite fixes on %s: %d used, %d without a fix; no anchor (the fixes spread less than %.1f m "
                  "or number fewer than %d)\n",
                  gps_topic.c_str(), pipeline.gnssFixesUsed(), feed.gps_outages, fc.gnss.anchor_min_spread,
                  fc.gnss.anchor_min_fixes);
    if (pipeline.gnssFixesRejected() > 0)
      std::printf("  %d satellite fixes were inconsistent with the anchor and the filter's pose (beyond the "
                  "innovation gate) and were not used\n",
                  pipeline.gnssFixesRejected());
  }
  if (!map_summary.empty())
    std::printf("  map: %s\n", map_summary.c_str());
  std::printf("  time: extraction %.2f s, filter %.2f s (%.0f clouds/s)\n", pipeline.secondsExtraction(),
              pipeline.secondsFilter(),
              feed.sweeps / std::max(1e-9, pipeline.secondsExtraction() + pipeline.secondsFilter()));
}

int runFastSlam(const Options& o)
{
  rosbag::Bag bag;
  openBag(o.bag_path, &bag);
  const auto topics = bagTopics(bag);
  const bool landmarks = !o.landmarks_topic.empty();
  const std::string sensor_topic = landmarks ? o.landmarks_topic : o.scan_given ? o.scan_topic : o.points_topic;
  requireTopic(topics, o.bag_path, sensor_topic,
               landmarks ? "rbpf_slam/TrunkArray" : o.scan_given ? "sensor_msgs/LaserScan" : "sensor_msgs/PointCloud2",
               landmarks ? "--landmarks" : o.scan_given ? "--scan" : "--points");
  requireTopic(topics, o.bag_path, o.odom_topic, "nav_msgs/Odometry", "--odom");
  core::TrunkDetectorConfig dc;
  core::FastSlamConfig fc;
  readFastSlamConfigs(o, &dc, &fc);
  core::TrunkSlamPipeline pipeline(dc, fc);
  FastSlamFeed feed;
  feed.pipeline = &pipeline;
  feed.sensor_frame = firstFrame(bag, o.bag_path, sensor_topic);
  // The sensor's mount on base_link from /tf_static (the first message names the sensor's frame).
  if (!staticMount(bag, o.base_frame, feed.sensor_frame, &feed.mount))
    throw std::runtime_error(o.bag_path + ": no " + o.base_frame + " -> " + feed.sensor_frame +
                             " transform on /tf_static");
  io::MapStart start;
  start.map_file = o.map_path;
  start.search = !o.initial_given;
  start.start = core::Pose2(o.initial_x, o.initial_y, o.initial_yaw);
  io::FastSlamMapSession session(&pipeline, start, [] { return g_signal != 0; });
  if (!o.quiet && session.fromSavedMap())
    std::printf("slam_bag fastslam: %s\n", session.startDescription().c_str());
  const std::string gps_topic = gpsSource(o, bag, topics, fc, &feed.antenna);

  Outputs out(o.out_dir);
  io::FastSlamRunRecord record;  // the run folder, as the node writes it
  int updates = 0, map_full = 0;
  // The map each restart ended, saved beside this run's (map.restartN.csv in the folder, or beside --save-map).
  const std::string ended_beside = out.enabled() ? o.out_dir + "/map.csv" : o.save_map_path;
  const auto keepEndedMaps = [&]() {
    for (const io::MapFile& f : session.endedMapFiles(ended_beside.empty() ? "map.csv" : ended_beside))
    {
      std::fprintf(stderr, "slam_bag: warning: the map before restart %d holds %zu trees%s%s\n", f.restart, f.trees,
                   ended_beside.empty() ? "; not saved (no --out or --save-map)" : "; saved to ",
                   ended_beside.empty() ? "" : f.path.c_str());
      if (!ended_beside.empty())
        out.add(f.path, f.content);
    }
  };
  const auto process = [&](double clock, bool flush) {
    keepEndedMaps();
    for (const core::PipelineUpdate& u : pipeline.process(clock, flush))
    {
      ++updates;
      map_full += u.stats.map_full;
      record.addUpdate(u);
    }
    keepEndedMaps();
  };
  std::vector<std::string> replayed{ sensor_topic, o.odom_topic };
  if (!gps_topic.empty())
    replayed.push_back(gps_topic);
  replay(bag, replayed, std::ref(feed), process);
  if (feed.sweeps == 0)
    throw std::runtime_error(o.bag_path + ": no usable message on " + sensor_topic + " (" +
                             std::to_string(feed.drops.count()) + " dropped); nothing written");
  if (updates == 0)
    throw std::runtime_error(o.bag_path + ": no filter update (no odometry on " + o.odom_topic +
                             " covers the sensor's messages?); nothing written");
  if (!pipeline.localized())
    throw std::runtime_error(o.bag_path + ": " + record.relocalizationSummary() + "; nothing written");
  std::string map_summary;
  if (!o.save_map_path.empty())
    for (io::FileContent& f : session.mapFiles(o.save_map_path, &map_summary))
      out.add(f.first, f.second);
  if (out.enabled())
  {
    const core::SmoothedRun smoothed = pipeline.smoothed();
    for (const io::FileContent& f : record.files(o.out_dir, pipeline.filter(), &smoothed))
      out.add(f.first, f.second);
    out.stream("timing.json") << timingJson(feed.sweeps, updates, pipeline.secondsExtraction(),
                                            pipeline.secondsFilter(), fc.particles, fc.seed);
  }
  out.commit();
  if (!o.quiet)
    printFastSlamSummary(o, fc, pipeline, session, record, feed, gps_topic, updates, map_full, map_summary);
  return 0;
}

#endif  // RBPF_SLAM_BAG_GRID_ONLY

int runGrid(const Options& o)
{
  rosbag::Bag bag;
  openBag(o.bag_path, &bag);
  const auto topics = bagTopics(bag);
  const bool use_wheels = !o.wheels_topic.empty();
  if (!o.odometry_only)
    requireTopic(topics, o.bag_path, o.scan_topic, "sensor_msgs/LaserScan", "--scan");
  if (use_wheels)
  {
    requireTopic(topics, o.bag_path, o.wheels_topic, "sensor_msgs/JointState", "--wheels");
    if (o.imu_weight > 0.0)
      requireTopic(topics, o.bag_path, o.imu_topic, "sensor_msgs/Imu", "--imu");
  }
  else
    requireTopic(topics, o.bag_path, o.odom_topic, "nav_msgs/Odometry", "--odom");
  core::GridSlamConfig gc;
  for (const std::string& path : o.config_paths)
    loadYaml(path, [&](const io::ParamSource& p) { io::readGridSlamConfig(p, &gc); });
  if (o.particles > 0)
    gc.particles = o.particles;
  if (o.seed >= 0)
    gc.seed = static_cast<std::uint64_t>(o.seed);
  if (!o.resampling.empty() && !core::parseResamplingMethod(o.resampling, &gc.resampling.method))
    throw std::runtime_error("--resampling must be low_variance or multinomial, not '" + o.resampling + "'");
  if (o.every_scan)
    gc.linear_update = gc.angular_update = gc.temporal_update = 0.0;
  core::GridSlamPipeline pipeline(gc);

  // The scanner's mount from /tf_static (the first scan names its frame).
  std::string laser_frame;
  if (!o.odometry_only)
  {
    rosbag::View first(bag, rosbag::TopicQuery(o.scan_topic));
    for (const auto& m : first)
      if (const auto s = m.instantiate<sensor_msgs::LaserScan>())
      {
        laser_frame = s->header.frame_id;
        break;
      }
  }
  core::SensorMount mount;
  if (!laser_frame.empty() && !staticMount(bag, o.base_frame, laser_frame, &mount))
    throw std::runtime_error(o.bag_path + ": no " + o.base_frame + " -> " + laser_frame + " transform on /tf_static");
  const core::Pose2 sensor(mount.x, mount.y, mount.yaw);

  Outputs out(o.out_dir);
  core::SkidSteerConfig sc;
  sc.effective_track = o.track;
  sc.imu_weight = o.imu_weight;
  core::SkidSteerOdometry wheels(sc);
  std::vector<double> last_wheel_angles;

  int scans = 0, processed = 0, resamples = 0;
  bool have_odometry = false;
  DropLog drops;
  long evaluations = 0, vetoed = 0, trusted = 0;
  std::vector<double> processed_stamps;
  const auto addOdometry = [&](double t, const core::Pose2& p, const std::string& topic, double clock) {
    if (!admitted(pipeline.addOdometry(t, p, clock), topic, t, &drops))
      return;
    have_odometry = true;
    if (out.enabled())
      io::writeTumLine(out.stream("odometry_all.tum"), t, p);
  };
  const auto feed = [&](const rosbag::MessageInstance& m, double clock) {
    if (const auto s = m.instantiate<sensor_msgs::LaserScan>())
    {
      const double t = s->header.stamp.toSec();
      core::ScanData scan;
      const std::string why = toScanData(*s, &scan);
      if (!why.empty())
        return drops.drop(m.getTopic(), t, why);
      admitted(pipeline.addScan(t, std::move(scan), sensor, clock, clock), m.getTopic(), t, &drops);
    }
    else if (const auto od = m.instantiate<nav_msgs::Odometry>())
    {
      const std::string bad = quaternionProblem(od->pose.pose.orientation);
      if (!bad.empty())
        return drops.drop(m.getTopic(), od->header.stamp.toSec(), "orientation " + bad);
      addOdometry(od->header.stamp.toSec(), odometryPose(*od), m.getTopic(), clock);
    }
    else if (const auto js = m.instantiate<sensor_msgs::JointState>())
    {
      // ESE 650 layout: FR FL RR RL cumulative wheel angles [rad]; left = mean(FL, RL), right = mean(FR, RR).
      const double t = js->header.stamp.toSec();
      if (js->position.size() < 4)
        return drops.drop(m.getTopic(), t, "fewer than 4 wheel positions");
      if (!last_wheel_angles.empty())
      {
        const auto d = [&](int i) { return (js->position[i] - last_wheel_angles[i]) * o.wheel_radius; };
        if (!wheels.addEncoders(t, 0.5 * (d(1) + d(3)), 0.5 * (d(0) + d(2))))
          return drops.drop(m.getTopic(), t, "wheel angles not finite or stamp not after the previous");
      }
      last_wheel_angles.assign(js->position.begin(), js->position.begin() + 4);
      addOdometry(t, wheels.pose(), m.getTopic(), clock);
    }
    else if (const auto imu = m.instantiate<sensor_msgs::Imu>())
    {
      if (!wheels.addGyro(imu->header.stamp.toSec(), imu->angular_velocity.z))
        drops.drop(m.getTopic(), imu->header.stamp.toSec(), "gyro rate not finite or stamp not after the previous");
    }
  };
  const auto process = [&](double clock, bool flush) {
    // The map each restart ended, saved beside this run's (map.restartN.yaml + .pgm in the folder).
    for (const core::GridTimelineMap& ended : pipeline.takeEndedMaps())
    {
      const std::string name = "map.restart" + std::to_string(ended.timeline + 1) + ".yaml";
      std::fprintf(stderr, "slam_bag: warning: the map before restart %d%s%s\n", ended.timeline + 1,
                   out.enabled() ? " is saved to " : " is not saved (no --out)",
                   out.enabled() ? (o.out_dir + "/" + name).c_str() : "");
      if (out.enabled())
        for (auto& f : io::encodeMapImage(ended.map, o.out_dir + "/" + name))
          out.add(f.first, f.second);
    }
    for (const core::GridPipelineUpdate& u : pipeline.process(clock, flush))
    {
      if (!u.error.empty())
      {
        drops.drop(o.scan_topic, u.stamp, u.error);
        continue;
      }
      ++scans;
      if (u.outage_began)
        std::fprintf(stderr, "slam_bag: warning: the odometry stopped at %.3f s; the scans from %.3f s are left out "
                     "of the map (kept as it is) until it returns\n", pipeline.outage().since, u.stamp);
      if (u.outage_scans > 0)
        std::fprintf(stderr, "slam_bag: warning: the odometry returned at %.3f s after %.3f s; %d scans were left "
                     "out of the map\n", u.stamp, u.outage_seconds, u.outage_scans);
      if (!u.step.skipped)
      {
        ++processed;
        resamples += u.step.resampled ? 1 : 0;
        evaluations += u.step.matcher_evaluations;
        vetoed += u.step.matches_vetoed;
        trusted += u.step.matches_trusted;
        processed_stamps.push_back(u.stamp);
      }
      if (out.enabled())
      {
        io::writeTumLine(out.stream("estimate.tum"), u.stamp, u.estimate);
        io::writeTumLine(out.stream("odometry.tum"), u.stamp, u.odometry);
      }
    }
  };

  std::vector<std::string> read_topics;
  if (!o.odometry_only)
    read_topics.push_back(o.scan_topic);
  if (use_wheels)
  {
    read_topics.push_back(o.wheels_topic);
    if (o.imu_weight > 0.0)
      read_topics.push_back(o.imu_topic);
  }
  else
    read_topics.push_back(o.odom_topic);
  replay(bag, read_topics, feed, process);
  const int resets = pipeline.restarts();
  const core::GridSlam& slam = pipeline.filter();
  const double seconds = pipeline.secondsFilter(), worst = pipeline.worstSeconds();
  const core::GridMapMemory memory = slam.mapMemory();
  if (pipeline.outage().scans > 0)
    std::fprintf(stderr, "slam_bag: warning: the odometry stopped at %.3f s and never returned: the last %.3f s "
                 "(%d scans) were left out of the map\n", pipeline.outage().since,
                 pipeline.outage().last_scan - pipeline.outage().since, pipeline.outage().scans);
  if (!o.odometry_only && scans == 0)
    throw std::runtime_error(o.bag_path + ": no scan of " + o.scan_topic + " was used (" +
                             std::to_string(drops.count()) + " messages dropped; is there odometry on " +
                             (use_wheels ? o.wheels_topic : o.odom_topic) + "?); nothing written");
  if (!have_odometry && scans == 0)
    throw std::runtime_error(o.bag_path + ": no usable odometry; nothing written");

  if (out.enabled())
  {
    if (slam.initialised())
      for (auto& f : io::encodeMapImage(slam.map().toImage(), o.out_dir + "/map.yaml"))
        out.add(f.first, f.second);
    // rbpf mode: the best particle's whole history (its poses as its lineage saw them), one per processed scan -
    // the smoothed trajectory that matches the final map; estimate.tum is the online estimate.
    const std::vector<core::Pose2> history = slam.bestTrajectory();
    if (!history.empty() && resets == 0 && history.size() == processed_stamps.size())
      for (std::size_t i = 0; i < history.size(); ++i)
        io::writeTumLine(out.stream("estimate_best_history.tum"), processed_stamps[i], history[i]);
    out.stream("timing.txt") << "scans " << scans << "\nprocessed " << processed << "\nfilter_seconds " << seconds
                             << "\nms_per_scan " << 1e3 * seconds / std::max(1, scans) << "\nworst_ms " << 1e3 * worst
                             << "\nresamples " << resamples << "\nparticles " << gc.particles << "\nseed " << gc.seed
                             << "\nlinear_update " << gc.linear_update << "\nangular_update " << gc.angular_update
                             << "\ntemporal_update " << gc.temporal_update << "\nmap_tiles " << memory.tiles
                             << "\nmap_mb " << memory.megabytes() << "\nbest_map_area_m2 " << memory.best_area
                             << "\nmb_per_particle_per_1000m2 " << memory.megabytesPerParticlePer1000SquareMetres()
                             << "\npeak_rss_mb " << peakResidentMegabytes() << "\n";
    std::ostringstream extra;
    extra.precision(12);
    extra << "\"linear_update\": " << gc.linear_update << ", \"angular_update\": " << gc.angular_update
          << ", \"temporal_update\": " << gc.temporal_update << ", \"map_tiles\": " << memory.tiles
          << ", \"map_mb\": " << memory.megabytes() << ", \"best_map_area_m2\": " << memory.best_area
          << ", \"mb_per_particle_per_1000m2\": " << memory.megabytesPerParticlePer1000SquareMetres()
          << ", \"peak_rss_mb\": " << peakResidentMegabytes();
    out.stream("timing.json") << timingJson(scans, processed, 0.0, seconds, gc.particles, gc.seed, extra.str());
    out.commit();
  }
  if (!o.quiet)
  {
    char thresholds[160];
    if (o.every_scan)
      std::snprintf(thresholds, sizeof(thresholds), "every scan: --every-scan turned the travel thresholds off");
    else if (gc.temporal_update > 0.0)
      std::snprintf(thresholds, sizeof(thresholds), "the others below the travel thresholds %g m, %g rad, %g s",
                    gc.linear_update, gc.angular_update, gc.temporal_update);
    else
      std::snprintf(thresholds, sizeof(thresholds), "the others below the travel thresholds %g m, %g rad",
                    gc.linear_update, gc.angular_update);
    std::printf("slam_bag grid: %s: %d scans, %d scans dropped (unreadable, stamps going backwards or not finite), "
                "%d messages dropped in all, %d processed (%s), %d resamplings, %d restarts (time jumped back)\n",
                o.bag_path.c_str(), scans, drops.count(o.scan_topic), drops.count(), processed, thresholds, resamples,
                resets);
    const core::Pose2& p = slam.mappingPose();
    std::printf("  final pose (map frame = first scan's odometry pose): %.3f %.3f %.1f deg; %zu map tiles\n", p.x, p.y,
                p.theta * 180.0 / M_PI, slam.map().tileCount());
    std::printf("  filter time %.2f s, %.3f ms per scan (worst %.1f ms), %d particles\n", seconds,
                1e3 * seconds / std::max(1, scans), 1e3 * worst, gc.particles);
    if (slam.initialised())
      std::printf("  map memory: %zu distinct tiles (shared tiles once) in %.2f MB; best map %zu tiles, %.0f m^2; "
                  "%.3f MB per particle per 1000 m^2 of map\n",
                  memory.tiles, memory.megabytes(), memory.best_tiles, memory.best_area,
                  memory.megabytesPerParticlePer1000SquareMetres());
    if (gc.mode == core::GridSlamMode::kRbpf && !o.odometry_only)
      std::printf("  scan matcher: %.1f poses scored per particle and processed scan; matches taken %ld, vetoed by "
                  "the odometry %ld (of %ld)\n",
                  static_cast<double>(evaluations) / std::max(1, processed) / std::max(1, gc.particles), trusted,
                  vetoed, static_cast<long>(processed - 1) * gc.particles);
    if (use_wheels && o.imu_weight > 0.0)
      std::printf("  gyro bias (from standing still) %.5f rad/s\n", wheels.gyroBias());
  }
  return 0;
}
/** @brief The value of option @p name as an integer in [lo, hi]; throws naming the option otherwise. */
long parseInteger(const std::string& name, const char* text, long lo, long hi)
{
  errno = 0;
  char* end = nullptr;
  const long v = std::strtol(text, &end, 10);
  if (errno != 0 || end == text || *end != '\0')
    throw std::invalid_argument(name + " must be an integer, not '" + text + "'");
  if (v < lo || v > hi)
    throw std::invalid_argument(name + " must be in " + std::to_string(lo) + ".." + std::to_string(hi) + ", not " +
                                text);
  return v;
}

/** @brief The value of option @p name as a finite number in [lo, hi]; throws naming the option otherwise. */
double parseNumber(const std::string& name, const char* text, double lo, double hi)
{
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (errno != 0 || end == text || *end != '\0' || !std::isfinite(v))
    throw std::invalid_argument(name + " must be a number, not '" + text + "'");
  if (v < lo || v > hi)
    throw std::invalid_argument(name + " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], not " +
                                text);
  return v;
}
}  // namespace

#ifdef RBPF_SLAM_BAG_GRID_ONLY
/**
 * @brief FastSLAM's runs go to slam_bag_fastslam beside this program (the same source with FastSLAM in): grid SLAM's
 * runs never load FastSLAM's libraries (PCL, Ceres), whose relocated pages alone take about 35 MB of resident memory.
 * Returns only when the exec failed.
 */
int execFastSlamRunner(char** argv)
{
  char self[4096];
  const ssize_t n = readlink("/proc/self/exe", self, sizeof(self) - 1);
  if (n <= 0)
  {
    std::fprintf(stderr, "slam_bag: cannot find its own path (/proc/self/exe): %s\n", std::strerror(errno));
    return 1;
  }
  self[n] = '\0';
  std::string dir(self);
  dir = dir.substr(0, dir.rfind('/'));
  const std::string runner = dir + "/slam_bag_fastslam";
  execv(runner.c_str(), argv);
  std::fprintf(stderr, "slam_bag: cannot run FastSLAM's runner %s: %s\n", runner.c_str(), std::strerror(errno));
  return 1;
}
#endif

int main(int argc, char** argv)
{
#ifdef RBPF_SLAM_BAG_GRID_ONLY
  {
    std::string filter = "fastslam";
    bool help = false;
    for (int i = 1; i < argc; ++i)
    {
      help = help || std::string(argv[i]) == "--help" || std::string(argv[i]) == "-h";
      if (std::string(argv[i]) == "--filter" && i + 1 < argc)
        filter = argv[i + 1];
    }
    if (filter != "grid" && !help)
      return execFastSlamRunner(argv);
  }
#else
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);  // PCL reports every failed RANSAC as an error
#endif
  Options o;
  try
  {
    for (int i = 1; i < argc; ++i)
    {
      const std::string a = argv[i];
      const bool has = i + 1 < argc;
      if (a == "--help" || a == "-h")
      {
        usage(argv[0]);
        return 0;
      }
      if (a == "--quiet")
        o.quiet = true;
      else if (a == "--odometry-only")
        o.odometry_only = true;
      else if (a == "--every-scan")
        o.every_scan = true;
      else if (a == "--no-gps")
        o.no_gps = true;
      else if (a.compare(0, 2, "--") == 0 && !has)
        throw std::invalid_argument(a + " needs a value");
      else if (a == "--filter")
        o.filter = argv[++i];
      else if (a == "--bag")
        o.bag_path = argv[++i];
      else if (a == "--points")
        o.points_topic = argv[++i];
      else if (a == "--scan")
      {
        o.scan_topic = argv[++i];
        o.scan_given = true;
      }
      else if (a == "--landmarks")
        o.landmarks_topic = argv[++i];
      else if (a == "--extraction-config")
        o.extraction_config_path = argv[++i];
      else if (a == "--odom")
        o.odom_topic = argv[++i];
      else if (a == "--base-frame")
        o.base_frame = argv[++i];
      else if (a == "--particles")
        o.particles = static_cast<int>(parseInteger(a, argv[++i], 1, core::FastSlamConfig::kMaxParticles));
      else if (a == "--seed")
        o.seed = parseInteger(a, argv[++i], 0, std::numeric_limits<long>::max());
      else if (a == "--method")
        o.method = argv[++i];
      else if (a == "--config")
        o.config_paths.push_back(argv[++i]);
      else if (a == "--resampling")
        o.resampling = argv[++i];
      else if (a == "--wheels")
        o.wheels_topic = argv[++i];
      else if (a == "--wheel-radius")
        o.wheel_radius = parseNumber(a, argv[++i], 1e-3, 10.0);
      else if (a == "--track")
        o.track = parseNumber(a, argv[++i], 1e-3, 100.0);
      else if (a == "--imu")
        o.imu_topic = argv[++i];
      else if (a == "--imu-weight")
        o.imu_weight = parseNumber(a, argv[++i], 0.0, 1.0);
      else if (a == "--out")
        o.out_dir = argv[++i];
      else if (a == "--map")
        o.map_path = argv[++i];
      else if (a == "--gps")
      {
        o.gps_topic = argv[++i];
        o.gps_given = true;
      }
      else if (a == "--save-map")
        o.save_map_path = argv[++i];
      else if (a == "--changes")
        throw std::invalid_argument("--changes is gone: with --map, --save-map FILE.csv writes the changes since that "
                                    "map beside it (FILE_changes.csv)");
      else if (a == "--initial-pose")
      {
        if (i + 3 >= argc)
          throw std::invalid_argument("--initial-pose needs X Y YAW_DEG");
        o.initial_x = parseNumber(a, argv[++i], -1e7, 1e7);
        o.initial_y = parseNumber(a, argv[++i], -1e7, 1e7);
        o.initial_yaw = parseNumber(a, argv[++i], -360.0, 360.0) * M_PI / 180.0;
        o.initial_given = true;
      }
      else
        throw std::invalid_argument("unknown argument '" + a + "' (--help lists the options)");
    }
    if (o.bag_path.empty())
      throw std::invalid_argument("--bag FILE is required (--help lists the options)");
    if (o.filter != "fastslam" && o.filter != "grid")
      throw std::invalid_argument("--filter must be fastslam or grid, not '" + o.filter + "'");
    if (!o.landmarks_topic.empty() && (o.scan_given || o.filter != "fastslam"))
      throw std::invalid_argument("--landmarks goes with --filter fastslam, without --scan");
    if (o.filter == "fastslam" && o.odometry_only)
      throw std::invalid_argument("--odometry-only goes with --filter grid");
    if (o.filter != "fastslam" && (!o.map_path.empty() || !o.save_map_path.empty()))
      throw std::invalid_argument("--map and --save-map go with --filter fastslam (a grid map is map.yaml + map.pgm)");
    if ((o.gps_given || o.no_gps) && o.filter != "fastslam")
      throw std::invalid_argument("--gps and --no-gps go with --filter fastslam");
    if (o.gps_given && o.no_gps)
      throw std::invalid_argument("--gps TOPIC and --no-gps exclude each other");
    if (o.initial_given && o.map_path.empty())
      throw std::invalid_argument("--initial-pose goes with --map FILE");
    if (o.filter == "fastslam" && o.every_scan)
      throw std::invalid_argument("--every-scan goes with --filter grid");
  }
  catch (const std::invalid_argument& e)
  {
    std::fprintf(stderr, "slam_bag: %s (usage: %s --help)\n", e.what(), argv[0]);
    return 2;
  }
  struct sigaction action;
  std::memset(&action, 0, sizeof(action));
  action.sa_handler = onSignal;
  for (const int signum : { SIGINT, SIGTERM, SIGHUP })
    sigaction(signum, &action, nullptr);
  try
  {
    struct stat st;
    if (::stat(o.bag_path.c_str(), &st) != 0)
      throw std::runtime_error(o.bag_path + ": " + std::strerror(errno));
    if (S_ISDIR(st.st_mode))
      throw std::runtime_error(o.bag_path + ": a folder, not a bag file");
    checkOutputDir(o.out_dir);
    if (!o.save_map_path.empty())
    {
      const std::size_t slash = o.save_map_path.find_last_of('/');
      checkOutputDir(slash == std::string::npos ? "." : o.save_map_path.substr(0, std::max<std::size_t>(slash, 1)));
    }
#ifdef RBPF_SLAM_BAG_GRID_ONLY
    return runGrid(o);
#else
    return o.filter == "grid" ? runGrid(o) : runFastSlam(o);
#endif
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "slam_bag: %s\n", e.what());
    return g_signal != 0 ? 128 + static_cast<int>(g_signal) : 1;
  }
}
