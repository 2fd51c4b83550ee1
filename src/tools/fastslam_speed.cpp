// Speed and memory of FastSLAM on one core; prints figures. Not a test.
//
//  1. One filter update (predict + update) with 100 and 1000 particles and about 10 visible trunks, in a known
//     map of 50 and 500 landmarks (a strip of forest 24 m wide, the robot driving along its middle at 0.1 m
//     per update; every particle starts with the same map, shared copy-on-write, its landmarks numbered
//     along the strip as a robot driving it would have created them).
//  2. The whole pipeline (trunk extraction + FastSLAM, 100 particles) per simulated VLP-16 sweep, on the
//     paper world and the dense world (the in-process runner, straight drive, seed 1).
//  3. Heap in use with 1000 particles against the map size, and the peak resident size.
//
//   rosrun rbpf_slam fastslam_speed [--updates K] [--proposal fastslam1|fastslam2] [--mixture F]
//                                   [--no-pipeline]
#include <pcl/console/print.h>
#include <malloc.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "package_dir.h"
#include "rbpf_slam/core/fastslam/fastslam.h"
#include "rbpf_slam/eval/forest_slam_runner.h"
#include "rbpf_slam/sim/world_file.h"

using namespace rbpf_slam;

namespace
{
constexpr double kDensity = 10.0 / (M_PI * (12.0 * 12.0 - 1.0));  // [1/m^2] 10 trunks in the 1-12 m scope
constexpr double kStripHalfWidth = 12.0;                          // [m]

struct Strip
{
  std::vector<Eigen::Vector2d> trees;
  double length = 0.0;
};

Strip makeStrip(int landmarks, std::mt19937_64& rng)
{
  Strip s;
  s.length = landmarks / (kDensity * 2.0 * kStripHalfWidth);
  std::uniform_real_distribution<double> x(0.0, s.length), y(-kStripHalfWidth, kStripHalfWidth);
  for (int i = 0; i < landmarks; ++i)
    s.trees.emplace_back(x(rng), y(rng));
  // In the order a robot driving along the strip would have mapped them (neighbours share chunks).
  std::sort(s.trees.begin(), s.trees.end(), [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() < b.x(); });
  return s;
}

core::LandmarkMap knownMap(const Strip& s)
{
  core::LandmarkMap map;
  for (std::size_t i = 0; i < s.trees.size(); ++i)
  {
    core::Landmark l;
    l.mean = s.trees[i];
    l.covariance = 0.02 * 0.02 * Eigen::Matrix2d::Identity();
    l.radius = 0.15;
    l.radius_variance = 0.01 * 0.01;
    l.evidence = 4.0;
    l.observations = 10;
    l.provisional = false;
    l.id = static_cast<int>(i);
    map.add(l);
  }
  return map;
}

std::vector<core::LandmarkObservation> observe(const Strip& s, const core::Pose2& pose, std::mt19937_64& rng)
{
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<core::LandmarkObservation> obs;
  for (const auto& t : s.trees)
  {
    const double dx = t.x() - pose.x, dy = t.y() - pose.y;
    const double r = std::hypot(dx, dy);
    if (r < 1.0 || r > 12.0)
      continue;
    core::LandmarkObservation o;
    o.range = r + 0.02 * n(rng);
    o.bearing = core::wrapAngle(std::atan2(dy, dx) - pose.theta + 0.003 * n(rng));
    o.covariance << 0.02 * 0.02, 0.0, 0.0, 0.003 * 0.003;
    o.radius = 0.15 + 0.005 * n(rng);
    o.radius_variance = 0.01 * 0.01;
    obs.push_back(o);
  }
  return obs;
}

std::size_t heapInUse()
{
  const struct mallinfo2 m = mallinfo2();
  return m.uordblks + m.hblkhd;
}

struct UpdateFigures
{
  double ms = 0.0;        // mean per update (predict + update)
  double ms_worst = 0.0;  // slowest update
  double visible = 0.0;   // mean observations per update
  double final_error = 0.0, odometry_error = 0.0;
  std::size_t heap = 0;   // heap in use at the end, minus before the filter was made
};

UpdateFigures timeUpdates(int particles, int landmarks, int updates, core::PoseProposal proposal, double mixture)
{
  std::mt19937_64 rng(static_cast<std::uint64_t>(1000 * particles + landmarks));
  const Strip strip = makeStrip(landmarks, rng);
  const std::size_t heap_before = heapInUse();
  core::FastSlamConfig cfg;
  cfg.particles = particles;
  cfg.seed = 1;
  cfg.proposal = proposal;
  cfg.mixture_fraction = mixture;
  core::FastSlam filter(cfg);
  const double start_x = std::max(0.0, 0.5 * strip.length - 0.05 * updates);
  core::Pose2 truth(start_x, 0.0, 0.0), odometry = truth;
  filter.initialize(truth, knownMap(strip));
  std::normal_distribution<double> n(0.0, 1.0);
  UpdateFigures f;
  for (int k = 0; k < updates; ++k)
  {
    // Truth drives 0.1 m along x; odometry reads it with 2 % and 0.002 rad of error (the filter's class).
    const core::Pose2 step(0.1, 0.0, 0.0);
    const core::Pose2 measured(0.1 * (1.0 + 0.02 * n(rng)), 0.0, 0.002 * n(rng));
    const core::Pose2 next_odometry = odometry * measured;
    const core::OdometryIncrement u = core::decomposeOdometry(odometry, next_odometry);
    odometry = next_odometry;
    truth = truth * step;
    const auto obs = observe(strip, truth, rng);
    const auto t0 = std::chrono::steady_clock::now();
    filter.predict(u);
    filter.update(obs, core::Pose2());
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    f.ms += ms / updates;
    f.ms_worst = std::max(f.ms_worst, ms);
    f.visible += static_cast<double>(obs.size()) / updates;
  }
  const core::Pose2 est = filter.best().pose;
  f.final_error = std::hypot(est.x - truth.x, est.y - truth.y);
  f.odometry_error = std::hypot(odometry.x - truth.x, odometry.y - truth.y);
  f.heap = heapInUse() - heap_before;
  return f;
}

long peakRssKb()
{
  struct rusage u;
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}
}  // namespace

