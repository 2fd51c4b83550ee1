#include "rbpf_slam/replay/fastslam_bag_run.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <nav_msgs/Odometry.h>
#include <pcl/console/print.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/NavSatFix.h>
#include <sensor_msgs/PointCloud2.h>

#include "rbpf_slam/TrunkArray.h"
#include "rbpf_slam/core/trunk_slam/trunk_slam_pipeline.h"
#include "rbpf_slam/io/fastslam_config.h"
#include "rbpf_slam/io/map_session.h"
#include "rbpf_slam/io/run_output.h"
#include "rbpf_slam/io/trunk_detector_config.h"
#include "rbpf_slam/ros/cloud_conversions.h"
#include "rbpf_slam/ros/gnss_conversions.h"
#include "rbpf_slam/ros/pose_msgs.h"
#include "rbpf_slam/ros/scan_conversions.h"
#include "rbpf_slam/ros/trunk_conversions.h"

namespace rbpf_slam
{
namespace replay
{
namespace
{
/** @brief The detector's and the filter's configuration from the files and options, as the node reads them. */
void readFastSlamConfigs(const SlamBagOptions& o, core::TrunkDetectorConfig* dc, core::TrunkSlamConfig* fc)
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

/** @brief The sensor's topic, checked with the odometry's for its type in the bag. */
std::string sensorTopic(const SlamBagOptions& o, const std::map<std::string, std::string>& topics)
{
  const bool landmarks = !o.landmarks_topic.empty();
  const std::string topic = landmarks ? o.landmarks_topic : o.scan_given ? o.scan_topic : o.points_topic;
  requireTopic(topics, o.bag_path, topic,
               landmarks ? "rbpf_slam/TrunkArray" : o.scan_given ? "sensor_msgs/LaserScan" : "sensor_msgs/PointCloud2",
               landmarks ? "--landmarks" : o.scan_given ? "--scan" : "--points");
  requireTopic(topics, o.bag_path, o.odom_topic, "nav_msgs/Odometry", "--odom");
  return topic;
}

/**
 * @brief The satellite fixes' topic: the bag's --gps topic (default /gps/fix when it is there; "" for none or
 * --no-gps), the antenna on base_link from /tf_static into @p antenna.
 */
std::string gpsSource(const SlamBagOptions& o, rosbag::Bag& bag, const std::map<std::string, std::string>& topics,
                      const core::TrunkSlamConfig& fc, core::SensorMount* antenna)
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
      feedOdometry(m.getTopic(), *od, clock);
    else if (const auto scan = m.instantiate<sensor_msgs::LaserScan>())
      feedScan(m.getTopic(), *scan, clock);
    else if (const auto cloud = m.instantiate<sensor_msgs::PointCloud2>())
      feedCloud(m.getTopic(), *cloud, clock);
    else if (const auto nav = m.instantiate<sensor_msgs::NavSatFix>())
      feedFix(m.getTopic(), *nav);
    else if (const auto array = m.instantiate<rbpf_slam::TrunkArray>())
      feedTrunks(m.getTopic(), *array, clock);
  }

  void feedOdometry(const std::string& topic, const nav_msgs::Odometry& od, double clock)
  {
    const std::string bad = quaternionProblem(od.pose.pose.orientation);
    if (!bad.empty())
      return drops.drop(topic, od.header.stamp.toSec(), "orientation " + bad);
    admitted(pipeline->addOdometry(od.header.stamp.toSec(), planarPose(od.pose.pose), clock), topic,
             od.header.stamp.toSec(), &drops);
  }

  void feedScan(const std::string& topic, const sensor_msgs::LaserScan& scan, double clock)
  {
    const double stamp = scan.header.stamp.toSec();
    const std::string why = toPlanarScan(scan, &planar);
    if (!why.empty())
      return drops.drop(topic, stamp, why);
    // The beams' own times, as the extraction nodelet gives them (TrunkArray.sweep_period).
    if (admitted(pipeline->addScan(stamp, scanPeriod(scan), planar, mount, clock, clock), topic, stamp, &drops))
      ++sweeps;
  }

