#include "rbpf_slam/replay/grid_bag_run.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <nav_msgs/Odometry.h>
#include <rosbag/view.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/JointState.h>
#include <sensor_msgs/LaserScan.h>

#include "rbpf_slam/core/filter/skid_steer_odometry.h"
#include "rbpf_slam/core/grid/grid_slam_pipeline.h"
#include "rbpf_slam/io/grid_slam_config.h"
#include "rbpf_slam/io/map_image_file.h"
#include "rbpf_slam/io/tum_file.h"
#include "rbpf_slam/ros/pose_msgs.h"
#include "rbpf_slam/ros/scan_conversions.h"

namespace rbpf_slam
{
namespace replay
{
namespace
{
/** @brief The configuration files, then the options that override them. */
core::GridSlamConfig readGridConfig(const SlamBagOptions& o)
{
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
  return gc;
}

/** @brief The topics a grid run reads, each checked for its type in the bag. */
std::vector<std::string> gridTopics(const SlamBagOptions& o, const std::map<std::string, std::string>& topics)
{
  std::vector<std::string> read;
  if (!o.odometry_only)
  {
    requireTopic(topics, o.bag_path, o.scan_topic, "sensor_msgs/LaserScan", "--scan");
    read.push_back(o.scan_topic);
  }
  if (!o.wheels_topic.empty())
  {
    requireTopic(topics, o.bag_path, o.wheels_topic, "sensor_msgs/JointState", "--wheels");
    read.push_back(o.wheels_topic);
    if (o.imu_weight > 0.0)
    {
      requireTopic(topics, o.bag_path, o.imu_topic, "sensor_msgs/Imu", "--imu");
      read.push_back(o.imu_topic);
    }
  }
  else
  {
    requireTopic(topics, o.bag_path, o.odom_topic, "nav_msgs/Odometry", "--odom");
    read.push_back(o.odom_topic);
  }
  return read;
}

/** @brief What the run counted. */
struct GridCounts
{
  int scans = 0, processed = 0, resamples = 0;
  bool have_odometry = false;
  long evaluations = 0, vetoed = 0, trusted = 0, consensus = 0;
  std::vector<double> processed_stamps;
};

/** @brief One grid run on one bag: the feed of its messages, the pipeline's updates, the outputs and the summary. */
class GridBagRun
{
public:
  GridBagRun(const SlamBagOptions& o, const core::GridSlamConfig& gc, const core::Pose2& sensor)
    : o_(o), gc_(gc), pipeline_(gc), sensor_(sensor), out_(o.out_dir), wheels_(skidSteer(o))
  {
  }

  void feed(const rosbag::MessageInstance& m, double clock);
  void process(double clock, bool flush);
  /** @brief Throws when the bag gave nothing to map; reports an outage that never ended. */
  void finish();
  void writeOutputs();
  void printSummary() const;

private:
  static core::SkidSteerConfig skidSteer(const SlamBagOptions& o)
  {
    core::SkidSteerConfig sc;
    sc.effective_track = o.track;
    sc.imu_weight = o.imu_weight;
    return sc;
  }
  void addOdometry(double t, const core::Pose2& p, const std::string& topic, double clock);
  void keepEndedMaps();
  void count(const core::GridPipelineUpdate& u);
  /** @brief A line of updates.csv: the stated pose and covariance at this scan (what the node publishes). */
  void writeUpdate(const core::GridPipelineUpdate& u);
  std::string timingText() const;
  std::string timingExtra() const;

