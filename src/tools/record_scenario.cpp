// Records a simulated scenario to a bag, in-process and deterministic (no roscore needed): the
// follower steers on odometry through the noise relay, as in the ROS graph.
//   record_scenario --world config/worlds/paper_forest.yaml --drive straight --seed 3 --out run.bag
#include <atomic>
#include <csignal>
#include <cstdio>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <memory>
#include <string>
#include <unistd.h>

#include <geometry_msgs/Twist.h>
#include <nav_msgs/Path.h>
#include <rosbag/bag.h>
#include <tf2_msgs/TFMessage.h>

#include "rbpf_slam/core/grid/occupancy_image.h"
#include "rbpf_slam/sim/scenario.h"
#include "rbpf_slam/io/files.h"
#include "rbpf_slam/io/map_image_file.h"
#include "rbpf_slam/ros/gnss_conversions.h"
#include "rbpf_slam/sim/sim_config.h"
#include "rbpf_slam/sim/waypoints_file.h"
#include "rbpf_slam/sim/world_file.h"
#include "rbpf_slam/ros/sim_conversions.h"

using namespace rbpf_slam;

namespace
{
std::atomic<bool> g_interrupted(false);

void onSignal(int)
{
  g_interrupted = true;
}

const char* kUsage =
    "usage: record_scenario (--world FILE | --indoor-map MAP.yaml) --out BAG [options]\n"
    "Records a simulated run (sensors, odometry, TF, ground truth) to a bag, deterministically.\n"
    "  --world FILE        forest world: YAML world file or tree list (x y radius per line)\n"
    "  --indoor-map FILE   indoor world: map_server YAML (2D lidar only, flat ground)\n"
    "  --drive NAME        straight | loop | waypoint file (x y per line, start frame); default straight\n"
    "  --seed N            seed of the simulator and the relay; default 0\n"
    "  --config FILE       simulator parameters (keys of config/forest_sim.yaml); default: built-in\n"
    "  --start X Y YAW_DEG start pose in the world (over --config's); default (0, 15, 0); the drive's\n"
    "                      waypoints are in the start frame\n"
    "  --out BAG           output bag (written to a temporary name, renamed when complete)\n"
    "  --no-points         leave the 3D point clouds out (small bags for odometry studies)\n"
    "  --quiet             no progress bar\n"
    "If the robot's footprint touches a trunk or a box, the simulator stops it there: the recorder reports the\n"
    "collision (time, true pose, what was hit), writes no bag and exits with status 3.\n"
    "example:\n"
    "  record_scenario --world config/worlds/paper_forest.yaml --drive loop --seed 3 --out loop3.bag\n";

void progress(double done, double total, bool final)
{
  const int width = 40;
  const double f = total > 0.0 ? std::min(1.0, done / total) : 1.0;
  const int filled = static_cast<int>(f * width);
  std::fprintf(stderr, "\r[%.*s%*s] %3d%%  %.1f / %.1f s simulated%s", filled,
               "########################################", width - filled, "", static_cast<int>(100 * f), done,
               total, final ? "\n" : "");
  std::fflush(stderr);
}
}  // namespace

