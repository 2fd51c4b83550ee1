// The offline runner for bags, for both filters: the same core classes as the nodelets, as fast as they
// compute (no roscore, no real-time wait). Reads only the sensor topics named here and /tf_static: never
// the truth.
//
//   rosrun rbpf_slam slam_bag --filter fastslam --bag FILE [--points /points | --scan /scan] [--odom /odom]
//       [--base-frame base_link] [--extraction-config YAML] [--config YAML] [--particles N] [--seed S]
//       [--method circle|centroid] [--out DIR] [--quiet]
//   rosrun rbpf_slam slam_bag --filter grid --bag FILE [--scan /scan] [--odom /odom] [--base-frame base_link]
//       [--particles N] [--seed S] [--config config/grid_slam.yaml] [--resampling low_variance|multinomial]
//       [--wheels /wheel_ticks [--wheel-radius 0.127] [--track 0.7283] [--imu /imu/data --imu-weight W]]
//       [--out DIR] [--quiet]
//
// --config is the filter's YAML (config/fastslam.yaml or config/grid_slam.yaml layout), --extraction-config the
// trunk extraction's (config/trunk_extraction.yaml layout); one pair per sensor type, e.g. config/lego/;
// --particles, --seed and --method override them. FastSLAM reads point clouds, or 2D scans when --scan is given.
//
// Both write DIR/timing.json (processing seconds; evaluate_bag_run reads it). fastslam writes DIR/estimate.tum,
// DIR/odometry.tum (TUM: t x y z qx qy qz qw; evo reads them) and DIR/map.csv; grid writes DIR/estimate.tum and DIR/odometry.tum (one pose per scan), DIR/odometry_all.tum
// (every odometry pose), DIR/map.yaml + DIR/map.pgm (map_server layout) and DIR/timing.txt.
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <sys/stat.h>

#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/JointState.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_msgs/TFMessage.h>

#include "rbpf_slam/core/grid_slam.h"
#include "rbpf_slam/core/odometry_buffer.h"
#include "rbpf_slam/core/skid_steer_odometry.h"
#include "rbpf_slam/core/trunk_slam_pipeline.h"
#include "rbpf_slam/io/grid_slam_config.h"
#include "rbpf_slam/io/map_image_file.h"
#include "rbpf_slam/io/param_source.h"
#include "rbpf_slam/io/fastslam_config.h"
#include "rbpf_slam/io/files.h"
#include "rbpf_slam/io/run_output.h"
#include "rbpf_slam/io/trunk_detector_config.h"
#include "rbpf_slam/ros/pose_msgs.h"
#include "rbpf_slam/ros/scan_conversions.h"

using namespace rbpf_slam;