  const SlamBagOptions& o_;
  const core::GridSlamConfig gc_;
  core::GridSlamPipeline pipeline_;
  const core::Pose2 sensor_;
  Outputs out_;
  core::SkidSteerOdometry wheels_;
  DropLog drops_;
  GridCounts n_;
};

void GridBagRun::addOdometry(double t, const core::Pose2& p, const std::string& topic, double clock)
{
  if (!admitted(pipeline_.addOdometry(t, p, clock), topic, t, &drops_))
    return;
  n_.have_odometry = true;
  if (out_.enabled())
    io::writeTumLine(out_.stream("odometry_all.tum"), t, p);
}

void GridBagRun::feed(const rosbag::MessageInstance& m, double clock)
{
  if (const auto s = m.instantiate<sensor_msgs::LaserScan>())
  {
    const double t = s->header.stamp.toSec();
    core::ScanData scan;
    const std::string why = toScanData(*s, &scan);
    if (!why.empty())
      return drops_.drop(m.getTopic(), t, why);
    admitted(pipeline_.addScan(t, std::move(scan), sensor_, clock, clock), m.getTopic(), t, &drops_);
  }
  else if (const auto od = m.instantiate<nav_msgs::Odometry>())
  {
    const std::string bad = quaternionProblem(od->pose.pose.orientation);
    if (!bad.empty())
      return drops_.drop(m.getTopic(), od->header.stamp.toSec(), "orientation " + bad);
    addOdometry(od->header.stamp.toSec(), planarPose(od->pose.pose), m.getTopic(), clock);
  }
  else if (const auto js = m.instantiate<sensor_msgs::JointState>())
  {
    const double t = js->header.stamp.toSec();
    const std::string why = wheels_.addWheelAngles(t, js->position, o_.wheel_radius);
    if (!why.empty())
      return drops_.drop(m.getTopic(), t, why);
    addOdometry(t, wheels_.pose(), m.getTopic(), clock);
  }
  else if (const auto imu = m.instantiate<sensor_msgs::Imu>())
  {
    if (!wheels_.addGyro(imu->header.stamp.toSec(), imu->angular_velocity.z))
      drops_.drop(m.getTopic(), imu->header.stamp.toSec(), "gyro rate not finite or stamp not after the previous");
  }
}

void GridBagRun::keepEndedMaps()
{
  // The map each restart ended, saved beside this run's (map.restartN.yaml + .pgm in the folder).
  for (const core::GridTimelineMap& ended : pipeline_.takeEndedMaps())
  {
    const std::string path = io::endedMapPath(o_.out_dir + "/map.yaml", ended.timeline);
    std::fprintf(stderr, "slam_bag: warning: the map before restart %d%s%s\n", ended.timeline + 1,
                 out_.enabled() ? " is saved to " : " is not saved (no --out)", out_.enabled() ? path.c_str() : "");
    if (out_.enabled())
      out_.add(io::encodeMapImage(ended.map, path));
  }
}

void GridBagRun::count(const core::GridPipelineUpdate& u)
{
  ++n_.scans;
  if (u.outage_began)
    std::fprintf(stderr, "slam_bag: warning: the odometry stopped at %.3f s; the scans from %.3f s are left out "
                 "of the map (kept as it is) until it returns\n", pipeline_.outage().since, u.stamp);
  if (u.outage_scans > 0)
    std::fprintf(stderr, "slam_bag: warning: the odometry returned at %.3f s after %.3f s; %d scans were left "
                 "out of the map\n", u.stamp, u.outage_seconds, u.outage_scans);
  if (!u.step.skipped)
  {
    ++n_.processed;
    n_.resamples += u.step.resampled ? 1 : 0;
    n_.evaluations += u.step.matcher_evaluations;
    n_.vetoed += u.step.matches_vetoed;
    n_.consensus += u.step.matches_consensus;
    n_.trusted += u.step.matches_trusted;
    n_.processed_stamps.push_back(u.stamp);
  }
}

void GridBagRun::writeUpdate(const core::GridPipelineUpdate& u)
{
  // The pose and covariance the node publishes on `pose` at this scan: the particle cloud carried by the odometry.
  std::ostringstream& o = out_.stream("updates.csv");
  if (o.tellp() == 0)
    o << "stamp,processed,matches_trusted,matches_vetoed,matches_consensus,estimate_x,estimate_y,estimate_theta,"
         "estimate_xx,estimate_xy,estimate_yy,estimate_thetatheta\n";
  const core::PoseMoments m = pipeline_.filter().cloudMoments(u.odometry);
  char line[320];
  std::snprintf(line, sizeof(line), "%.6f,%d,%d,%d,%d,%.6f,%.6f,%.6f,%.9g,%.9g,%.9g,%.9g\n", u.stamp,
                u.step.skipped ? 0 : 1, u.step.matches_trusted, u.step.matches_vetoed, u.step.matches_consensus,
                m.mean.x, m.mean.y, m.mean.theta, m.covariance(0, 0), m.covariance(0, 1), m.covariance(1, 1),
                m.covariance(2, 2));
  o << line;
}

void GridBagRun::process(double clock, bool flush)
{
  keepEndedMaps();
  for (const core::GridPipelineUpdate& u : pipeline_.process(clock, flush))
  {
    if (!u.error.empty())
    {
      drops_.drop(o_.scan_topic, u.stamp, u.error);
      continue;
    }
    count(u);
    if (out_.enabled())
    {
      io::writeTumLine(out_.stream("estimate.tum"), u.stamp, u.estimate);
      io::writeTumLine(out_.stream("odometry.tum"), u.stamp, u.odometry);
      writeUpdate(u);
    }
  }
}

void GridBagRun::finish()
{
  const core::GridSlamPipeline::Outage& outage = pipeline_.outage();
  if (outage.scans > 0)
    std::fprintf(stderr, "slam_bag: warning: the odometry stopped at %.3f s and never returned: the last %.3f s "
                 "(%d scans) were left out of the map\n", outage.since, outage.last_scan - outage.since,
                 outage.scans);
  if (!o_.odometry_only && n_.scans == 0)
    throw std::runtime_error(o_.bag_path + ": no scan of " + o_.scan_topic + " was used (" +
                             std::to_string(drops_.count()) + " messages dropped; is there odometry on " +
                             (o_.wheels_topic.empty() ? o_.odom_topic : o_.wheels_topic) + "?); nothing written");
  if (!n_.have_odometry && n_.scans == 0)
    throw std::runtime_error(o_.bag_path + ": no usable odometry; nothing written");
}

std::string GridBagRun::timingText() const
{
  const double seconds = pipeline_.secondsFilter(), worst = pipeline_.worstSeconds();
  const core::GridMapMemory memory = pipeline_.filter().mapMemory();
  std::ostringstream t;
  t.precision(12);
  t << "scans " << n_.scans << "\nprocessed " << n_.processed << "\nfilter_seconds " << seconds << "\nms_per_scan "
    << 1e3 * seconds / std::max(1, n_.scans) << "\nworst_ms " << 1e3 * worst << "\nresamples " << n_.resamples
    << "\nparticles " << gc_.particles << "\nseed " << gc_.seed << "\nlinear_update " << gc_.linear_update
    << "\nangular_update " << gc_.angular_update << "\ntemporal_update " << gc_.temporal_update << "\nmap_tiles "
    << memory.tiles << "\nmap_mb " << memory.megabytes() << "\nbest_map_area_m2 " << memory.best_area
    << "\nmb_per_particle_per_1000m2 " << memory.megabytesPerParticlePer1000SquareMetres() << "\npeak_rss_mb "
    << peakResidentMegabytes() << "\n";
  return t.str();
}

std::string GridBagRun::timingExtra() const
{
  const core::GridMapMemory memory = pipeline_.filter().mapMemory();
  std::ostringstream extra;
  extra.precision(12);
  extra << "\"linear_update\": " << gc_.linear_update << ", \"angular_update\": " << gc_.angular_update
        << ", \"temporal_update\": " << gc_.temporal_update << ", \"map_tiles\": " << memory.tiles
        << ", \"map_mb\": " << memory.megabytes() << ", \"best_map_area_m2\": " << memory.best_area
        << ", \"mb_per_particle_per_1000m2\": " << memory.megabytesPerParticlePer1000SquareMetres()
        << ", \"peak_rss_mb\": " << peakResidentMegabytes();
  return extra.str();
}

void GridBagRun::writeOutputs()
{
  if (!out_.enabled())
    return;
  const core::GridSlam& slam = pipeline_.filter();
  if (slam.initialised())
    out_.add(io::encodeMapImage(slam.map().toImage(), o_.out_dir + "/map.yaml"));
  // rbpf mode: the best particle's whole history (its poses as its lineage saw them), one per processed scan -
  // the smoothed trajectory that matches the final map; estimate.tum is the online estimate.
  const std::vector<core::Pose2> history = slam.bestTrajectory();
  if (!history.empty() && pipeline_.restarts() == 0 && history.size() == n_.processed_stamps.size())
    for (std::size_t i = 0; i < history.size(); ++i)
      io::writeTumLine(out_.stream("estimate_best_history.tum"), n_.processed_stamps[i], history[i]);
  out_.stream("timing.txt") << timingText();
  out_.stream("timing.json") << io::timingJson(n_.scans, n_.processed, 0.0, pipeline_.secondsFilter(), gc_.particles,
                                               gc_.seed, timingExtra());
  out_.commit();
}

void GridBagRun::printSummary() const
{
  char thresholds[160];
  if (o_.every_scan)
    std::snprintf(thresholds, sizeof(thresholds), "every scan: --every-scan turned the travel thresholds off");
  else if (gc_.linear_update <= 0.0 && gc_.angular_update <= 0.0 && gc_.temporal_update <= 0.0)
    std::snprintf(thresholds, sizeof(thresholds), "every scan: the travel thresholds are 0");
  else if (gc_.temporal_update > 0.0)
    std::snprintf(thresholds, sizeof(thresholds), "the others below the travel thresholds %g m, %g rad, %g s",
                  gc_.linear_update, gc_.angular_update, gc_.temporal_update);
  else
    std::snprintf(thresholds, sizeof(thresholds), "the others below the travel thresholds %g m, %g rad",
                  gc_.linear_update, gc_.angular_update);
  const core::GridSlam& slam = pipeline_.filter();
  const double seconds = pipeline_.secondsFilter(), worst = pipeline_.worstSeconds();
  const core::GridMapMemory memory = slam.mapMemory();
  std::printf("slam_bag grid: %s: %d scans, %d scans dropped (unreadable, stamps going backwards or not finite), "
              "%d messages dropped in all, %d processed (%s), %d resamplings, %d restarts (time jumped back)\n",
              o_.bag_path.c_str(), n_.scans, drops_.count(o_.scan_topic), drops_.count(), n_.processed, thresholds,
              n_.resamples, pipeline_.restarts());
  const core::Pose2& p = slam.mappingPose();
  std::printf("  final pose (map frame = first scan's odometry pose): %.3f %.3f %.1f deg; %zu map tiles\n", p.x, p.y,
              p.theta * 180.0 / M_PI, slam.map().tileCount());
  std::printf("  filter time %.2f s, %.3f ms per scan (worst %.1f ms), %d particles\n", seconds,
              1e3 * seconds / std::max(1, n_.scans), 1e3 * worst, gc_.particles);
  if (slam.initialised())
    std::printf("  map memory: %zu distinct tiles (shared tiles once) in %.2f MB; best map %zu tiles, %.0f m^2; "
                "%.3f MB per particle per 1000 m^2 of map\n",
                memory.tiles, memory.megabytes(), memory.best_tiles, memory.best_area,
                memory.megabytesPerParticlePer1000SquareMetres());
  if (gc_.mode == core::GridSlamMode::kRbpf && !o_.odometry_only)
    std::printf("  scan matcher: %.1f poses scored per particle and processed scan; matches taken %ld, vetoed by "
                "the odometry %ld (of %ld), taken by the particles' common correction %ld\n",
                static_cast<double>(n_.evaluations) / std::max(1, n_.processed) / std::max(1, gc_.particles),
                n_.trusted, n_.vetoed, static_cast<long>(n_.processed - 1) * gc_.particles, n_.consensus);
  if (!o_.wheels_topic.empty() && o_.imu_weight > 0.0)
    std::printf("  gyro bias (from standing still) %.5f rad/s\n", wheels_.gyroBias());
}
}  // namespace

int runGridBag(const SlamBagOptions& o)
{
  rosbag::Bag bag;
  openBag(o.bag_path, &bag);
  const std::vector<std::string> read = gridTopics(o, bagTopics(bag));
  const core::GridSlamConfig gc = readGridConfig(o);
  // The scanner's mount from /tf_static (the first scan names its frame).
  const std::string laser_frame = o.odometry_only ? std::string() : firstFrame(bag, o.scan_topic);
  core::SensorMount mount;
  if (!laser_frame.empty() && !staticMount(bag, o.base_frame, laser_frame, &mount))
    throw std::runtime_error(o.bag_path + ": no " + o.base_frame + " -> " + laser_frame + " transform on /tf_static");
  GridBagRun run(o, gc, core::Pose2(mount.x, mount.y, mount.yaw));
  replay(
      bag, read, [&](const rosbag::MessageInstance& m, double clock) { run.feed(m, clock); },
      [&](double clock, bool flush) { run.process(clock, flush); });
  run.finish();
  run.writeOutputs();
  if (!o.quiet)
    run.printSummary();
  return 0;
}

}  // namespace replay
}  // namespace rbpf_slam
