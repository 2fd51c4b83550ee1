// Trunk extraction from a car's planar scanner: simulated 2D scans of a park (trees, poles, bushes, parked cars),
// detections against the true trunks by range band. Prints a table; not a test.
//
//   rosrun rbpf_slam scan_trunk_benchmark [--world FILE] [--cars FILE|none] [--step M] [--min-beams N] [--min-jump M]
// The scanner: 180 deg field of view, 0.5 deg step, 80 m, 0.5 m above the ground, range sigma 2 cm.
// --min-beams: arcs of fewer beams are dropped (the detector's scan_min_beams; default: the detector's default).
// --min-jump: the detector's scan_min_jump [m].
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <pcl/console/print.h>

#include "package_dir.h"
#include "rbpf_slam/sim/forest_simulator.h"
#include "rbpf_slam/eval/forest_slam_runner.h"
#include "rbpf_slam/core/filter/random.h"
#include "rbpf_slam/core/extraction/trunk_detector.h"
#include "rbpf_slam/sim/world_file.h"

using namespace rbpf_slam;

namespace
{
const double kBands[] = { 0.0, 10.0, 20.0, 30.0, 50.0, 80.0 };
constexpr int kNumBands = 5;
constexpr double kGate = 0.5;       // [m] a detection within this of a true trunk's centre is that trunk's
constexpr double kHitDistance = 0.08;  // [m] a return this close to a trunk's surface is a hit on it (4 sigma)
constexpr double kChi2Of2Dof997 = 11.83;            // 3-sigma ellipse (99.7 %) of a 2D Gaussian

struct Band
{
  int visible = 0, visible2 = 0, found = 0, found2 = 0, detections = 0, clutter = 0, matched = 0, covered = 0;
  double sum_err2 = 0.0;
};

int bandOf(double range)
{
  for (int b = 0; b < kNumBands; ++b)
    if (range >= kBands[b] && range < kBands[b + 1])
      return b;
  return -1;
}
}  // namespace

