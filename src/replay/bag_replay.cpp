#include "rbpf_slam/replay/bag_replay.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>

#include <sys/stat.h>
#include <unistd.h>

#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_msgs/TFMessage.h>

#include "rbpf_slam/TrunkArray.h"
#include "rbpf_slam/core/fastslam/fastslam.h"
#include "rbpf_slam/ros/pose_msgs.h"

namespace rbpf_slam
{
namespace replay
{
namespace
{
volatile std::sig_atomic_t g_signal = 0;
void onSignal(int signum) { g_signal = signum; }

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

/** @brief Options without a value; false when @p a is not one of them. */
bool parseFlag(const std::string& a, SlamBagOptions* o)
{
  if (a == "--help" || a == "-h")
    o->help = true;
  else if (a == "--quiet")
    o->quiet = true;
  else if (a == "--odometry-only")
    o->odometry_only = true;
  else if (a == "--every-scan")
    o->every_scan = true;
  else if (a == "--no-gps")
    o->no_gps = true;
  else
    return false;
  return true;
}

/** @brief Options of topics and files (one value each); false when @p a is not one of them. */
bool parseName(const std::string& a, const char* v, SlamBagOptions* o)
{
  static const std::map<std::string, std::string SlamBagOptions::*> names{
    { "--filter", &SlamBagOptions::filter },
    { "--bag", &SlamBagOptions::bag_path },
    { "--points", &SlamBagOptions::points_topic },
    { "--landmarks", &SlamBagOptions::landmarks_topic },
    { "--extraction-config", &SlamBagOptions::extraction_config_path },
    { "--odom", &SlamBagOptions::odom_topic },
    { "--base-frame", &SlamBagOptions::base_frame },
    { "--method", &SlamBagOptions::method },
    { "--resampling", &SlamBagOptions::resampling },
    { "--wheels", &SlamBagOptions::wheels_topic },
    { "--imu", &SlamBagOptions::imu_topic },
    { "--out", &SlamBagOptions::out_dir },
    { "--map", &SlamBagOptions::map_path },
    { "--save-map", &SlamBagOptions::save_map_path },
  };
  const auto it = names.find(a);
  if (it != names.end())
    o->*(it->second) = v;
  else if (a == "--scan")
  {
    o->scan_topic = v;
    o->scan_given = true;
  }
  else if (a == "--gps")
  {
    o->gps_topic = v;
    o->gps_given = true;
  }
  else if (a == "--config")
    o->config_paths.push_back(v);
  else
    return false;
  return true;
}

/** @brief Options of numbers (one value each); false when @p a is not one of them. */
bool parseValue(const std::string& a, const char* v, SlamBagOptions* o)
{
  if (a == "--particles")
    o->particles = static_cast<int>(parseInteger(a, v, 1, core::FastSlamConfig::kMaxParticles));
  else if (a == "--seed")
    o->seed = parseInteger(a, v, 0, std::numeric_limits<long>::max());
  else if (a == "--wheel-radius")
    o->wheel_radius = parseNumber(a, v, 1e-3, 10.0);
  else if (a == "--track")
    o->track = parseNumber(a, v, 1e-3, 100.0);
  else if (a == "--imu-weight")
    o->imu_weight = parseNumber(a, v, 0.0, 1.0);
  else
    return false;
  return true;
}

/** @brief The options that go with one filter only, or exclude each other. */
void checkCombinations(const SlamBagOptions& o)
{
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
}  // namespace

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

SlamBagOptions parseOptions(int argc, char** argv)
{
  SlamBagOptions o;
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    if (parseFlag(a, &o))
    {
      if (o.help)
        return o;
      continue;
    }
    if (a.compare(0, 2, "--") == 0 && i + 1 >= argc)
      throw std::invalid_argument(a + " needs a value");
    if (a == "--changes")
      throw std::invalid_argument("--changes is gone: with --map, --save-map FILE.csv writes the changes since that "
                                  "map beside it (FILE_changes.csv)");
    if (a == "--initial-pose")
    {
      if (i + 3 >= argc)
        throw std::invalid_argument("--initial-pose needs X Y YAW_DEG");
      o.initial_x = parseNumber(a, argv[++i], -1e7, 1e7);
      o.initial_y = parseNumber(a, argv[++i], -1e7, 1e7);
      o.initial_yaw = parseNumber(a, argv[++i], -360.0, 360.0) * M_PI / 180.0;
      o.initial_given = true;
    }
    else if (!parseName(a, argv[i + 1], &o) && !parseValue(a, argv[i + 1], &o))
      throw std::invalid_argument("unknown argument '" + a + "' (--help lists the options)");
    else
      ++i;
  }
  checkCombinations(o);
  return o;
}

void checkPaths(const SlamBagOptions& o)
{
  // A filter's short file (config/X.yaml) holds the keys a user sets; its advanced file (config/X_advanced.yaml)
  // the rest. The short file alone leaves the advanced keys at their built-in values, which is not the node's filter.
  for (std::size_t i = 0; i < o.config_paths.size(); ++i)
  {
    const std::string advanced = io::withoutExtension(o.config_paths[i]) + "_advanced.yaml";
    struct stat beside;
    if (::stat(advanced.c_str(), &beside) == 0 &&
        std::find(o.config_paths.begin(), o.config_paths.begin() + static_cast<long>(i), advanced) ==
            o.config_paths.begin() + static_cast<long>(i))
      std::fprintf(stderr, "slam_bag: warning: %s is given without %s before it: its advanced keys keep their "
                   "built-in values, not the node's (--config %s --config %s)\n", o.config_paths[i].c_str(),
                   advanced.c_str(), advanced.c_str(), o.config_paths[i].c_str());
  }

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
}

void catchSignals()
{
  struct sigaction action;
  std::memset(&action, 0, sizeof(action));
  action.sa_handler = onSignal;
  for (const int signum : { SIGINT, SIGTERM, SIGHUP })
    sigaction(signum, &action, nullptr);
}

int interruption() { return static_cast<int>(g_signal); }

void checkInterrupted()
{
  if (g_signal != 0)
    throw std::runtime_error("interrupted by signal " + std::to_string(static_cast<int>(g_signal)) +
                             "; no output written");
}

std::ostringstream& Outputs::stream(const std::string& name)
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

void Outputs::add(const std::vector<io::FileContent>& files)
{
  extra_.insert(extra_.end(), files.begin(), files.end());
}

void Outputs::commit()
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

std::map<std::string, std::string> bagTopics(rosbag::Bag& bag)
{
  std::map<std::string, std::string> topics;
  rosbag::View all(bag);
  for (const rosbag::ConnectionInfo* c : all.getConnections())
    topics[c->topic] = c->datatype;
  return topics;
}

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

std::string firstFrame(rosbag::Bag& bag, const std::string& topic)
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
  return "";
}

void DropLog::drop(const std::string& topic, double stamp, const std::string& why)
{
  ++count_;
  ++per_topic_[topic];
  if (count_ <= 5)
    std::fprintf(stderr, "slam_bag: warning: %s at %.3f: %s; dropped%s\n", topic.c_str(), stamp, why.c_str(),
                 count_ == 5 ? " (further drops are only counted)" : "");
}

int DropLog::count(const std::string& topic) const
{
  const auto it = per_topic_.find(topic);
  return it == per_topic_.end() ? 0 : it->second;
}

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

double peakResidentMegabytes()
{
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.compare(0, 6, "VmHWM:") == 0)
      return std::atof(line.c_str() + 6) / 1024.0;
  return 0.0;
}

void warnUnusedKeys(const std::string& path, const std::vector<std::string>& keys)
{
  for (const auto& key : keys)
    if (std::find(io::nodeOnlyKeys().begin(), io::nodeOnlyKeys().end(), key) == io::nodeOnlyKeys().end())
      std::fprintf(stderr, "slam_bag: warning: %s: key '%s' is not one of this filter's (misspelt?); ignored\n",
                   path.c_str(), key.c_str());
}

}  // namespace replay
}  // namespace rbpf_slam
