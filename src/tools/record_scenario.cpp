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
#include "rbpf_slam/sim/drive_check.h"
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
    "A drive the robot cannot follow (no way round the trunks and boxes within the follower's max_departure of it,\n"
    "or off the ground) is refused before it starts, with the reason (exit 4).\n"
    "If the robot's footprint touches a trunk or a box, the simulator stops it there: the recorder reports the\n"
    "collision (time, true pose, what was hit), writes no bag and exits with status 3. A drive not finished in time\n"
    "(the follower's time limit) keeps its bag and exits with status 5.\n"
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
/** Command-line options. */
struct Options
{
  std::string world_path, indoor_map, drive = "straight", config_path, out;
  int seed = 0;
  bool start_given = false;
  core::Pose2 start;
  bool points = true, quiet = !isatty(STDERR_FILENO);
};

/** The value of option @p a at argv[*i + 1] (advancing *i); exits with the usage status when there is none. */
void optionValue(int argc, char** argv, const std::string& a, int* i, std::string* v)
{
  if (*i + 1 >= argc)
  {
    std::fprintf(stderr, "record_scenario: %s needs a value\n%s", a.c_str(), kUsage);
    std::exit(2);
  }
  *v = argv[++*i];
}

/** --start X Y YAW_DEG; false (after saying why) for a value that is not a number. */
bool parseStart(int argc, char** argv, const std::string& a, int* i, Options* opt)
{
  std::string v;
  double* fields[3] = { &opt->start.x, &opt->start.y, &opt->start.theta };
  for (double* f : fields)
  {
    optionValue(argc, argv, a, i, &v);
    char* end = nullptr;
    *f = std::strtod(v.c_str(), &end);
    if (end == v.c_str() || *end != '\0' || !std::isfinite(*f))
    {
      std::fprintf(stderr, "record_scenario: --start takes three numbers X Y YAW_DEG, got '%s'\n", v.c_str());
      return false;
    }
  }
  opt->start.theta *= M_PI / 180.0;
  opt->start_given = true;
  return true;
}

/**
 * Reads the options. False when the program is to end at once with *status: 0 after --help, 2 after a usage error
 * (already reported).
 */
bool parseOptions(int argc, char** argv, Options* opt, int* status)
{
  *status = 2;
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    std::string v;
    if (a == "--world")
      optionValue(argc, argv, a, &i, &opt->world_path);
    else if (a == "--indoor-map")
      optionValue(argc, argv, a, &i, &opt->indoor_map);
    else if (a == "--drive")
      optionValue(argc, argv, a, &i, &opt->drive);
    else if (a == "--config")
      optionValue(argc, argv, a, &i, &opt->config_path);
    else if (a == "--out")
      optionValue(argc, argv, a, &i, &opt->out);
    else if (a == "--seed")
    {
      optionValue(argc, argv, a, &i, &v);
      char* end = nullptr;
      opt->seed = static_cast<int>(std::strtol(v.c_str(), &end, 10));
      if (*end != '\0')
      {
        std::fprintf(stderr, "record_scenario: --seed takes an integer, got '%s'\n", v.c_str());
        return false;
      }
    }
    else if (a == "--start")
    {
      if (!parseStart(argc, argv, a, &i, opt))
        return false;
    }
    else if (a == "--no-points")
      opt->points = false;
    else if (a == "--quiet")
      opt->quiet = true;
    else if (a == "-h" || a == "--help")
    {
      std::printf("%s", kUsage);
      *status = 0;
      return false;
    }
    else
    {
      std::fprintf(stderr, "record_scenario: unknown argument '%s'\n%s", a.c_str(), kUsage);
      return false;
    }
  }
  if ((opt->world_path.empty() == opt->indoor_map.empty()) || opt->out.empty())
  {
    std::fprintf(stderr, "record_scenario: give exactly one of --world/--indoor-map, and --out\n%s", kUsage);
    return false;
  }
  return true;
}

/** The scenario of --config over the defaults, with the seed, the start and the drive of the options. */
sim::ScenarioConfig readScenario(const Options& opt)
{
  std::vector<std::string> unknown;
  sim::ScenarioConfig config =
      sim::loadScenario(opt.config_path, opt.drive, opt.start_given ? &opt.start : nullptr, &unknown);
  for (const auto& k : unknown)
    std::fprintf(stderr, "record_scenario: warning: %s: unknown key '%s' ignored\n", opt.config_path.c_str(),
                 k.c_str());
  config.sim.seed = static_cast<std::uint64_t>(static_cast<std::int64_t>(opt.seed));
  return config;
}