int main(int argc, char** argv)
{
  std::string world_path, indoor_map, drive = "straight", config_path, out;
  int seed = 0;
  bool start_given = false;
  core::Pose2 start;
  bool points = true, quiet = !isatty(STDERR_FILENO);
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    auto value = [&](std::string* v) {
      if (i + 1 >= argc)
      {
        std::fprintf(stderr, "record_scenario: %s needs a value\n%s", a.c_str(), kUsage);
        std::exit(2);
      }
      *v = argv[++i];
    };
    std::string v;
    if (a == "--world")
      value(&world_path);
    else if (a == "--indoor-map")
      value(&indoor_map);
    else if (a == "--drive")
      value(&drive);
    else if (a == "--config")
      value(&config_path);
    else if (a == "--out")
      value(&out);
    else if (a == "--seed")
    {
      value(&v);
      char* end = nullptr;
      seed = static_cast<int>(std::strtol(v.c_str(), &end, 10));
      if (*end != '\0')
      {
        std::fprintf(stderr, "record_scenario: --seed takes an integer, got '%s'\n", v.c_str());
        return 2;
      }
    }
    else if (a == "--start")
    {
      double* fields[3] = { &start.x, &start.y, &start.theta };
      for (double* f : fields)
      {
        value(&v);
        char* end = nullptr;
        *f = std::strtod(v.c_str(), &end);
        if (end == v.c_str() || *end != '\0' || !std::isfinite(*f))
        {
          std::fprintf(stderr, "record_scenario: --start takes three numbers X Y YAW_DEG, got '%s'\n", v.c_str());
          return 2;
        }
      }
      start.theta *= M_PI / 180.0;
      start_given = true;
    }
    else if (a == "--no-points")
      points = false;
    else if (a == "--quiet")
      quiet = true;
    else if (a == "-h" || a == "--help")
    {
      std::printf("%s", kUsage);
      return 0;
    }
    else
    {
      std::fprintf(stderr, "record_scenario: unknown argument '%s'\n%s", a.c_str(), kUsage);
      return 2;
    }
  }
  if ((world_path.empty() == indoor_map.empty()) || out.empty())
  {
    std::fprintf(stderr, "record_scenario: give exactly one of --world/--indoor-map, and --out\n%s", kUsage);
    return 2;
  }

  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  try
  {
    core::ScenarioConfig config;
    if (!config_path.empty())
    {
      io::YamlParamSource params(config_path);
      io::readScenarioConfig(params, &config);
      for (const auto& k : params.unusedKeys())
        std::fprintf(stderr, "record_scenario: warning: %s: unknown key '%s' ignored\n", config_path.c_str(),
                     k.c_str());
    }
    config.sim.seed = static_cast<std::uint64_t>(static_cast<std::int64_t>(seed));
    if (start_given)
      config.sim.start = start;
    std::string error;
    config.drive = io::namedDrive(drive, &error);
    if (config.drive.empty())
      throw std::runtime_error(error);
    std::shared_ptr<const core::OccupancyImage> image;
    core::ForestWorld world;
    if (!indoor_map.empty())
    {
      image = std::make_shared<const core::OccupancyImage>(io::loadMapImage(indoor_map));
      world.ground.amplitude = 0.0;
      config.sim.lidar3d.enabled = false;
      config.sim.lidar2d.enabled = true;
    }
    else
    {
      world = io::loadForestWorld(world_path);
    }
    if (!points)
      config.sim.lidar3d.enabled = false;
    core::Scenario scenario(world, config, image);
    const double start_ground_z = core::Ground(scenario.simulator().world().ground).height(config.sim.start.x, config.sim.start.y);
    const core::PathFollower probe(config.drive, config.follower);
    const double expected = probe.length() / config.follower.speed + config.settle;

    const SimFrames frames;
    const double base = 1000.0;
    io::AtomicFile output(out);  // removed again if the recording does not complete
    rosbag::Bag bag(output.temporary(), rosbag::bagmode::Write);
    bag.setCompression(rosbag::compression::LZ4);
    tf2_msgs::TFMessage statics;
    statics.transforms = { toStaticTf(config.sim.lidar3d.mount, frames.base, frames.lidar3d, 0.0, base),
                           toStaticTf(config.sim.lidar2d.mount, frames.base, frames.lidar2d, 0.0, base) };
    if (config.sim.gnss.enabled)
      statics.transforms.push_back(toStaticTf(gpsMount(config.sim.gnss), frames.base, frames.gps, 0.0, base));
    const ros::Time t0 = toRosTime(0.0, base);
    bag.write("/tf_static", t0, statics);
    const auto trees = toTruthTrees(scenario.simulator().world(), config.sim.start, frames, 0.0, base);
    bag.write("/ground_truth/trees", t0, *trees);
    bag.write("/ground_truth/tree_markers", t0, *toTreeMarkers(*trees, "true_trees", 0.55f, 0.35f, 0.15f));
    if (image)
      bag.write("/ground_truth/map", t0, *toTruthMap(*image, config.sim.start, frames, 0.0, base));

    nav_msgs::Path truth_path;
    truth_path.header.frame_id = frames.map;
    std::size_t n_odom = 0, n_points = 0, n_scans = 0, n_imu = 0, n_truth = 0, n_gps = 0;
    core::SimulatorOutput step_out;
    double last_report = -1.0;
    bool running = true;
    while (running)
    {
      if (g_interrupted)
        throw std::runtime_error("interrupted");
      step_out.clear();
      running = scenario.step(&step_out);
      const ros::Time now = toRosTime(scenario.simulator().time(), base);
      for (const auto& o : step_out.odometry)
      {
        bag.write("/odom", now, *toOdometry(o, frames, base));
        tf2_msgs::TFMessage tf;
        tf.transforms.push_back(toOdomTf(o, frames, base));
        bag.write("/tf", now, tf);
        ++n_odom;
      }
      for (const auto& s : step_out.imu)
      {
        bag.write("/imu/data", now, *toImu(s, config.sim.imu, frames.base, base));
        ++n_imu;
      }
      for (const auto& s : step_out.sweeps)
      {
        bag.write("/points", now, *toPointCloud2(s, frames.lidar3d, base));
        ++n_points;
      }
      for (const auto& s : step_out.scans)
      {
        bag.write("/scan", now, *toLaserScan(s, frames.lidar2d, base));
        ++n_scans;
      }
      for (const auto& g : step_out.gnss)
      {
        const ros::Time stamp = toRosTime(g.fix.stamp, base);
        const double vertical = config.sim.gnss.vertical_factor;
        bag.write("/gps/fix", now, *toNavSatFix(g.fix, frames.gps, stamp, vertical));
        bag.write("/ground_truth/fix", now, *toNavSatFix(g.truth, frames.gps, stamp, vertical));
        ++n_gps;
      }
      for (const auto& t : step_out.truth)
      {
        const auto msg = toTruthOdometry(t, config.sim.start, start_ground_z, frames, base);
        bag.write("/ground_truth/odom", now, *msg);
        geometry_msgs::PoseStamped pose;
        pose.header = msg->header;
        pose.pose = msg->pose.pose;
        truth_path.poses.push_back(pose);
        ++n_truth;
      }
      const double t = scenario.simulator().time();
      if (!quiet && t - last_report >= 0.5)
      {
        progress(t, expected, false);
        last_report = t;
      }
    }
    if (const core::Collision* c = scenario.simulator().collision())
    {
      if (!quiet)
        std::fprintf(stderr, "\n");
      std::fprintf(stderr,
                   "record_scenario: COLLISION at %.2f s: the robot's footprint touched %s at true pose (%.2f, %.2f, "
                   "%.1f deg) in the world; the run ended there; no bag written\n",
                   c->stamp, c->what(scenario.simulator().world()).c_str(), c->pose.x, c->pose.y,
                   c->pose.theta * 180.0 / M_PI);
      return 3;  // the bag and the temporary file are removed as they go out of scope
    }
    truth_path.header.stamp = toRosTime(scenario.simulator().time(), base);
    bag.write("/ground_truth/path", truth_path.header.stamp, truth_path);
    bag.close();
    output.commit();
    if (!quiet)
      progress(scenario.simulator().time(), expected, true);

    const core::Pose2 truth = core::between(config.sim.start, scenario.simulator().robot().pose());
    std::printf("record_scenario: wrote %s: %.1f s simulated, drive '%s' %s, seed %d\n", out.c_str(),
                scenario.simulator().time(), drive.c_str(),
                scenario.timedOut() ? "TIMED OUT before its end" : "completed", seed);
    std::printf("  /points %zu  /scan %zu  /odom %zu  /imu/data %zu  /gps/fix %zu  /ground_truth/odom %zu  (+ /tf, "
                "/tf_static, /ground_truth/trees, /ground_truth/tree_markers, /ground_truth/path%s)\n",
                n_points, n_scans, n_odom, n_imu, n_gps, n_truth, n_gps > 0 ? ", /ground_truth/fix" : "");
    std::printf("  final true pose in the start frame: (%.2f, %.2f, %.1f deg)\n", truth.x, truth.y,
                truth.theta * 180.0 / M_PI);
    return scenario.timedOut() ? 1 : 0;
  }
  catch (const std::exception& e)
  {
    if (!quiet)
      std::fprintf(stderr, "\n");
    std::fprintf(stderr, "record_scenario: %s; no bag written\n", e.what());
    return g_interrupted ? 130 : 1;
  }
}
