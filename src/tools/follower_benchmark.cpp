// Prints how the simulator's path follower keeps to its drive: over seeds of a world and a drive, the collisions,
// the runs that did not finish, and how far the robot went from the drive, both as the follower sees it (its
// odometry against the drive in the start frame) and truly (the true pose against the drive laid from the true start).
//   follower_benchmark --world config/worlds/dense_forest.yaml --drive config/sim/stand_square.txt --seeds 20
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <limits>
#include <string>
#include <vector>

#include "rbpf_slam/io/param_source.h"
#include "rbpf_slam/sim/drive_check.h"
#include "rbpf_slam/sim/scenario.h"
#include "rbpf_slam/sim/sim_config.h"
#include "rbpf_slam/sim/waypoints_file.h"
#include "rbpf_slam/sim/world_file.h"

using namespace rbpf_slam;

namespace
{
const char* kUsage =
    "usage: follower_benchmark --world FILE [--drive NAME] [--config FILE] [--start X Y YAW_DEG] [--seeds N]\n"
    "                          [--first-seed N] [--max-departure M] [--no-points] [--force]\n"
    "Runs the simulated robot along a drive (no SLAM) and prints, per seed and over the seeds: collisions, runs that\n"
    "timed out, the largest distance of the odometry from the drive (what the follower steers on, unless --config\n"
    "sets follower/steer_on: truth) and of the true pose from the drive laid from the true start. A run fails on a\n"
    "collision, a time-out, or a true departure above --max-departure (default 3 m). Exits 1 when any run failed, 4\n"
    "when the drive is refused before it starts.\n"
    "  --world FILE        forest world (YAML world file or tree list)\n"
    "  --drive NAME        straight | loop | waypoint file (x y per line, start frame); default straight\n"
    "  --config FILE       simulator parameters (keys of config/forest_sim.yaml); default: built-in\n"
    "  --start X Y YAW_DEG start pose in the world; default (0, 15, 0) or --config's\n"
    "  --seeds N           seeds first-seed .. first-seed + N - 1; default 20 (first seed 1)\n"
    "  --no-points         leave the 3D sweeps out (the planner then sees only a 2D scanner, if any)\n"
    "  --force             run a drive the check refuses, to see how it fails\n";

double median(std::vector<double> v)
{
  if (v.empty())
    return NAN;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct Options
{
  std::string world, drive = "straight", config;
  bool start_given = false, points = true, force = false;
  core::Pose2 start;
  int seeds = 20, first_seed = 1;
  double max_departure = 3.0;
};

bool number(const char* s, double* v)
{
  char* end = nullptr;
  *v = std::strtod(s, &end);
  return end != s && *end == '\0' && std::isfinite(*v);
}

bool parse(int argc, char** argv, Options* opt, int* status)
{
  *status = 2;
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    const auto value = [&](int n) {
      if (i + n >= argc)
      {
        std::fprintf(stderr, "follower_benchmark: %s needs %d value(s)\n%s", a.c_str(), n, kUsage);
        std::exit(2);
      }
    };
    double v = 0.0;
    if (a == "--world" || a == "--drive" || a == "--config")
    {
      value(1);
      (a == "--world" ? opt->world : a == "--drive" ? opt->drive : opt->config) = argv[++i];
    }
    else if (a == "--start")
    {
      value(3);
      double* f[3] = { &opt->start.x, &opt->start.y, &opt->start.theta };
      for (double* x : f)
        if (!number(argv[++i], x))
        {
          std::fprintf(stderr, "follower_benchmark: --start takes three numbers, got '%s'\n", argv[i]);
          return false;
        }
      opt->start.theta *= M_PI / 180.0;
      opt->start_given = true;
    }
    else if (a == "--seeds" || a == "--first-seed" || a == "--max-departure")
    {
      value(1);
      if (!number(argv[++i], &v) || (a != "--first-seed" && v <= 0.0))
      {
        std::fprintf(stderr, "follower_benchmark: %s takes a positive number, got '%s'\n", a.c_str(), argv[i]);
        return false;
      }
      if (a == "--seeds")
        opt->seeds = static_cast<int>(v);
      else if (a == "--first-seed")
        opt->first_seed = static_cast<int>(v);
      else
        opt->max_departure = v;
    }
    else if (a == "--no-points")
      opt->points = false;
    else if (a == "--force")
      opt->force = true;
    else if (a == "-h" || a == "--help")
    {
      std::printf("%s", kUsage);
      *status = 0;
      return false;
    }
    else
    {
      std::fprintf(stderr, "follower_benchmark: unknown argument '%s'\n%s", a.c_str(), kUsage);
      return false;
    }
  }
  if (opt->world.empty())
  {
    std::fprintf(stderr, "follower_benchmark: --world is required\n%s", kUsage);
    return false;
  }
  return true;
}

struct SeedResult
{
  bool collided = false, timed_out = false;
  std::string what;
  double odom_departure = 0.0, true_departure = 0.0, length = 0.0, time = 0.0;
  int avoiding = 0, commands = 0;
};

SeedResult runSeed(const sim::ForestWorld& world, sim::ScenarioConfig config, int seed)
{
  config.sim.seed = static_cast<std::uint64_t>(static_cast<std::int64_t>(seed));
  sim::Scenario scenario(world, config, nullptr);
  SeedResult r;
  sim::SimulatorOutput out;
  core::Pose2 last = config.sim.start;
  bool first = true;
  for (bool running = true; running;)
  {
    out.clear();
    running = scenario.step(&out);
    for (const auto& o : out.odometry)
    {
      r.odom_departure = std::max(r.odom_departure, sim::distanceToPolyline(config.drive, o.pose.x, o.pose.y));
      ++r.commands;
      r.avoiding += scenario.follower().avoiding() ? 1 : 0;
    }
    for (const auto& t : out.truth)
    {
      const core::Pose2 p = core::between(config.sim.start, t.pose);
      r.true_departure = std::max(r.true_departure, sim::distanceToPolyline(config.drive, p.x, p.y));
      if (!first)
        r.length += std::hypot(t.pose.x - last.x, t.pose.y - last.y);
      last = t.pose;
      first = false;
    }
  }
  r.time = scenario.simulator().time();
  if (const sim::Collision* c = scenario.simulator().collision())
  {
    r.collided = true;
    char buf[200];
    std::snprintf(buf, sizeof(buf), "%s at %.1f s, true pose (%.2f, %.2f)", c->what(world).c_str(), c->stamp,
                  c->pose.x, c->pose.y);
    r.what = buf;
  }
  r.timed_out = !r.collided && scenario.timedOut();
  return r;
}
}  // namespace