int main(int argc, char** argv)
{
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);  // PCL reports every failed RANSAC as an error
  int updates = 200;
  bool pipeline = true;
  double mixture = 0.0;
  core::PoseProposal proposal = core::PoseProposal::kFastSlam1;
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    if (a == "--updates" && has)
      updates = std::max(1, std::atoi(argv[++i]));
    else if (a == "--proposal" && has && core::parsePoseProposal(argv[i + 1], &proposal))
      ++i;
    else if (a == "--mixture" && has)
      mixture = std::atof(argv[++i]);
    else if (a == "--no-pipeline")
      pipeline = false;
    else
    {
      std::fprintf(stderr, "usage: %s [--updates K] [--proposal fastslam1|fastslam2] [--mixture F] [--no-pipeline]\n",
                   argv[0]);
      return 2;
    }
  }
  try
  {
    std::printf("1. One filter update (predict + update), %s%s, known map in a strip 24 m wide, %d updates of "
                "0.1 m, one core\n",
                core::toString(proposal), mixture > 0.0 ? (", mixture " + std::to_string(mixture)).c_str() : "",
                updates);
    std::printf("%10s %10s %8s %9s %9s %9s %11s %9s %10s\n", "particles", "landmarks", "visible", "ms/update",
                "worst ms", "rate Hz", "heap MB", "final m", "odom m");
    for (int particles : { 100, 1000 })
      for (int landmarks : { 50, 500 })
      {
        const UpdateFigures f = timeUpdates(particles, landmarks, updates, proposal, mixture);
        std::printf("%10d %10d %8.1f %9.3f %9.3f %9.0f %11.2f %9.3f %10.3f\n", particles, landmarks, f.visible, f.ms,
                    f.ms_worst, 1000.0 / f.ms, f.heap / 1e6, f.final_error, f.odometry_error);
        std::fflush(stdout);
      }

    std::printf("\n3. Heap in use with 1000 particles after %d updates against the map size (one shared map: "
                "%zu bytes per landmark in chunks of %zu)\n",
                updates, sizeof(core::Landmark), core::LandmarkMap::kChunk);
    std::printf("%10s %11s %15s %13s %9s\n", "landmarks", "heap MB", "bytes/particle", "ms/update", "rate Hz");
    for (int landmarks : { 50, 500, 5000 })
    {
      const UpdateFigures f = timeUpdates(1000, landmarks, updates, proposal, mixture);
      std::printf("%10d %11.2f %15.0f %13.3f %9.0f\n", landmarks, f.heap / 1e6, f.heap / 1000.0, f.ms, 1000.0 / f.ms);
      std::fflush(stdout);
    }

    if (pipeline)
    {
      std::printf("\n2. Whole pipeline (trunk extraction + FastSLAM, 100 particles, %s) per simulated VLP-16 sweep, "
                  "straight drive, seed 1\n",
                  core::toString(proposal));
      std::printf("%20s %8s %8s %14s %11s %12s %9s %9s %8s\n", "world", "method", "sweeps", "extraction ms",
                  "filter ms", "pipeline ms", "rate Hz", "final m", "DR m");
      for (const char* name : { "paper_forest", "dense_forest" })
        for (const char* method : { "circle", "centroid" })
        {
          const sim::ForestWorld world =
              sim::loadForestWorld(tools::packageFile(std::string("config/worlds/") + name + ".yaml"));
          eval::ForestSlamRunConfig cfg;
          cfg.scenario.drive = sim::straightDrive();
          core::parseTrunkMethod(method, &cfg.detector.method);
          cfg.filter.particles = 100;
          cfg.filter.proposal = proposal;
          cfg.filter.mixture_fraction = mixture;
          cfg.scenario.sim.seed = cfg.filter.seed = cfg.detector.seed = 1;
          const eval::ForestSlamRunResult r = eval::runForestSlam(world, cfg);
          const double n = std::max(1, r.sweeps);
          const double ext = 1000.0 * r.seconds_extraction / n, fil = 1000.0 * r.seconds_filter / n;
          std::printf("%20s %8s %8d %14.3f %11.3f %12.3f %9.0f %9.3f %8.3f\n", name, method, r.sweeps, ext, fil,
                      ext + fil, 1000.0 / (ext + fil), r.final_error, r.final_error_odometry);
          std::fflush(stdout);
        }
    }
    std::printf("\npeak resident size of this process: %.1f MB\n", peakRssKb() / 1024.0);
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "fastslam_speed: %s\n", e.what());
    return 1;
  }
  return 0;
}