namespace
{

struct Options
{
  std::string filter = "fastslam";
  std::string bag_path, points_topic = "/points", scan_topic = "/scan", odom_topic = "/odom";
  std::string base_frame = "base_link", out_dir, method, config_path, extraction_config_path, resampling;
  bool scan_given = false;  // fastslam: 2D scans instead of point clouds
  std::string wheels_topic, imu_topic = "/imu/data";
  int particles = -1;  // the filter's default
  long seed = -1;  // the configuration's (0 by default)
  bool quiet = false;
  double wheel_radius = 0.127, track = 0.7283, imu_weight = 0.0;
};

void usage(const char* argv0)
{
  std::fprintf(stderr,
               "usage: %s [--filter fastslam|grid] --bag FILE [--odom TOPIC] [--base-frame FRAME] [--particles N]\n"
               "          [--seed S] [--out DIR] [--quiet]\n"
               "          [--config YAML (the filter's)]\n"
               "  fastslam: [--points TOPIC | --scan TOPIC] [--extraction-config YAML] [--method circle|centroid]\n"
               "  grid:     [--scan TOPIC] [--resampling low_variance|multinomial]\n"
               "            [--wheels TOPIC [--wheel-radius M] [--track M] [--imu TOPIC] [--imu-weight W]]\n"
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

/** @brief mkdir -p; throws naming the folder when it cannot be made. */
void makeDirectories(const std::string& dir)
{
  if (!io::makeDirectories(dir))
    throw std::runtime_error(dir + ": cannot create the folder");
}

std::string openOut(const std::string& dir, const std::string& name, std::ofstream* f)
{
  f->open(dir + "/" + name);
  f->precision(12);
  if (!*f)
    throw std::runtime_error(dir + "/" + name + ": cannot write");
  return dir + "/" + name;
}

/** @brief Reads a YAML file with @p reader (if a path is given); errors name the file, unused keys are warned. */
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
    std::fprintf(stderr, "slam_bag: warning: %s: key '%s' is not used by this filter\n", path.c_str(), key.c_str());
}

void writeTimingJson(const std::string& dir, int sweeps, int updates, double extraction, double filter, int particles,
                     std::uint64_t seed)
{
  std::ofstream timing(dir + "/timing.json");
  timing << "{\"sweeps\": " << sweeps << ", \"updates\": " << updates << ", \"seconds_extraction\": " << extraction
         << ", \"seconds_filter\": " << filter << ", \"particles\": " << particles << ", \"seed\": " << seed << "}\n";
  if (!timing)
    throw std::runtime_error(dir + "/timing.json: cannot write");
}

int runFastSlam(const Options& o)
{
  rosbag::Bag bag(o.bag_path, rosbag::bagmode::Read);
  // The lidar's mount on base_link from /tf_static (the first message names the lidar frame).
  const std::string sensor_topic = o.scan_given ? o.scan_topic : o.points_topic;
  std::string lidar_frame;
  {
    rosbag::View first(bag, rosbag::TopicQuery(sensor_topic));
    for (const auto& m : first)
    {
      if (const auto cloud = m.instantiate<sensor_msgs::PointCloud2>())
        lidar_frame = cloud->header.frame_id;
      else if (const auto scan = m.instantiate<sensor_msgs::LaserScan>())
        lidar_frame = scan->header.frame_id;
      if (!lidar_frame.empty())
        break;
    }
  }
  if (lidar_frame.empty())
    throw std::runtime_error(o.bag_path + ": no " +
                             (o.scan_given ? "sensor_msgs/LaserScan" : "sensor_msgs/PointCloud2") + " on " +
                             sensor_topic);
  core::SensorMount mount;
  if (!staticMount(bag, o.base_frame, lidar_frame, &mount))
    throw std::runtime_error(o.bag_path + ": no " + o.base_frame + " -> " + lidar_frame + " transform on /tf_static");

  core::TrunkDetectorConfig dc;
  dc.sensor_height = mount.z;
  core::FastSlamConfig fc;
  loadYaml(o.extraction_config_path, [&](const io::ParamSource& p) { io::readTrunkDetectorConfig(p, &dc); });
  loadYaml(o.config_path, [&](const io::ParamSource& p) { io::readFastSlamConfig(p, &fc); });
  if (!o.method.empty() && !core::parseTrunkMethod(o.method, &dc.method))
    throw std::runtime_error("--method must be circle or centroid");
  if (o.particles > 0)
    fc.particles = o.particles;
  if (o.seed >= 0)
  {
    fc.seed = static_cast<std::uint64_t>(o.seed);
    dc.seed = static_cast<std::uint64_t>(o.seed);
  }
  core::TrunkSlamPipeline pipeline(dc, fc, mount);

  std::ofstream est, odo;
  if (!o.out_dir.empty())
  {
    makeDirectories(o.out_dir);
    openOut(o.out_dir, "estimate.tum", &est);
    openOut(o.out_dir, "odometry.tum", &odo);
  }
  std::vector<Eigen::Vector3f> pts;
  int clouds = 0, updates = 0, dropped = 0;
  double last_cloud = -1e300;
  const auto consume = [&](const std::vector<core::PipelineUpdate>& ups) {
    for (const auto& u : ups)
    {
      ++updates;
      if (est.is_open())
      {
        io::writeTumLine(est, u.stamp, pipeline.filter().best().pose);
        io::writeTumLine(odo, u.stamp, u.odometry);
      }
    }
  };
  core::PlanarScan planar;
  rosbag::View view(bag, rosbag::TopicQuery(std::vector<std::string>{ sensor_topic, o.odom_topic }));
  for (const auto& m : view)
  {
    if (const auto od = m.instantiate<nav_msgs::Odometry>())
    {
      const core::Pose2 p(od->pose.pose.position.x, od->pose.pose.position.y, yawOf(od->pose.pose.orientation));
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.theta) ||
          !pipeline.addOdometry(od->header.stamp.toSec(), p))
        ++dropped;
    }
    else if (const auto scan = m.instantiate<sensor_msgs::LaserScan>())
    {
      const double stamp = scan->header.stamp.toSec();
      if (stamp <= last_cloud || !(scan->angle_increment != 0.0f) || !std::isfinite(scan->angle_min))
      {
        ++dropped;
        continue;
      }
      last_cloud = stamp;
      planar.ranges = scan->ranges;  // NaN / Inf / out-of-range beams are skipped by the detector (REP-117)
      planar.angle_min = scan->angle_min;
      planar.angle_increment = scan->angle_increment;
      planar.range_min = scan->range_min;
      planar.range_max = scan->range_max;
      // The beams' own times: time_increment apart (0 when the driver does not say: one instant).
      const double period = scan->time_increment > 0.0f && scan->ranges.size() > 1
                                ? static_cast<double>(scan->time_increment) * static_cast<double>(scan->ranges.size() - 1)
                                : 0.0;
      pipeline.addScan(stamp, std::max(period, 1e-3), planar);
      ++clouds;
    }
    else if (const auto cloud = m.instantiate<sensor_msgs::PointCloud2>())
    {
      const double stamp = cloud->header.stamp.toSec();
      if (stamp <= last_cloud)
      {
        ++dropped;
        continue;
      }
      last_cloud = stamp;
      pts.clear();
      double period = 0.0;
      bool has_time = false;
      for (const auto& f : cloud->fields)
        has_time = has_time || (f.name == "time" && f.datatype == sensor_msgs::PointField::FLOAT32);
      sensor_msgs::PointCloud2ConstIterator<float> x(*cloud, "x"), y(*cloud, "y"), z(*cloud, "z");
      for (; x != x.end(); ++x, ++y, ++z)
        pts.emplace_back(*x, *y, *z);
      if (has_time)
        for (sensor_msgs::PointCloud2ConstIterator<float> t(*cloud, "time"); t != t.end(); ++t)
          period = std::max(period, static_cast<double>(*t));
      pipeline.addSweep(stamp, std::max(period, 1e-3), pts);
      ++clouds;
    }
    consume(pipeline.process(false));
  }
  consume(pipeline.process(true));

