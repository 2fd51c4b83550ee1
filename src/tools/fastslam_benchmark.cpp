// FastSLAM on the simulated forest through the in-process runner, over seeds; prints a table with the same
// runs' dead reckoning. Not a test.
//
//   rosrun rbpf_slam fastslam_benchmark [--world FILE] [--drive straight|loop|FILE] [--particles N]
//                                       [--seeds K] [--method circle|centroid] [--first-seed S]
//                                       [--proposal fastslam1|fastslam2] [--mixture F] [--odometry-noise K]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <sys/stat.h>
#include <string>
#include <vector>

#include "rbpf_slam/core/forest_slam_runner.h"
#include "rbpf_slam/core/path_follower.h"
#include "rbpf_slam/io/run_output.h"
#include "rbpf_slam/io/world_file.h"

using namespace rbpf_slam;

namespace
{
double median(std::vector<double> v)
{
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : (v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]));
}
double worst(const std::vector<double>& v)
{
  return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
}
std::string jsonStats(const char* name, const std::vector<double>& v, bool larger_is_worse = true)
{
  std::ostringstream o;
  o.precision(6);
  o << "\"" << name << "\": {\"median\": " << median(v) << ", \"worst\": "
    << (v.empty() ? 0.0 : (larger_is_worse ? *std::max_element(v.begin(), v.end()) : *std::min_element(v.begin(), v.end())))
    << ", \"values\": [";
  for (std::size_t i = 0; i < v.size(); ++i)
    o << (i ? ", " : "") << v[i];
  o << "]}";
  return o.str();
}

double best(const std::vector<double>& v)
{
  return v.empty() ? 0.0 : *std::min_element(v.begin(), v.end());
}
}  // namespace