/** The forest world, or the indoor map in @p image (with flat ground and the 2D lidar only). */
sim::ForestWorld loadWorld(const Options& opt, sim::ScenarioConfig* config,
                           std::shared_ptr<const core::OccupancyImage>* image)
{
  sim::ForestWorld world;
  if (!opt.indoor_map.empty())
  {
    *image = std::make_shared<const core::OccupancyImage>(io::loadMapImage(opt.indoor_map));
    world.ground.amplitude = 0.0;
    config->sim.lidar3d.enabled = false;
    config->sim.lidar2d.enabled = true;
  }
  else
  {
    world = sim::loadForestWorld(opt.world_path);
  }
  if (!opt.points)
    config->sim.lidar3d.enabled = false;
  return world;
}

/** What is written once at the start: the sensors' static transforms and the truth (trees, indoor map). */
void writeStatics(const sim::ScenarioConfig& config, const sim::ForestWorld& world, const core::OccupancyImage* image,
                  const SimFrames& frames, double base, rosbag::Bag* bag)
{
  tf2_msgs::TFMessage statics;
  statics.transforms = { toStaticTf(config.sim.lidar3d.mount, frames.base, frames.lidar3d, 0.0, base),
                         toStaticTf(config.sim.lidar2d.mount, frames.base, frames.lidar2d, 0.0, base) };
  if (config.sim.gnss.enabled)
    statics.transforms.push_back(toStaticTf(gpsMount(config.sim.gnss), frames.base, frames.gps, 0.0, base));
  const ros::Time t0 = toRosTime(0.0, base);
  bag->write("/tf_static", t0, statics);
  const auto trees = toTruthTrees(world, config.sim.start, frames, 0.0, base);
  bag->write("/ground_truth/trees", t0, *trees);
  bag->write("/ground_truth/tree_markers", t0, *toTreeMarkers(*trees, "true_trees", 0.55f, 0.35f, 0.15f));
  if (image)
    bag->write("/ground_truth/map", t0, *toTruthMap(*image, config.sim.start, frames, 0.0, base));
}

/** Writes each step's messages to the bag, counting them, and gathers the true path. */
class StepWriter
{
public:
  StepWriter(const sim::ScenarioConfig& config, const SimFrames& frames, double base, double start_ground_z,
             rosbag::Bag* bag)
      : config_(config), frames_(frames), base_(base), start_ground_z_(start_ground_z), bag_(*bag)
  {
    truth_path.header.frame_id = frames.map;
  }

  void write(const sim::SimulatorOutput& step_out, const ros::Time& now)
  {
    for (const auto& o : step_out.odometry)
    {
      bag_.write("/odom", now, *toOdometry(o, frames_, base_));
      tf2_msgs::TFMessage tf;
      tf.transforms.push_back(toOdomTf(o, frames_, base_));
      bag_.write("/tf", now, tf);
      ++n_odom;
    }
    for (const auto& s : step_out.imu)
    {
      bag_.write("/imu/data", now, *toImu(s, config_.sim.imu, frames_.base, base_));
      ++n_imu;
    }
    for (const auto& s : step_out.sweeps)
    {
      bag_.write("/points", now, *toPointCloud2(s, frames_.lidar3d, base_));
      ++n_points;
    }
    for (const auto& s : step_out.scans)
    {
      bag_.write("/scan", now, *toLaserScan(s, frames_.lidar2d, base_));
      ++n_scans;
    }
    for (const auto& g : step_out.gnss)
    {
      const ros::Time stamp = toRosTime(g.fix.stamp, base_);
      const double vertical = config_.sim.gnss.vertical_factor;
      bag_.write("/gps/fix", now, *toNavSatFix(g.fix, frames_.gps, stamp, vertical));
      bag_.write("/ground_truth/fix", now, *toNavSatFix(g.truth, frames_.gps, stamp, vertical));
      ++n_gps;
    }
    for (const auto& t : step_out.truth)
    {
      const auto msg = toTruthOdometry(t, config_.sim.start, start_ground_z_, frames_, base_);
      bag_.write("/ground_truth/odom", now, *msg);
      geometry_msgs::PoseStamped pose;
      pose.header = msg->header;
      pose.pose = msg->pose.pose;
      truth_path.poses.push_back(pose);
      ++n_truth;
    }
  }

  nav_msgs::Path truth_path;
  std::size_t n_odom = 0, n_points = 0, n_scans = 0, n_imu = 0, n_truth = 0, n_gps = 0;

private:
  const sim::ScenarioConfig& config_;
  const SimFrames& frames_;
  double base_;
  double start_ground_z_;
  rosbag::Bag& bag_;
};