  const core::Particle& best = pipeline.filter().best();
  if (!o.out_dir.empty())
  {
    std::vector<core::Landmark> landmarks;
    for (std::size_t i = 0; i < best.map.size(); ++i)
      landmarks.push_back(best.map[i]);
    io::writeLandmarksCsv(o.out_dir + "/map.csv", landmarks);
    writeTimingJson(o.out_dir, clouds, updates, pipeline.secondsExtraction(), pipeline.secondsFilter(), fc.particles,
                    fc.seed);
  }
  if (!o.quiet)
  {
    std::printf("slam_bag fastslam: %s: %d clouds, %d filter updates, %d messages dropped (time going backwards or "
                "not finite)\n",
                o.bag_path.c_str(), clouds, updates, dropped);
    std::printf("  final pose (map frame = first odometry pose): %.3f %.3f %.1f deg; %zu landmarks\n", best.pose.x,
                best.pose.y, best.pose.theta * 180.0 / M_PI, best.map.size());
    std::printf("  time: extraction %.2f s, filter %.2f s (%.0f clouds/s)\n", pipeline.secondsExtraction(),
                pipeline.secondsFilter(), clouds / std::max(1e-9, pipeline.secondsExtraction() + pipeline.secondsFilter()));
  }
  return 0;
}