int main(int argc, char** argv)
{
  std::string world_path = std::string(RBPF_SLAM_SOURCE_DIR) + "/config/worlds/paper_forest.yaml";
  std::string drive = "straight", method = "circle";
  int particles = 100, seeds = 20, first_seed = 1;
  bool ideal = false;
  std::string proposal = "fastslam1";
  double mixture = 0.0;
  double odometry_noise = 1.0;  // --odometry-noise K: the simulated wheel noise and scale mismatch times K
  std::string out_dir;  // --out DIR: TUM trajectories, maps and summary.json  // diagnostic: odometry without noise, mismatch or latency
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    if (a == "--world" && has)
      world_path = argv[++i];
    else if (a == "--drive" && has)
      drive = argv[++i];
    else if (a == "--particles" && has)
      particles = std::atoi(argv[++i]);
    else if (a == "--seeds" && has)
      seeds = std::atoi(argv[++i]);
    else if (a == "--first-seed" && has)
      first_seed = std::atoi(argv[++i]);
    else if (a == "--out" && has)
      out_dir = argv[++i];
    else if (a == "--ideal-odometry")
      ideal = true;
    else if (a == "--method" && has)
      method = argv[++i];
    else if (a == "--proposal" && has)
      proposal = argv[++i];
    else if (a == "--mixture" && has)
      mixture = std::atof(argv[++i]);
    else if (a == "--odometry-noise" && has)
      odometry_noise = std::atof(argv[++i]);
    else
    {
      std::fprintf(stderr,
                   "usage: %s [--world FILE] [--drive straight|loop|FILE] [--particles N] [--seeds K] "
                   "[--method circle|centroid] [--first-seed S] [--ideal-odometry] [--out DIR]\n"
                   "       [--proposal fastslam1|fastslam2] [--mixture F] [--odometry-noise K]\n",
                   argv[0]);
      return 2;
    }
  }
  try
  {
    const core::ForestWorld world = io::loadForestWorld(world_path);
    core::ForestSlamRunConfig cfg;
    std::string error;
    cfg.scenario.drive = core::namedDrive(drive, &error);
    if (!error.empty())
      throw std::runtime_error(error);
    if (!core::parseTrunkMethod(method, &cfg.detector.method))
      throw std::runtime_error("--method must be circle or centroid");
    cfg.filter.particles = particles;
    if (!core::parsePoseProposal(proposal, &cfg.filter.proposal))
      throw std::runtime_error("--proposal must be fastslam1 or fastslam2");
    cfg.filter.mixture_fraction = mixture;
    {
      auto& o = cfg.scenario.sim.odometry;
      o.wheel_sigma *= odometry_noise;
      o.left_scale = 1.0 + odometry_noise * (o.left_scale - 1.0);
      o.right_scale = 1.0 + odometry_noise * (o.right_scale - 1.0);
    }
    if (ideal)
    {
      cfg.scenario.sim.odometry.left_scale = cfg.scenario.sim.odometry.right_scale = 1.0;
      cfg.scenario.sim.odometry.wheel_sigma = 0.0;
      cfg.scenario.sim.robot.turn_slip = 0.0;
    }
    std::printf("FastSLAM %s, %s drive, %d particles, extraction %s, proposal %s, mixture %.2f, odometry noise x%.1f, "
                "seeds %d..%d\n",
                world_path.substr(world_path.find_last_of('/') + 1).c_str(), drive.c_str(), particles, method.c_str(),
                proposal.c_str(), mixture, odometry_noise, first_seed, first_seed + seeds - 1);
    std::printf("%5s %9s %9s %8s %8s %8s %7s %5s %5s %8s %7s %8s\n", "seed", "final [m]", "DR [m]", "ATE [m]",
                "DR ATE", "tree-ft", "recall", "dup", "spur", "r RMS cm", "sweeps", "rate Hz");
    std::vector<double> fin, fin_dr, ate, ate_dr, dist, recall, rad, dup, spur, rate;
    int failed = 0;
    for (int s = first_seed; s < first_seed + seeds; ++s)
    {
      cfg.scenario.sim.seed = static_cast<std::uint64_t>(s);
      cfg.filter.seed = static_cast<std::uint64_t>(s);
      cfg.detector.seed = static_cast<std::uint64_t>(s);
      const core::ForestSlamRunResult r = core::runForestSlam(world, cfg);
      const double hz = r.sweeps / std::max(1e-9, r.seconds_extraction + r.seconds_filter);
      std::printf("%5d %9.3f %9.3f %8.3f %8.3f %8.3f %6.1f%% %5d %5d %8.2f %7d %8.1f\n", s, r.final_error,
                  r.final_error_odometry, r.ate, r.ate_odometry, r.map.mean_distance, 100.0 * r.map.recall,
                  r.map.duplicates, r.map.spurious, 100.0 * r.map.radius_rms, r.sweeps, hz);
      std::fflush(stdout);
      fin.push_back(r.final_error);
      fin_dr.push_back(r.final_error_odometry);
      ate.push_back(r.ate);
      ate_dr.push_back(r.ate_odometry);
      dist.push_back(r.map.mean_distance);
      recall.push_back(r.map.recall);
      rad.push_back(r.map.radius_rms);
      dup.push_back(r.map.duplicates);
      spur.push_back(r.map.spurious);
      rate.push_back(hz);
      failed += r.final_error > 1.0;
      if (!out_dir.empty())
      {
        mkdir(out_dir.c_str(), 0755);
        const std::string base = out_dir + "/seed" + std::to_string(s);
        io::writeTum(base + "_estimate.tum", r.stamps, r.estimate);
        io::writeTum(base + "_odometry.tum", r.stamps, r.odometry);
        io::writeTum(base + "_truth.tum", r.stamps, r.truth);
        io::writeLandmarksCsv(base + "_map.csv", r.landmarks);
        std::ofstream trees(base + "_trees.csv");
        trees << "x,y,radius,seen\n";
        for (std::size_t k = 0; k < r.trees.size(); ++k)
          trees << r.trees[k].position.x() << ',' << r.trees[k].position.y() << ',' << r.trees[k].radius << ','
                << (r.tree_seen[k] ? 1 : 0) << '\n';
      }
    }
    std::printf("median %9.3f %9.3f %8.3f %8.3f %8.3f %6.1f%% %5.0f %5.0f %8.2f %7s %8.1f\n", median(fin), median(fin_dr),
                median(ate), median(ate_dr), median(dist), 100.0 * median(recall), median(dup), median(spur),
                100.0 * median(rad), "", median(rate));
    std::printf("worst  %9.3f %9.3f %8.3f %8.3f %8.3f %6.1f%% %5.0f %5.0f %8.2f %7s %8.1f\n", worst(fin), best(fin_dr),
                worst(ate), best(ate_dr), worst(dist), 100.0 * best(recall), worst(dup), worst(spur), 100.0 * worst(rad),
                "", best(rate));
    if (!out_dir.empty())
    {
      std::ofstream js(out_dir + "/summary.json");
      js << "{\"world\": \"" << world_path << "\", \"drive\": \"" << drive << "\", \"particles\": " << particles
         << ", \"method\": \"" << method << "\", \"proposal\": \"" << proposal << "\", \"mixture\": " << mixture
         << ", \"odometry_noise\": " << odometry_noise << ", \"first_seed\": " << first_seed << ", \"seeds\": " << seeds
         << ", \"failed\": " << failed << ",\n " << jsonStats("final_error_m", fin) << ",\n "
         << jsonStats("final_error_dead_reckoning_m", fin_dr, false) << ",\n " << jsonStats("ate_m", ate) << ",\n "
         << jsonStats("ate_dead_reckoning_m", ate_dr, false) << ",\n " << jsonStats("tree_to_feature_m", dist)
         << ",\n " << jsonStats("recall", recall, false) << ",\n " << jsonStats("duplicates", dup) << ",\n "
         << jsonStats("spurious", spur) << ",\n " << jsonStats("radius_rms_m", rad) << ",\n "
         << jsonStats("rate_hz", rate, false) << "}\n";
      std::printf("wrote %s/summary.json and per-seed TUM trajectories and maps\n", out_dir.c_str());
    }
    std::printf("failed runs (final error > 1 m): %d of %d   (DR columns: the same runs' dead reckoning; "
                "'worst' DR = the smallest drift)\n",
                failed, seeds);
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "fastslam_benchmark: %s\n", e.what());
    return 1;
  }
  return 0;
}