/** Runs the scenario to its end, writing each step; throws when interrupted. */
void runScenario(const Options& opt, double expected, double base, sim::Scenario* scenario, StepWriter* writer)
{
  sim::SimulatorOutput step_out;
  double last_report = -1.0;
  bool running = true;
  while (running)
  {
    if (g_interrupted)
      throw std::runtime_error("interrupted");
    step_out.clear();
    running = scenario->step(&step_out);
    const ros::Time now = toRosTime(scenario->simulator().time(), base);
    writer->write(step_out, now);
    const double t = scenario->simulator().time();
    if (!opt.quiet && t - last_report >= 0.5)
    {
      progress(t, expected, false);
      last_report = t;
    }
  }
}

/** What was written and where the robot ended. */
void printSummary(const Options& opt, const sim::ScenarioConfig& config, sim::Scenario* scenario,
                  const StepWriter& writer)
{
  const core::Pose2 truth = core::between(config.sim.start, scenario->simulator().robot().pose());
  std::printf("record_scenario: wrote %s: %.1f s simulated, drive '%s' %s, seed %d\n", opt.out.c_str(),
              scenario->simulator().time(), opt.drive.c_str(),
              scenario->timedOut() ? "TIMED OUT before its end" : "completed", opt.seed);
  std::printf(
      "  /points %zu  /scan %zu  /odom %zu  /imu/data %zu  /gps/fix %zu  /ground_truth/odom %zu  (+ /tf, "
      "/tf_static, /ground_truth/trees, /ground_truth/tree_markers, /ground_truth/path%s)\n",
      writer.n_points, writer.n_scans, writer.n_odom, writer.n_imu, writer.n_gps, writer.n_truth,
      writer.n_gps > 0 ? ", /ground_truth/fix" : "");
  std::printf("  final true pose in the start frame: (%.2f, %.2f, %.1f deg)\n", truth.x, truth.y,
              truth.theta * 180.0 / M_PI);
}

/**
 * Records the scenario to the bag: 0 when the drive completed, 5 when it timed out (the bag kept), 3 (and no bag)
 * when the robot collided.
 */
int record(const Options& opt, const sim::ScenarioConfig& config, const core::OccupancyImage* image,
           sim::Scenario* scenario)
{
  const double start_ground_z =
      sim::Ground(scenario->simulator().world().ground).height(config.sim.start.x, config.sim.start.y);
  const sim::PathFollower probe(config.drive, config.follower);
  const double expected = probe.length() / config.follower.speed + config.settle;

  const SimFrames frames;
  const double base = 1000.0;
  io::AtomicFile output(opt.out);  // removed again if the recording does not complete
  rosbag::Bag bag(output.temporary(), rosbag::bagmode::Write);
  bag.setCompression(rosbag::compression::LZ4);
  writeStatics(config, scenario->simulator().world(), image, frames, base, &bag);

  StepWriter writer(config, frames, base, start_ground_z, &bag);
  runScenario(opt, expected, base, scenario, &writer);
  if (const sim::Collision* c = scenario->simulator().collision())
  {
    if (!opt.quiet)
      std::fprintf(stderr, "\n");
    std::fprintf(stderr,
                 "record_scenario: COLLISION at %.2f s: the robot's footprint touched %s at true pose (%.2f, %.2f, "
                 "%.1f deg) in the world; the run ended there; no bag written\n",
                 c->stamp, c->what(scenario->simulator().world()).c_str(), c->pose.x, c->pose.y,
                 c->pose.theta * 180.0 / M_PI);
    return sim::exit_status::kCollided;  // the bag and the temporary file are removed as they go out of scope
  }
  writer.truth_path.header.stamp = toRosTime(scenario->simulator().time(), base);
  bag.write("/ground_truth/path", writer.truth_path.header.stamp, writer.truth_path);
  bag.close();
  output.commit();
  if (!opt.quiet)
    progress(scenario->simulator().time(), expected, true);
  printSummary(opt, config, scenario, writer);
  return scenario->timedOut() ? sim::exit_status::kTimedOut : 0;
}
}  // namespace

int main(int argc, char** argv)
{
  Options opt;
  int status = 0;
  if (!parseOptions(argc, argv, &opt, &status))
    return status;

  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  try
  {
    sim::ScenarioConfig config = readScenario(opt);
    std::shared_ptr<const core::OccupancyImage> image;
    const sim::ForestWorld world = loadWorld(opt, &config, &image);
    std::string refused;
    if (!image && !sim::checkDrive(world, config, &refused))
    {
      std::fprintf(stderr, "record_scenario: the drive '%s' is refused before it starts: %s; no bag written\n",
                   opt.drive.c_str(), refused.c_str());
      return sim::exit_status::kRefused;
    }
    sim::Scenario scenario(world, config, image);
    return record(opt, config, image.get(), &scenario);
  }
  catch (const std::exception& e)
  {
    if (!opt.quiet)
      std::fprintf(stderr, "\n");
    std::fprintf(stderr, "record_scenario: %s; no bag written\n", e.what());
    return g_interrupted ? 130 : 1;
  }
}