  void feedCloud(const std::string& topic, const sensor_msgs::PointCloud2& cloud, double clock)
  {
    const double stamp = cloud.header.stamp.toSec();
    const std::string why = readCloud(cloud, &cloud_points);
    if (!why.empty())
      return drops.drop(topic, stamp, why);
    if (admitted(pipeline->addSweep(stamp, cloud_points.sweep_period, cloud_points.points, mount, clock, clock),
                 topic, stamp, &drops))
      ++sweeps;
  }

  void feedFix(const std::string& topic, const sensor_msgs::NavSatFix& nav)
  {
    if (nav.status.status < sensor_msgs::NavSatStatus::STATUS_FIX)
    {
      ++gps_outages;  // the receiver says it has no fix: an outage, not a bad message
      return;
    }
    const std::string why = pipeline->addFix(toGnssFix(nav, kUnknownGpsSigma), Eigen::Vector2d(antenna.x, antenna.y));
    if (!why.empty())
      drops.drop(topic, nav.header.stamp.toSec(), why);
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
                                          " detections not finite or out of range (a negative radius or variance, "
                                          "no covariance; not a look that saw no tree)");
    if (bad > 0)
      drops.drop(topic, stamp, std::to_string(bad) + " detections not finite or out of range (a negative radius or "
                                                     "variance, no covariance; left out, no tree counts as missed in "
                                                     "this array)");
    if (admitted(pipeline->addTrunks(std::move(sweep), clock, clock), topic, stamp, &drops))
      ++sweeps;
  }
};

/** @brief What a FastSLAM run counted besides its feed. */
struct FastSlamCounts
{
  int updates = 0, map_full = 0;
  std::string gps_topic, map_summary;
};

/** @brief What a FastSLAM run did, on stdout. */
void printGnssSummary(const core::TrunkSlamConfig& fc, const core::TrunkSlamPipeline& pipeline,
                      const io::FastSlamMapSession& session, const FastSlamFeed& feed, const std::string& gps_topic)
{
  const io::MapAnchor anchor = pipeline.anchor();
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
  if (pipeline.gnssAnchorOutliers() > 0)
    std::printf("  %d satellite fixes were left out of the anchor's fit as far from the others (a receiver's fault)\n",
                pipeline.gnssAnchorOutliers());
}

void printFastSlamSummary(const SlamBagOptions& o, const core::TrunkSlamConfig& fc,
                          const core::TrunkSlamPipeline& pipeline, const io::FastSlamMapSession& session,
                          const io::FastSlamRunRecord& record, const FastSlamFeed& feed, const FastSlamCounts& n)
{
  std::printf("slam_bag fastslam: %s: %d clouds, %d filter updates, %d messages dropped (unreadable, stamps going "
              "backwards or not finite), %d restarts (time jumped back)\n",
              o.bag_path.c_str(), feed.sweeps, n.updates, feed.drops.count(), pipeline.restarts());
  const core::Pose2 estimate = pipeline.localized() ? pipeline.filter().estimate() : core::Pose2(NAN, NAN, NAN);
  std::printf("  final estimate (%s; map frame = %s): %.3f %.3f %.1f deg; "
              "%zu landmarks in the best particle's map\n",
              core::toString(fc.estimate),
              session.fromSavedMap() ? "the frame of the map it started from" :
                                       "the odometry frame at the first update",
              estimate.x, estimate.y, estimate.theta * 180.0 / M_PI, pipeline.filter().best().map.size());
  std::printf("  %s\n", record.healthSummary().c_str());
  if (n.map_full > 0)
    std::printf("  the map reached max_landmarks (%d): %d observations made no new landmark\n", fc.max_landmarks,
                n.map_full);
  for (const std::string& summary : { record.relocalizationSummary(), record.lostSummary(), record.loopSummary() })
    if (!summary.empty())
      std::printf("  %s\n", summary.c_str());
  if (!n.gps_topic.empty())
    printGnssSummary(fc, pipeline, session, feed, n.gps_topic);
  if (!n.map_summary.empty())
    std::printf("  map: %s\n", n.map_summary.c_str());
  std::printf("  time: extraction %.2f s, filter %.2f s (%.0f clouds/s)\n", pipeline.secondsExtraction(),
              pipeline.secondsFilter(),
              feed.sweeps / std::max(1e-9, pipeline.secondsExtraction() + pipeline.secondsFilter()));
}