int runGrid(const Options& o)
{
  rosbag::Bag bag(o.bag_path, rosbag::bagmode::Read);
  core::GridSlamConfig gc;
  if (!o.config_path.empty())
  {
    io::YamlParamSource yaml(o.config_path);
    io::readGridSlamConfig(yaml, &gc);
  }
  if (o.particles > 0)
    gc.particles = o.particles;
  if (o.seed >= 0)
    gc.seed = static_cast<std::uint64_t>(o.seed);
  if (!o.resampling.empty() && !core::parseResamplingMethod(o.resampling, &gc.resampling))
    throw std::runtime_error("--resampling must be low_variance or multinomial");
  core::GridSlam slam(gc);

  // The scanner's mount from /tf_static (the first scan names its frame). A bag without scans is allowed:
  // it gives odometry only (e.g. wheel odometry with and without IMU fusion).
  std::string laser_frame;
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

  std::ofstream est, odo, odo_all;
  if (!o.out_dir.empty())
  {
    makeDirectories(o.out_dir);
    openOut(o.out_dir, "estimate.tum", &est);
    openOut(o.out_dir, "odometry.tum", &odo);
    openOut(o.out_dir, "odometry_all.tum", &odo_all);
  }

  core::SkidSteerConfig sc;
  sc.effective_track = o.track;
  sc.imu_weight = o.imu_weight;
  core::SkidSteerOdometry wheels(sc);
  std::vector<double> last_wheel_angles;
  const bool use_wheels = !o.wheels_topic.empty();

  core::OdometryBuffer odometry;
  std::deque<std::pair<double, core::ScanData>> pending;
  int scans = 0, dropped = 0, bad_scans = 0, resamples = 0;
  long evaluations = 0;
  double last_scan = -1e300, seconds = 0.0, worst = 0.0;
  std::vector<double> scan_stamps;
  const auto addOdometry = [&](double t, const core::Pose2& p) {
    if (!std::isfinite(t) || !std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.theta) ||
        odometry.add(t, p) == core::OdometryBuffer::AddResult::kBackwards)
    {
      ++dropped;
      return;
    }
    if (odo_all.is_open())
      io::writeTumLine(odo_all, t, p);
  };
  const auto process = [&](bool flush) {
    while (!pending.empty() && !odometry.empty() && (flush || odometry.covers(pending.front().first)))
    {
      const double t = pending.front().first;
      const core::Pose2 od = odometry.at(t);
      const auto t0 = std::chrono::steady_clock::now();
      const core::GridSlamStep step = slam.update(od, pending.front().second, sensor);
      const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      seconds += dt;
      worst = std::max(worst, dt);
      resamples += step.resampled ? 1 : 0;
      evaluations += step.matcher_evaluations;
      ++scans;
      scan_stamps.push_back(t);
      if (est.is_open())
      {
        io::writeTumLine(est, t, slam.mappingPose());
        io::writeTumLine(odo, t, od);
      }
      odometry.dropBefore(t);
      pending.pop_front();
    }
  };

  std::vector<std::string> topics{ o.scan_topic };
  if (use_wheels)
  {
    topics.push_back(o.wheels_topic);
    if (o.imu_weight > 0.0)
      topics.push_back(o.imu_topic);
  }
  else
    topics.push_back(o.odom_topic);
  rosbag::View view(bag, rosbag::TopicQuery(topics));
  for (const auto& m : view)
  {
    if (const auto s = m.instantiate<sensor_msgs::LaserScan>())
    {
      const double t = s->header.stamp.toSec();
      core::ScanData scan;
      const std::string why = toScanData(*s, &scan);
      if (!why.empty() || t <= last_scan)
      {
        ++bad_scans;
        continue;
      }
      last_scan = t;
      pending.emplace_back(t, std::move(scan));
    }
    else if (const auto od = m.instantiate<nav_msgs::Odometry>())
      addOdometry(od->header.stamp.toSec(),
                  core::Pose2(od->pose.pose.position.x, od->pose.pose.position.y, yawOf(od->pose.pose.orientation)));
    else if (const auto js = m.instantiate<sensor_msgs::JointState>())
    {
      // ESE 650 layout: FR FL RR RL cumulative wheel angles [rad]; left = mean(FL, RL), right = mean(FR, RR).
      if (js->position.size() < 4)
      {
        ++dropped;
        continue;
      }
      const double t = js->header.stamp.toSec();
      if (!last_wheel_angles.empty())
      {
        const auto d = [&](int i) { return (js->position[i] - last_wheel_angles[i]) * o.wheel_radius; };
        if (!wheels.addEncoders(t, 0.5 * (d(1) + d(3)), 0.5 * (d(0) + d(2))))
        {
          ++dropped;
          continue;
        }
      }
      last_wheel_angles.assign(js->position.begin(), js->position.begin() + 4);
      addOdometry(t, wheels.pose());
    }
    else if (const auto imu = m.instantiate<sensor_msgs::Imu>())
    {
      if (!wheels.addGyro(imu->header.stamp.toSec(), imu->angular_velocity.z))
        ++dropped;
    }
    process(false);
  }
  process(true);

  if (!o.out_dir.empty())
  {
    if (slam.initialised())
      io::saveMapImage(slam.map().toImage(), o.out_dir + "/map.yaml");
    // rbpf mode: the best particle's whole history (its poses as its lineage saw them), one per scan - the
    // smoothed trajectory that matches the final map; estimate.tum is the online estimate.
    const std::vector<core::Pose2> history = slam.bestTrajectory();
    if (!history.empty() && history.size() == scan_stamps.size())
    {
      std::ofstream best;
      openOut(o.out_dir, "estimate_best_history.tum", &best);
      for (std::size_t i = 0; i < history.size(); ++i)
        io::writeTumLine(best, scan_stamps[i], history[i]);
    }
    std::ofstream timing(o.out_dir + "/timing.txt");
    timing << "scans " << scans << "\nfilter_seconds " << seconds << "\nms_per_scan "
           << 1e3 * seconds / std::max(1, scans) << "\nworst_ms " << 1e3 * worst << "\nresamples " << resamples
           << "\nparticles " << gc.particles << "\nseed " << gc.seed << "\n";
    writeTimingJson(o.out_dir, scans, scans, 0.0, seconds, gc.particles, gc.seed);
  }
  if (!o.quiet)
  {
    std::printf("slam_bag grid: %s: %d scans, %d scans dropped (malformed or time going backwards), %d odometry "
                "messages dropped, %d resamplings\n",
                o.bag_path.c_str(), scans, bad_scans, dropped, resamples);
    const core::Pose2& p = slam.mappingPose();
    std::printf("  final pose (map frame = first scan's odometry pose): %.3f %.3f %.1f deg; %zu map tiles\n", p.x, p.y,
                p.theta * 180.0 / M_PI, slam.map().tileCount());
    std::printf("  filter time %.2f s, %.3f ms per scan (worst %.1f ms), %d particles\n", seconds,
                1e3 * seconds / std::max(1, scans), 1e3 * worst, gc.particles);
    if (gc.mode == core::GridSlamMode::kRbpf)
      std::printf("  scan matcher: %.1f poses scored per particle and scan\n",
                  static_cast<double>(evaluations) / std::max(1, scans) / std::max(1, gc.particles));
    if (use_wheels && o.imu_weight > 0.0)
      std::printf("  gyro bias (from standing still) %.5f rad/s\n", wheels.gyroBias());
  }
  return 0;
}
}  // namespace