int main(int argc, char** argv)
{
  Options opt;
  int status = 0;
  if (!parse(argc, argv, &opt, &status))
    return status;
  try
  {
    std::vector<std::string> unknown;
    sim::ScenarioConfig config =
        sim::loadScenario(opt.config, opt.drive, opt.start_given ? &opt.start : nullptr, &unknown);
    for (const auto& k : unknown)
      std::fprintf(stderr, "follower_benchmark: warning: %s: unknown key '%s' ignored\n", opt.config.c_str(),
                   k.c_str());
    if (!opt.points)
      config.sim.lidar3d.enabled = false;
    std::string error;
    const sim::ForestWorld world = sim::loadForestWorld(opt.world);
    if (!sim::checkDrive(world, config, &error) && !opt.force)
    {
      std::fprintf(stderr, "follower_benchmark: the drive '%s' is refused: %s\n", opt.drive.c_str(), error.c_str());
      return sim::exit_status::kRefused;
    }
    const sim::PathFollower probe(config.drive, config.follower);
    std::printf("follower_benchmark: world %s, drive %s (%.0f m), seeds %d-%d, speed %.2f m/s, avoidance %s, "
                "steering on %s\n",
                opt.world.c_str(), opt.drive.c_str(), probe.length(), opt.first_seed, opt.first_seed + opt.seeds - 1,
                config.follower.speed, config.follower.avoid_obstacles ? "on" : "off",
                config.steer_on == sim::SteerOn::kTruth ? "the truth" : "odometry");
    std::vector<double> odom_dep, true_dep, lengths;
    int collided = 0, timed_out = 0, departed = 0;
    for (int s = opt.first_seed; s < opt.first_seed + opt.seeds; ++s)
    {
      const SeedResult r = runSeed(world, config, s);
      odom_dep.push_back(r.odom_departure);
      true_dep.push_back(r.true_departure);
      lengths.push_back(r.length);
      collided += r.collided;
      timed_out += r.timed_out;
      departed += r.true_departure > opt.max_departure;
      std::printf("  seed %3d: %6.1f s, %6.1f m driven, departure odometry %5.2f m, true %5.2f m, avoiding %4.1f %%"
                  "%s%s\n",
                  s, r.time, r.length, r.odom_departure, r.true_departure,
                  100.0 * r.avoiding / std::max(1, r.commands), r.collided ? ", COLLISION: " : "",
                  r.collided ? r.what.c_str() : (r.timed_out ? ", TIMED OUT" : ""));
      std::fflush(stdout);
    }
    std::printf("  over %d seeds: collisions %d, timed out %d, true departure > %.1f m: %d; departure odometry median "
                "%.2f / worst %.2f m, true median %.2f / worst %.2f m; driven %.0f / %.0f m (median / longest)\n",
                opt.seeds, collided, timed_out, opt.max_departure, departed, median(odom_dep),
                *std::max_element(odom_dep.begin(), odom_dep.end()), median(true_dep),
                *std::max_element(true_dep.begin(), true_dep.end()), median(lengths),
                *std::max_element(lengths.begin(), lengths.end()));
    return collided + timed_out + departed > 0 ? 1 : 0;
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "follower_benchmark: %s\n", e.what());
    return 2;
  }
}
