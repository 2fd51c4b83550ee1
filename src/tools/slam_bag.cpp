// The offline runner for bags, for both filters: the same pipelines as the nodelets, as fast as they compute (no
// roscore, no real-time wait). Reads only the sensor topics named here and /tf_static: never the truth.
//
//   rosrun rbpf_slam slam_bag --filter fastslam --bag FILE [--points /points | --scan /scan | --landmarks TOPIC]
//       [--odom /odom]
//       [--base-frame base_link] [--extraction-config YAML] [--config YAML] [--particles N] [--seed S]
//       [--method circle|centroid] [--out DIR] [--quiet]
//   rosrun rbpf_slam slam_bag --filter grid --bag FILE [--scan /scan] [--odom /odom] [--base-frame base_link]
//       [--particles N] [--seed S] [--config YAML] [--resampling low_variance|multinomial]
//       [--every-scan] [--wheels /wheel_ticks [--wheel-radius 0.127] [--track 0.7283] [--imu /imu/data --imu-weight W]]
//       [--out DIR] [--quiet]
//
// --config is the filter's YAML (repeated, each file overrides the ones before it, e.g. the advanced file, the
// user's file, then an odometry class of config/odometry/), --extraction-config the trunk extraction's
// (config/trunk_extraction.yaml layout); one pair per sensor type, e.g. config/lego/; --particles, --seed, --method
// and --every-scan override them (--every-scan: grid SLAM processes every scan, its travel thresholds
// linear_update, angular_update and temporal_update all 0, whatever the files say; for benchmarks). FastSLAM reads
// point clouds, or 2D scans when --scan is given, or the detections of any landmark detector (rbpf_slam/TrunkArray
// in the sensor frame) when --landmarks is given.
//
// Every output file is written at the end, atomically (to a temporary, then renamed): a run that fails or is
// interrupted (SIGINT, SIGTERM, SIGHUP) leaves no output behind. Messages whose stamps go back by more than a second
// restart the filter (a looped bag), as the nodes do; unreadable messages are dropped and counted. The outputs of
// each filter: replay/grid_bag_run.h and replay/fastslam_bag_run.h.
//
// A grid run loads neither PCL nor Ceres: FastSLAM's runner is a library of its own, loaded only for a FastSLAM run.
#include <cstdio>
#include <stdexcept>
#include <string>

#include <dlfcn.h>
#include <unistd.h>

#include "rbpf_slam/replay/bag_replay.h"
#include "rbpf_slam/replay/fastslam_bag_run.h"
#include "rbpf_slam/replay/grid_bag_run.h"

using namespace rbpf_slam;

namespace
{
/**
 * @brief FastSLAM's runner, from its library: found as the dynamic loader finds libraries (the program's run path,
 * LD_LIBRARY_PATH), else in the library folder of the program's own space (lib/ above lib/rbpf_slam/, in a devel
 * and an install space alike). @throws std::runtime_error naming the library when it cannot be loaded.
 */
replay::FastSlamRunner loadFastSlamRunner()
{
  void* library = dlopen(replay::kFastSlamRunnerLibrary, RTLD_NOW | RTLD_LOCAL);
  if (!library)
  {
    const std::string first = dlerror();
    char self[4096];
    const ssize_t n = readlink("/proc/self/exe", self, sizeof(self) - 1);
    std::string beside;
    if (n > 0)
    {
      const std::string exe(self, static_cast<std::size_t>(n));
      const std::string dir = exe.substr(0, exe.rfind('/'));
      beside = dir.substr(0, dir.rfind('/')) + "/" + replay::kFastSlamRunnerLibrary;
      library = dlopen(beside.c_str(), RTLD_NOW | RTLD_LOCAL);
    }
    if (!library)
      throw std::runtime_error("cannot load FastSLAM's runner " + std::string(replay::kFastSlamRunnerLibrary) + " (" +
                               first + (beside.empty() ? "" : "; nor " + beside) + ")");
  }
  dlerror();
  void* symbol = dlsym(library, replay::kFastSlamRunnerSymbol);
  if (!symbol)
    throw std::runtime_error(std::string("FastSLAM's runner has no entry ") + replay::kFastSlamRunnerSymbol + ": " +
                             dlerror());
  return reinterpret_cast<replay::FastSlamRunner>(symbol);
}
}  // namespace

int main(int argc, char** argv)
{
  replay::SlamBagOptions o;
  try
  {
    o = replay::parseOptions(argc, argv);
  }
  catch (const std::invalid_argument& e)
  {
    std::fprintf(stderr, "slam_bag: %s (usage: %s --help)\n", e.what(), argv[0]);
    return 2;
  }
  if (o.help)
  {
    replay::usage(argv[0]);
    return 0;
  }
  replay::catchSignals();
  try
  {
    replay::checkPaths(o);
    if (o.filter == "grid")
      return replay::runGridBag(o);
    return loadFastSlamRunner()(&o);
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "slam_bag: %s\n", e.what());
    return replay::interruption() != 0 ? 128 + replay::interruption() : 1;
  }
}
