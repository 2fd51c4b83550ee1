// Prints the forest simulator's figures: time to cast one VLP-16 sweep (28,800 rays) among the
// trees of a world, and the dead-reckoning drift of the reference drives over seeds.
//   sim_benchmark [--world FILE]... [--seeds N] [--sweeps N]
// Without --world: the paper world and a generated 150-tree stand of the same area.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "package_dir.h"
#include "rbpf_slam/sim/forest_simulator.h"
#include "rbpf_slam/sim/scenario.h"
#include "rbpf_slam/sim/world_file.h"

using namespace rbpf_slam;

namespace
{
double median(std::vector<double> v)
{
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n == 0 ? NAN : (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
}

/** @brief A stand of @p n trunks on 30 x 30 m, >= 1.2 m apart, like the paper world's clutter. */
sim::ForestWorld generatedStand(int n, std::uint64_t seed)
{
  sim::ForestWorld world;
  core::Random random(seed);
  for (int attempts = 0; static_cast<int>(world.trunks.size()) < n && attempts < 100000; ++attempts)
  {
    sim::TrunkSpec t;
    t.x = random.uniform(0.0, 30.0);
    t.y = random.uniform(0.0, 30.0);
    t.radius = random.uniform(0.1, 0.3);
    bool ok = true;
    for (const auto& o : world.trunks)
      ok = ok && std::hypot(o.x - t.x, o.y - t.y) > 1.2;
    if (ok)
      world.trunks.push_back(t);
  }
  world.ground.amplitude = 0.3;
  sim::ClutterSpec clutter;
  clutter.bushes = 12;
  clutter.rocks = 6;
  clutter.branches = 10;
  sim::addClutter(clutter, &world);
  return world;
}

void benchmarkCast(const std::string& name, const sim::ForestWorld& world, int sweeps)
{
  sim::SimulatorConfig config;
  config.start = core::Pose2(15.0, 15.0, 0.3);
  sim::ForestSimulator sim(world, config);
  sim::LidarSweep sweep;
  std::vector<double> ms;
  std::size_t points = 0;
  for (int i = 0; i < sweeps; ++i)
  {
    const auto t0 = std::chrono::steady_clock::now();
    sim.castSweep(0.0, &sweep);
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    points += sweep.points.size();
  }
  const int rays = config.lidar3d.rings * static_cast<int>(std::lround(2 * M_PI / config.lidar3d.azimuth_resolution));
  std::printf("%-28s %6zu trunks %6zu clutter  %6d rays  %8.2f ms median  %8.2f ms worst  %7zu returns/sweep\n",
              name.c_str(), world.trunks.size(), world.foliage.size() + world.rocks.size() + world.branches.size(),
              rays, median(ms), *std::max_element(ms.begin(), ms.end()), points / std::max(1, sweeps));
}

void benchmarkDrift(const std::string& name, const sim::ForestWorld& world, const std::vector<Eigen::Vector2d>& drive,
                    int seeds)
{
  std::vector<double> final_error, sideways, along;
  for (int seed = 0; seed < seeds; ++seed)
  {
    sim::ScenarioConfig config;
    config.sim.seed = static_cast<std::uint64_t>(seed);
    config.sim.lidar3d.enabled = false;
    config.drive = drive;
    sim::Scenario scenario(world, config);
    sim::SimulatorOutput out;
    core::Pose2 odom;
    while (true)
    {
      out.clear();
      const bool running = scenario.step(&out);
      for (const auto& o : out.odometry)
        odom = o.pose;
      if (!running)
        break;
    }
    // Truth in the start frame (where odometry starts), compared with the final odometry pose.
    const core::Pose2 truth = core::between(config.sim.start, scenario.simulator().robot().pose());
    const core::Pose2 err = core::between(truth, odom);  // odometry's error in the true robot frame
    final_error.push_back(std::hypot(err.x, err.y));
    sideways.push_back(std::abs(err.y));
    along.push_back(std::abs(err.x));
  }
  std::printf("%-28s seeds %3d  final error median %.2f m (min %.2f, max %.2f)  sideways median %.2f m (min %.2f)"
              "  along median %.2f m\n",
              name.c_str(), seeds, median(final_error), *std::min_element(final_error.begin(), final_error.end()),
              *std::max_element(final_error.begin(), final_error.end()), median(sideways),
              *std::min_element(sideways.begin(), sideways.end()), median(along));
}
}  // namespace

int main(int argc, char** argv)
{
  std::vector<std::string> worlds;
  int seeds = 20, sweeps = 20;
  for (int i = 1; i < argc; ++i)
  {
    const std::string arg = argv[i];
    if (arg == "--world" && i + 1 < argc)
      worlds.push_back(argv[++i]);
    else if (arg == "--seeds" && i + 1 < argc)
      seeds = std::atoi(argv[++i]);
    else if (arg == "--sweeps" && i + 1 < argc)
      sweeps = std::atoi(argv[++i]);
    else
    {
      std::fprintf(stderr, "usage: %s [--world FILE]... [--seeds N] [--sweeps N]\n", argv[0]);
      return 2;
    }
  }
  const bool default_worlds = worlds.empty();
  if (default_worlds)
  {
    worlds.push_back(tools::packageFile("config/worlds/paper_forest.yaml"));
    worlds.push_back(tools::packageFile("config/worlds/dense_forest.yaml"));
  }
  try
  {
    std::printf("== Cast time of one VLP-16 sweep (16 rings x 1800 columns, one core)\n");
    std::vector<std::pair<std::string, sim::ForestWorld>> loaded;
    for (const auto& path : worlds)
      loaded.emplace_back(path.substr(path.find_last_of('/') + 1), sim::loadForestWorld(path));
    for (const auto& w : loaded)
      benchmarkCast(w.first, w.second, sweeps);
    benchmarkCast("generated 150 trees", generatedStand(150, 7), sweeps);

    std::printf("\n== Dead reckoning (wheel odometry alone) against truth, reference drives\n");
    for (const auto& w : loaded)
    {
      if (default_worlds && &w != &loaded.front())
        break;  // the reference drift is the paper world's
      benchmarkDrift(w.first + " straight", w.second, sim::straightDrive(), seeds);
      benchmarkDrift(w.first + " loop", w.second, sim::loopDrive(), seeds);
    }
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "sim_benchmark: %s\n", e.what());
    return 1;
  }
  return 0;
}