int main(int argc, char** argv)
{
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);  // PCL reports every failed RANSAC as an error
  std::string world_path, cars_path;  // default: the package's config/worlds/park.yaml and park.cars.txt
  double step = 10.0;
  int min_beams = -1;
  double min_jump = -1.0;
  for (int i = 1; i < argc; ++i)
  {
    const std::string arg = argv[i];
    if (arg == "--world" && i + 1 < argc)
      world_path = argv[++i];
    else if (arg == "--cars" && i + 1 < argc)
      cars_path = argv[++i];
    else if (arg == "--step" && i + 1 < argc)
      step = std::atof(argv[++i]);
    else if (arg == "--min-beams" && i + 1 < argc)
      min_beams = std::atoi(argv[++i]);
    else if (arg == "--min-jump" && i + 1 < argc)
      min_jump = std::atof(argv[++i]);
    else
    {
      std::fprintf(stderr, "usage: %s [--world FILE] [--cars FILE|none] [--step M] [--min-beams N] [--min-jump M]\n", argv[0]);
      return 2;
    }
  }
  try
  {
    if (world_path.empty())
      world_path = tools::packageFile("config/worlds/park.yaml");
    if (cars_path.empty())
      cars_path = tools::packageFile("config/worlds/park.cars.txt");
    const core::ForestWorld world = io::loadForestWorld(world_path);
    // Parked cars: boxes of the default size (4.5 x 1.8 x 1.5 m).
    const std::vector<core::BoxSpec> cars =
        cars_path == "none" ? std::vector<core::BoxSpec>() : io::loadBoxList(cars_path);

    core::SimulatorConfig sim_config;
    sim_config.lidar3d.enabled = false;
    core::Lidar2DConfig& l = sim_config.lidar2d;
    l.enabled = true;
    l.angle_min = -0.5 * M_PI;
    l.angle_max = 0.5 * M_PI;
    l.beams = 361;
    l.min_range = 0.1;
    l.max_range = 80.0;
    l.range_sigma = 0.02;
    l.mount = core::Mount{ 0.0, 0.0, 0.5, 0.0, 0.0, 0.0 };

    core::TrunkDetectorConfig cfg;
    cfg.range_sigma = l.range_sigma;
    cfg.max_range = l.max_range;
    // The park's trunks: trees of radius 0.10-0.50 m and poles of 0.04-0.08 m.
    cfg.arc_radius_prior = 0.2;
    cfg.arc_radius_sigma = 0.15;
    if (min_beams > 0)
      cfg.scan_min_beams = min_beams;
    if (min_jump > 0.0)
      cfg.scan_min_jump = min_jump;
    core::TrunkDetector detector(cfg);

    // Sensor poses on a grid over the park's interior, headings from a seeded generator, clear of everything.
    core::Random random(5);
    std::vector<core::Pose2> poses;
    for (double x = world.min_x + 10.0; x <= world.max_x - 10.0 + 1e-9; x += step)
      for (double y = world.min_y + 10.0; y <= world.max_y - 10.0 + 1e-9; y += step)
      {
        bool clear = true;
        for (const auto& t : world.trunks)
          clear = clear && std::hypot(t.x - x, t.y - y) > t.radius + 1.0;
        for (const auto& c : cars)
          clear = clear && std::hypot(c.x - x, c.y - y) > 4.0;
        const double heading = random.uniform(-M_PI, M_PI);
        if (clear)
          poses.emplace_back(x, y, heading);
      }

    Band band[kNumBands];
    core::TrunkDetectorStats total;
    core::Random car_noise(9);
    for (const auto& pose : poses)
    {
      sim_config.start = pose;
      core::ForestSimulator sim(world, sim_config);
      core::LaserScan2D s;
      sim.castScan(0.0, &s);
      const Eigen::Isometry3d sensor = sim.bodyPose(pose) * l.mount.transform();
      const Eigen::Vector2d origin = sensor.translation().head<2>();
      const double yaw = std::atan2(sensor.linear()(1, 0), sensor.linear()(0, 0));
      core::PlanarScan scan = core::toPlanarScan(s);
      // Hits per true trunk (a return within kHitDistance of its surface).
      std::vector<int> hits(world.trunks.size(), 0);
      for (std::size_t b = 0; b < scan.ranges.size(); ++b)
      {
        const double a = yaw + scan.angle_min + scan.angle_increment * static_cast<double>(b);
        const Eigen::Vector2d d(std::cos(a), std::sin(a));
        double car = std::numeric_limits<double>::infinity();
        for (const auto& c : cars)
          car = std::min(car, core::intersectBox(c, 0.0, sensor.translation(), Eigen::Vector3d(d.x(), d.y(), 0.0)));
        float& r = scan.ranges[b];
        if (std::isfinite(car) && !(std::isfinite(r) && r < car))
        {
          const double noisy = car + car_noise.gaussian(l.range_sigma);
          r = noisy <= l.max_range ? static_cast<float>(noisy) : std::numeric_limits<float>::infinity();
          continue;
        }
        if (!std::isfinite(r))
          continue;
        const Eigen::Vector2d p = origin + d * static_cast<double>(r);
        for (std::size_t k = 0; k < world.trunks.size(); ++k)
        {
          const auto& t = world.trunks[k];
          if (std::abs(std::hypot(p.x() - t.x, p.y() - t.y) - t.radius) < kHitDistance)
            ++hits[k];
        }
      }

      core::TrunkDetectorStats stats;
      const auto obs = detector.detectScan(scan, &stats);
      total.clusters += stats.clusters;
      total.rejected_size += stats.rejected_size;
      total.rejected_radius += stats.rejected_radius;
      total.rejected_inliers += stats.rejected_inliers;
      total.rejected_shape += stats.rejected_shape;
      total.rejected_clutter += stats.rejected_clutter;
      total.trunks += stats.trunks;

      // True trunks in the scan frame; greedy one-to-one matching by distance within the gate.
      const Eigen::Rotation2Dd to_scan(-yaw);
      std::vector<Eigen::Vector2d> truth;
      for (const auto& t : world.trunks)
        truth.push_back(to_scan * (Eigen::Vector2d(t.x, t.y) - origin));
      std::vector<std::pair<double, std::pair<std::size_t, std::size_t>>> pairs;
      for (std::size_t i = 0; i < obs.size(); ++i)
        for (std::size_t k = 0; k < truth.size(); ++k)
        {
          const double e = (obs[i].center - truth[k]).norm();
          if (e < kGate)
            pairs.push_back({ e, { i, k } });
        }
      std::sort(pairs.begin(), pairs.end());
      std::vector<int> match(obs.size(), -1), matched_by(truth.size(), -1);
      for (const auto& p : pairs)
        if (match[p.second.first] < 0 && matched_by[p.second.second] < 0)
        {
          match[p.second.first] = static_cast<int>(p.second.second);
          matched_by[p.second.second] = static_cast<int>(p.second.first);
        }
      for (std::size_t k = 0; k < truth.size(); ++k)
      {
        const int b = bandOf(truth[k].norm());
        if (b < 0 || hits[k] < 1)
          continue;
        ++band[b].visible;
        band[b].visible2 += hits[k] >= 2;
        if (matched_by[k] >= 0)
        {
          ++band[b].found;
          band[b].found2 += hits[k] >= 2;
        }
      }
      // A detection of a trunk that no beam hit within kHitDistance (a grazing hit) still counts as no clutter.
      for (std::size_t i = 0; i < obs.size(); ++i)
      {
        const int b = bandOf(obs[i].range);
        if (b < 0)
          continue;
        ++band[b].detections;
        bool near_truth = false;
        for (const auto& t : truth)
          near_truth = near_truth || (obs[i].center - t).norm() < kGate;
        band[b].clutter += !near_truth;
        if (match[i] >= 0)
        {
          const Eigen::Vector2d e = obs[i].center - truth[static_cast<std::size_t>(match[i])];
          ++band[b].matched;
          band[b].sum_err2 += e.squaredNorm();
          band[b].covered += e.dot(obs[i].covariance.inverse() * e) <= kChi2Of2Dof997;
        }
      }
    }

    std::printf("2D trunk extraction: %s, %zu trunks (trees and poles), %zu cars, %zu scans\n"
                "scanner 180 deg, 0.5 deg step, 80 m, 0.5 m high, sigma 2 cm; recall over trunks hit by >= 1 beam "
                "(>= 2 beams);\nclutter = detections with no true trunk within %.1f m; 'in 3 sigma' = matched "
                "detections whose error is inside the covariance's 99.7 %% ellipse\n",
                world_path.substr(world_path.find_last_of('/') + 1).c_str(), world.trunks.size(), cars.size(),
                poses.size(), kGate);
    std::printf("%-8s %8s %9s %12s %10s %11s %9s %11s\n", "band [m]", "visible", "recall", "recall >=2b",
                "detections", "clutter", "RMS [cm]", "in 3 sigma");
    Band all;
    const auto line = [](const char* label, const Band& b) {
      const int matched = b.matched;
      std::printf("%-8s %8d %8.1f%% %11.1f%% %10d %10.1f%% %9.1f %10.1f%%\n", label, b.visible,
                  b.visible ? 100.0 * b.found / b.visible : 0.0, b.visible2 ? 100.0 * b.found2 / b.visible2 : 0.0,
                  b.detections, b.detections ? 100.0 * b.clutter / b.detections : 0.0,
                  matched > 0 ? 100.0 * std::sqrt(b.sum_err2 / matched) : 0.0,
                  matched > 0 ? 100.0 * b.covered / matched : 0.0);
    };
    for (int b = 0; b < kNumBands; ++b)
    {
      char label[32];
      std::snprintf(label, sizeof(label), "%.0f-%.0f", kBands[b], kBands[b + 1]);
      line(label, band[b]);
      all.visible += band[b].visible;
      all.visible2 += band[b].visible2;
      all.found += band[b].found;
      all.found2 += band[b].found2;
      all.detections += band[b].detections;
      all.clutter += band[b].clutter;
      all.matched += band[b].matched;
      all.covered += band[b].covered;
      all.sum_err2 += band[b].sum_err2;
    }
    line("all", all);
    std::printf("arcs %d: rejected size %d, radius %d, inliers %d, shape %d", total.clusters, total.rejected_size,
                total.rejected_radius, total.rejected_inliers, total.rejected_shape);
    std::printf(", clutter %d; trunks %d\n", total.rejected_clutter, total.trunks);
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "scan_trunk_benchmark: %s\n", e.what());
    return 1;
  }
  return 0;
}