/** @brief Throws when the bag gave the filter nothing to do, or the start in a saved map was never found. */
void checkRan(const SlamBagOptions& o, const std::string& sensor_topic, const core::TrunkSlamPipeline& pipeline,
              const io::FastSlamRunRecord& record, const FastSlamFeed& feed, int updates)
{
  if (feed.sweeps == 0)
    throw std::runtime_error(o.bag_path + ": no usable message on " + sensor_topic + " (" +
                             std::to_string(feed.drops.count()) + " dropped); nothing written");
  if (updates == 0)
    throw std::runtime_error(o.bag_path + ": no filter update (no odometry on " + o.odom_topic +
                             " covers the sensor's messages?); nothing written");
  if (!pipeline.localized())
    throw std::runtime_error(o.bag_path + ": " + record.relocalizationSummary() + "; nothing written");
}
}  // namespace

int runFastSlamBag(const SlamBagOptions& o)
{
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);  // PCL reports every failed RANSAC as an error
  rosbag::Bag bag;
  openBag(o.bag_path, &bag);
  const auto topics = bagTopics(bag);
  const std::string sensor_topic = sensorTopic(o, topics);
  core::TrunkDetectorConfig dc;
  core::TrunkSlamConfig fc;
  readFastSlamConfigs(o, &dc, &fc);
  core::TrunkSlamPipeline pipeline(dc, fc);
  FastSlamFeed feed;
  feed.pipeline = &pipeline;
  feed.sensor_frame = firstFrame(bag, sensor_topic);
  if (feed.sensor_frame.empty())
    throw std::runtime_error(o.bag_path + ": the messages on " + sensor_topic + " name no frame");
  // The sensor's mount on base_link from /tf_static (the first message names the sensor's frame).
  if (!staticMount(bag, o.base_frame, feed.sensor_frame, &feed.mount))
    throw std::runtime_error(o.bag_path + ": no " + o.base_frame + " -> " + feed.sensor_frame +
                             " transform on /tf_static");
  io::MapStart start;
  start.map_file = o.map_path;
  start.search = !o.initial_given;
  start.start = core::Pose2(o.initial_x, o.initial_y, o.initial_yaw);
  io::FastSlamMapSession session(&pipeline, start, [] { return interruption() != 0; });
  if (!o.quiet && session.fromSavedMap())
    std::printf("slam_bag fastslam: %s\n", session.startDescription().c_str());
  FastSlamCounts n;
  n.gps_topic = gpsSource(o, bag, topics, fc, &feed.antenna);

  Outputs out(o.out_dir);
  io::FastSlamRunRecord record;  // the run folder, as the node writes it
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
      ++n.updates;
      n.map_full += u.stats.map_full;
      record.addUpdate(u);
    }
    keepEndedMaps();
  };
  std::vector<std::string> replayed{ sensor_topic, o.odom_topic };
  if (!n.gps_topic.empty())
    replayed.push_back(n.gps_topic);
  replay(bag, replayed, std::ref(feed), process);
  checkRan(o, sensor_topic, pipeline, record, feed, n.updates);
  if (pipeline.shortReachSweeps() > 0)
    std::fprintf(stderr, "slam_bag: warning: in %d of %d clouds %s (--extraction-config)\n",
                 pipeline.shortReachSweeps(), feed.sweeps, pipeline.reachShortfall().c_str());
  if (!o.save_map_path.empty())
    out.add(session.mapFiles(o.save_map_path, &n.map_summary));
  if (out.enabled())
    out.add(record.folder(o.out_dir, pipeline, feed.sweeps, n.updates));
  out.commit();
  if (!o.quiet)
    printFastSlamSummary(o, fc, pipeline, session, record, feed, n);
  return 0;
}

}  // namespace replay
}  // namespace rbpf_slam

/** @brief The entry slam_bag finds in this library when it loads it for a FastSLAM run (kFastSlamRunnerSymbol). */
extern "C" int rbpf_slam_run_fastslam_bag(const rbpf_slam::replay::SlamBagOptions* options)
{
  return rbpf_slam::replay::runFastSlamBag(*options);
}