int main(int argc, char** argv)
{
  Options o;
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    if (a == "--filter" && has)
      o.filter = argv[++i];
    else if (a == "--bag" && has)
      o.bag_path = argv[++i];
    else if (a == "--points" && has)
      o.points_topic = argv[++i];
    else if (a == "--scan" && has)
    {
      o.scan_topic = argv[++i];
      o.scan_given = true;
    }
    else if (a == "--extraction-config" && has)
      o.extraction_config_path = argv[++i];
    else if (a == "--odom" && has)
      o.odom_topic = argv[++i];
    else if (a == "--base-frame" && has)
      o.base_frame = argv[++i];
    else if (a == "--particles" && has)
      o.particles = std::atoi(argv[++i]);
    else if (a == "--seed" && has)
      o.seed = std::atol(argv[++i]);
    else if (a == "--method" && has)
      o.method = argv[++i];
    else if (a == "--config" && has)
      o.config_path = argv[++i];
    else if (a == "--resampling" && has)
      o.resampling = argv[++i];
    else if (a == "--wheels" && has)
      o.wheels_topic = argv[++i];
    else if (a == "--wheel-radius" && has)
      o.wheel_radius = std::atof(argv[++i]);
    else if (a == "--track" && has)
      o.track = std::atof(argv[++i]);
    else if (a == "--imu" && has)
      o.imu_topic = argv[++i];
    else if (a == "--imu-weight" && has)
      o.imu_weight = std::atof(argv[++i]);
    else if (a == "--out" && has)
      o.out_dir = argv[++i];
    else if (a == "--quiet")
      o.quiet = true;
    else
    {
      usage(argv[0]);
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  if (o.bag_path.empty() || (o.filter != "fastslam" && o.filter != "grid"))
  {
    usage(argv[0]);
    return 2;
  }
  try
  {
    return o.filter == "grid" ? runGrid(o) : runFastSlam(o);
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "slam_bag: %s\n", e.what());
    return 1;
  }
}
