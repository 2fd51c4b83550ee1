// Offline runner for bags: trunk extraction and FastSLAM on a bag's point clouds and wheel odometry, the
// same classes as the nodelets, as fast as they compute (no roscore, no real-time wait). Reads only the
// sensor topics named here and /tf_static: never the truth.
//
//   rosrun rbpf_slam fastslam_bag --bag FILE [--points /points | --scan /scan] [--odom /odom]
//       [--base-frame base_link] [--extraction-config YAML] [--fastslam-config YAML] [--particles N] [--seed S]
//       [--method circle|centroid] [--out DIR] [--quiet]
//
// The configurations are the nodelets' YAML files (config/trunk_extraction.yaml, config/fastslam.yaml, or one
// per sensor type such as config/lego/); --particles, --seed and --method override them.
//
// Writes DIR/estimate.tum and DIR/odometry.tum (TUM: t x y z qx qy qz qw; evo reads them), DIR/map.csv (the
// best particle's landmarks) and DIR/timing.json (processing seconds); scripts/evaluate_bag_run scores them.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <sys/stat.h>

#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_msgs/TFMessage.h>

#include "rbpf_slam/core/trunk_slam_pipeline.h"
#include "rbpf_slam/io/fastslam_config.h"
#include "rbpf_slam/io/param_source.h"
#include "rbpf_slam/io/run_output.h"
#include "rbpf_slam/io/trunk_detector_config.h"

using namespace rbpf_slam;

namespace
{
double yawOf(const geometry_msgs::Quaternion& q)
{
  return std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
}

void usage(const char* argv0)
{
  std::fprintf(stderr,
               "usage: %s --bag FILE [--points TOPIC | --scan TOPIC] [--odom TOPIC] [--base-frame FRAME]\n"
               "          [--extraction-config YAML] [--fastslam-config YAML] [--particles N] [--seed S]\n"
               "          [--method circle|centroid] [--out DIR] [--quiet]\n"
               "Runs trunk extraction and FastSLAM on a bag offline; writes DIR/estimate.tum, DIR/odometry.tum, "
               "DIR/map.csv.\nexample: %s --bag paper1.bag --out results/paper1\n",
               argv0, argv0);
}
}  // namespace

