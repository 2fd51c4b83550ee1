#ifndef RBPF_SLAM_REPLAY_BAG_REPLAY_H
#define RBPF_SLAM_REPLAY_BAG_REPLAY_H

#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <rosbag/bag.h>

#include "rbpf_slam/core/filter/pose2.h"
#include "rbpf_slam/core/filter/stamp_gate.h"
#include "rbpf_slam/io/files.h"
#include "rbpf_slam/io/param_source.h"

namespace rbpf_slam
{
namespace replay
{
/** @brief What slam_bag was asked to do (its command line; slam_bag --help). */
struct SlamBagOptions
{
  std::string filter = "fastslam";
  std::string bag_path, points_topic = "/points", scan_topic = "/scan", odom_topic = "/odom";
  std::string base_frame = "base_link", out_dir, method, extraction_config_path, resampling;
  std::vector<std::string> config_paths;  ///< the filter's YAML files, each overriding the ones before
  bool scan_given = false;                ///< fastslam: 2D scans instead of point clouds
  std::string landmarks_topic;            ///< fastslam: a detector's TrunkArrays instead of clouds or scans
  std::string map_path, save_map_path;    ///< fastslam: the tree map to start from, the tree map to write
  double initial_x = 0.0, initial_y = 0.0, initial_yaw = 0.0;  ///< fastslam: base_link in that map at the start
  bool initial_given = false;
  std::string wheels_topic, imu_topic = "/imu/data";
  std::string gps_topic = "/gps/fix";  ///< fastslam: satellite fixes, used when the bag has them
  bool gps_given = false, no_gps = false;
  int particles = -1;  ///< the filter's default
  long seed = -1;      ///< the configuration's (0 by default)
  bool quiet = false;
  bool odometry_only = false;  ///< grid: a bag without scans (wheel odometry, with and without the gyro)
  bool every_scan = false;     ///< grid: travel thresholds off (every scan processed), over the config files
  double wheel_radius = 0.127, track = 0.7283, imu_weight = 0.0;
  bool help = false;  ///< --help: print usage() and do nothing else
};

/** @brief slam_bag's usage text. */
void usage(const char* argv0);
/**
 * @brief The options of slam_bag's command line, checked against each other.
 * @throws std::invalid_argument naming the option that is wrong.
 */
SlamBagOptions parseOptions(int argc, char** argv);
/** @brief Checks, before a long run, that the bag is a file and that the output folders can be written. */
void checkPaths(const SlamBagOptions& o);

/** @brief Makes SIGINT, SIGTERM and SIGHUP end the run cleanly: interrupted() says so, and no output is written. */
void catchSignals();
/** @brief The signal that arrived (0: none). */
int interruption();
/** @brief Throws when SIGINT, SIGTERM or SIGHUP arrived: nothing has been written yet, and nothing will be. */
void checkInterrupted();

/** @brief The run's output files, held until the run completes, then written at once, atomically. */
class Outputs
{
public:
  explicit Outputs(std::string dir) : dir_(std::move(dir)) {}
  bool enabled() const { return !dir_.empty(); }
  /** @brief The text of the file @p name in the folder (12 significant digits), made on first use. */
  std::ostringstream& stream(const std::string& name);
  /** @brief A file of its own path (beside the folder, e.g. --save-map's). */
  void add(const std::string& path, const std::string& content) { extra_.emplace_back(path, content); }
  void add(const std::vector<io::FileContent>& files);
  const std::string& dir() const { return dir_; }
  /** @brief Writes every file (after checkInterrupted()); the folder is made first. */
  void commit();

private:
  std::string dir_;
  std::map<std::string, std::unique_ptr<std::ostringstream>> streams_;
  std::vector<std::string> order_;
  std::vector<io::FileContent> extra_;
};

/** @brief Opens a bag for reading. @throws std::runtime_error naming the file. */
void openBag(const std::string& path, rosbag::Bag* bag);
/** @brief The topics of the bag with their types. */
std::map<std::string, std::string> bagTopics(rosbag::Bag& bag);
/** @brief Throws, listing what the bag holds, unless @p topic is in it with type @p type. */
void requireTopic(const std::map<std::string, std::string>& topics, const std::string& bag, const std::string& topic,
                  const std::string& type, const char* option);
/** @brief The transform base_frame -> child on /tf_static (planar part), if present. */
bool staticMount(rosbag::Bag& bag, const std::string& base_frame, const std::string& child, core::SensorMount* mount);
/** @brief The frame the first message on @p topic names (clouds, scans, trunk arrays); "" when none does. */
std::string firstFrame(rosbag::Bag& bag, const std::string& topic);

/** @brief Counts dropped messages per topic; the first few are explained on stderr, all of them in the summary. */
class DropLog
{
public:
  void drop(const std::string& topic, double stamp, const std::string& why);
  int count() const { return count_; }
  int count(const std::string& topic) const;

private:
  int count_ = 0;
  std::map<std::string, int> per_topic_;
};

/**
 * @brief What the pipeline made of one message's stamp (its core::TimelineGate, as in the nodes): true when the
 * message was used; a drop is counted, a restart said.
 */
bool admitted(core::StampVerdict v, const std::string& topic, double stamp, DropLog* drops);

/**
 * @brief The one bag loop of both filters: every message of @p topics in record order goes to @p feed, then
 * @p process runs with the record time as the clock (so a sensor message waits for odometry exactly as long as
 * the bag says it did); at the end @p process flushes.
 */
void replay(rosbag::Bag& bag, const std::vector<std::string>& topics,
            const std::function<void(const rosbag::MessageInstance&, double clock)>& feed,
            const std::function<void(double clock, bool flush)>& process);

/** @brief This process's peak resident memory [MB] (VmHWM of /proc/self/status); 0 where it cannot be read. */
double peakResidentMegabytes();

/** @brief Warns of each key of @p path that no reader took (the nodes' own keys excepted). */
void warnUnusedKeys(const std::string& path, const std::vector<std::string>& keys);
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
  warnUnusedKeys(path, yaml.unusedKeys());
}

}  // namespace replay
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_REPLAY_BAG_REPLAY_H