int main(int argc, char** argv)
{
  std::string bag_path, points_topic = "/points", scan_topic, odom_topic = "/odom", base_frame = "base_link", out_dir,
      method, extraction_yaml, fastslam_yaml;
  int particles = -1;
  long seed = -1;
  bool quiet = false;
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    if (a == "--bag" && has)
      bag_path = argv[++i];
    else if (a == "--points" && has)
      points_topic = argv[++i];
    else if (a == "--scan" && has)
      scan_topic = argv[++i];
    else if (a == "--extraction-config" && has)
      extraction_yaml = argv[++i];
    else if (a == "--fastslam-config" && has)
      fastslam_yaml = argv[++i];
    else if (a == "--odom" && has)
      odom_topic = argv[++i];
    else if (a == "--base-frame" && has)
      base_frame = argv[++i];
    else if (a == "--particles" && has)
      particles = std::atoi(argv[++i]);
    else if (a == "--seed" && has)
      seed = std::atol(argv[++i]);
    else if (a == "--method" && has)
      method = argv[++i];
    else if (a == "--out" && has)
      out_dir = argv[++i];
    else if (a == "--quiet")
      quiet = true;
    else
    {
      usage(argv[0]);
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  if (bag_path.empty())
  {
    usage(argv[0]);
    return 2;
  }
  try
  {
    rosbag::Bag bag(bag_path, rosbag::bagmode::Read);
    // The lidar's mount on base_link from /tf_static (the first message names the lidar frame).
    const bool use_scan = !scan_topic.empty();
    const std::string sensor_topic = use_scan ? scan_topic : points_topic;
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
      throw std::runtime_error(bag_path + ": no " + (use_scan ? "sensor_msgs/LaserScan" : "sensor_msgs/PointCloud2") +
                               " on " + sensor_topic);
    core::SensorMount mount;
    bool have_mount = lidar_frame == base_frame;
    rosbag::View statics(bag, rosbag::TopicQuery("/tf_static"));
    for (const auto& m : statics)
    {
      const auto tf = m.instantiate<tf2_msgs::TFMessage>();
      if (!tf)
        continue;
      for (const auto& t : tf->transforms)
        if (t.header.frame_id == base_frame && t.child_frame_id == lidar_frame)
        {
          mount.x = t.transform.translation.x;
          mount.y = t.transform.translation.y;
          mount.z = t.transform.translation.z;
          mount.yaw = yawOf(t.transform.rotation);
          have_mount = true;
        }
    }
    if (!have_mount)
      throw std::runtime_error(bag_path + ": no " + base_frame + " -> " + lidar_frame + " transform on /tf_static");

    core::TrunkDetectorConfig dc;
    dc.sensor_height = mount.z;
    core::FastSlamConfig fc;
    const auto load = [](const std::string& path, const auto& reader) {
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
        std::fprintf(stderr, "fastslam_bag: warning: %s: key '%s' is not used here\n", path.c_str(), key.c_str());
    };
    load(extraction_yaml, [&](const io::ParamSource& p) { io::readTrunkDetectorConfig(p, &dc); });
    load(fastslam_yaml, [&](const io::ParamSource& p) { io::readFastSlamConfig(p, &fc); });
    if (!method.empty() && !core::parseTrunkMethod(method, &dc.method))
      throw std::runtime_error("--method must be circle or centroid");
    if (particles > 0)
      fc.particles = particles;
    if (seed >= 0)
    {
      fc.seed = static_cast<std::uint64_t>(seed);
      dc.seed = static_cast<std::uint64_t>(seed);
    }
    core::TrunkSlamPipeline pipeline(dc, fc, mount);

    std::ofstream est, odo;
    if (!out_dir.empty())
    {
      mkdir(out_dir.c_str(), 0755);
      est.open(out_dir + "/estimate.tum");
      odo.open(out_dir + "/odometry.tum");
      est.precision(12);
      odo.precision(12);
      if (!est || !odo)
        throw std::runtime_error(out_dir + ": cannot write");
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
    rosbag::View view(bag, rosbag::TopicQuery(std::vector<std::string>{ sensor_topic, odom_topic }));
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
        pipeline.addScan(stamp, std::max(static_cast<double>(scan->scan_time), 1e-3), planar);
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
    if (!out_dir.empty())
    {
      std::vector<core::Landmark> landmarks;
      for (std::size_t i = 0; i < best.map.size(); ++i)
        landmarks.push_back(best.map[i]);
      io::writeLandmarksCsv(out_dir + "/map.csv", landmarks);
      std::ofstream timing(out_dir + "/timing.json");
      timing << "{\"sweeps\": " << clouds << ", \"updates\": " << updates << ", \"dropped\": " << dropped
             << ", \"seconds_extraction\": " << pipeline.secondsExtraction()
             << ", \"seconds_filter\": " << pipeline.secondsFilter() << ", \"particles\": " << fc.particles
             << ", \"seed\": " << fc.seed << "}\n";
      if (!timing)
        throw std::runtime_error(out_dir + "/timing.json: cannot write");
    }
    if (!quiet)
    {
      std::printf("fastslam_bag: %s: %d clouds, %d filter updates, %d messages dropped (time going backwards or "
                  "not finite)\n",
                  bag_path.c_str(), clouds, updates, dropped);
      std::printf("  final pose (map frame = first odometry pose): %.3f %.3f %.1f deg; %zu landmarks\n", best.pose.x,
                  best.pose.y, best.pose.theta * 180.0 / M_PI, best.map.size());
      std::printf("  time: extraction %.2f s, filter %.2f s (%.0f clouds/s)\n", pipeline.secondsExtraction(),
                  pipeline.secondsFilter(), clouds / std::max(1e-9, pipeline.secondsExtraction() + pipeline.secondsFilter()));
    }
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "fastslam_bag: %s\n", e.what());
    return 1;
  }
  return 0;
}
