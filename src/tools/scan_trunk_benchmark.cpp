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
struct Options
{
  std::string world_path, cars_path;  // default: the package's config/worlds/park.yaml and park.cars.txt
  double step = 10.0;
  int min_beams = -1;
  double min_jump = -1.0;
};

/** Reads the options; false (after printing the usage) for an unknown option or one without its value. */
bool parseOptions(int argc, char** argv, Options* opt)
{
  for (int i = 1; i < argc; ++i)
  {
    const std::string arg = argv[i];
    if (arg == "--world" && i + 1 < argc)
      opt->world_path = argv[++i];
    else if (arg == "--cars" && i + 1 < argc)
      opt->cars_path = argv[++i];
    else if (arg == "--step" && i + 1 < argc)
      opt->step = std::atof(argv[++i]);
    else if (arg == "--min-beams" && i + 1 < argc)
      opt->min_beams = std::atoi(argv[++i]);
    else if (arg == "--min-jump" && i + 1 < argc)
      opt->min_jump = std::atof(argv[++i]);
    else
    {
      std::fprintf(stderr, "usage: %s [--world FILE] [--cars FILE|none] [--step M] [--min-beams N] [--min-jump M]\n", argv[0]);
      return false;
    }
  }
  return true;
}

/** The simulator with the car's planar scanner only. */
sim::SimulatorConfig scannerConfig()
{
  sim::SimulatorConfig sim_config;
  sim_config.lidar3d.enabled = false;
  sim::Lidar2DConfig& l = sim_config.lidar2d;
  l.enabled = true;
  l.angle_min = -0.5 * M_PI;
  l.angle_max = 0.5 * M_PI;
  l.beams = 361;
  l.min_range = 0.1;
  l.max_range = 80.0;
  l.range_sigma = 0.02;
  l.mount = sim::Mount{ 0.0, 0.0, 0.5, 0.0, 0.0, 0.0 };
  return sim_config;
}

/** The detector for scanner @p l, with the options' arc settings. */
core::TrunkDetectorConfig detectorConfig(const sim::Lidar2DConfig& l, const Options& opt)
{
  core::TrunkDetectorConfig cfg;
  cfg.range_sigma = l.range_sigma;
  cfg.max_range = l.max_range;
  // The park's trunks: trees of radius 0.10-0.50 m and poles of 0.04-0.08 m.
  cfg.arc_radius_prior = 0.2;
  cfg.arc_radius_sigma = 0.15;
  if (opt.min_beams > 0)
    cfg.scan_min_beams = opt.min_beams;
  if (opt.min_jump > 0.0)
    cfg.scan_min_jump = opt.min_jump;
  return cfg;
}

/** Sensor poses on a grid over the park's interior, headings from a seeded generator, clear of everything. */
std::vector<core::Pose2> sensorPoses(const sim::ForestWorld& world, const std::vector<sim::BoxSpec>& cars, double step)
{
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
  return poses;
}

/** One simulated scan: its ranges (with the parked cars), where the scanner stood, and the beams on each trunk. */
struct ScanView
{
  core::PlanarScan scan;
  Eigen::Vector2d origin;
  double yaw = 0.0;
  std::vector<int> hits;  ///< per true trunk: returns within kHitDistance of its surface
};

/** The scan from @p pose; the cars are cast here (the simulator's world has none) with noise from @p car_noise. */
ScanView simulateScan(const sim::ForestWorld& world, const std::vector<sim::BoxSpec>& cars, const core::Pose2& pose,
                      sim::SimulatorConfig* sim_config, core::Random* car_noise)
{
  const sim::Lidar2DConfig& l = sim_config->lidar2d;
  sim_config->start = pose;
  sim::ForestSimulator sim(world, *sim_config);
  sim::LaserScan2D s;
  sim.castScan(0.0, &s);
  const Eigen::Isometry3d sensor = sim.bodyPose(pose) * l.mount.transform();
  ScanView view;
  view.origin = sensor.translation().head<2>();
  view.yaw = std::atan2(sensor.linear()(1, 0), sensor.linear()(0, 0));
  view.scan = eval::toPlanarScan(s);
  core::PlanarScan& scan = view.scan;
  // Hits per true trunk (a return within kHitDistance of its surface).
  view.hits.assign(world.trunks.size(), 0);
  for (std::size_t b = 0; b < scan.ranges.size(); ++b)
  {
    const double a = view.yaw + scan.angle_min + scan.angle_increment * static_cast<double>(b);
    const Eigen::Vector2d d(std::cos(a), std::sin(a));
    double car = std::numeric_limits<double>::infinity();
    for (const auto& c : cars)
      car = std::min(car, sim::intersectBox(c, 0.0, sensor.translation(), Eigen::Vector3d(d.x(), d.y(), 0.0)));
    float& r = scan.ranges[b];
    if (std::isfinite(car) && !(std::isfinite(r) && r < car))
    {
      const double noisy = car + car_noise->gaussian(l.range_sigma);
      r = noisy <= l.max_range ? static_cast<float>(noisy) : std::numeric_limits<float>::infinity();
      continue;
    }
    if (!std::isfinite(r))
      continue;
    const Eigen::Vector2d p = view.origin + d * static_cast<double>(r);
    for (std::size_t k = 0; k < world.trunks.size(); ++k)
    {
      const auto& t = world.trunks[k];
      if (std::abs(std::hypot(p.x() - t.x, p.y() - t.y) - t.radius) < kHitDistance)
        ++view.hits[k];
    }
  }
  return view;
}

void addStats(const core::TrunkDetectorStats& stats, core::TrunkDetectorStats* total)
{
  total->clusters += stats.clusters;
  total->rejected_size += stats.rejected_size;
  total->rejected_radius += stats.rejected_radius;
  total->rejected_inliers += stats.rejected_inliers;
  total->rejected_shape += stats.rejected_shape;
  total->rejected_clutter += stats.rejected_clutter;
  total->trunks += stats.trunks;
}

/**
 * Greedy one-to-one matching by distance within the gate: @p match per detection and @p matched_by per true trunk
 * (-1: none).
 */
void matchDetections(const std::vector<core::TrunkObservation>& obs, const std::vector<Eigen::Vector2d>& truth,
                     std::vector<int>* match, std::vector<int>* matched_by)
{
  std::vector<std::pair<double, std::pair<std::size_t, std::size_t>>> pairs;
  for (std::size_t i = 0; i < obs.size(); ++i)
    for (std::size_t k = 0; k < truth.size(); ++k)
    {
      const double e = (obs[i].center - truth[k]).norm();
      if (e < kGate)
        pairs.push_back({ e, { i, k } });
    }
  std::sort(pairs.begin(), pairs.end());
  match->assign(obs.size(), -1);
  matched_by->assign(truth.size(), -1);
  for (const auto& p : pairs)
    if ((*match)[p.second.first] < 0 && (*matched_by)[p.second.second] < 0)
    {
      (*match)[p.second.first] = static_cast<int>(p.second.second);
      (*matched_by)[p.second.second] = static_cast<int>(p.second.first);
    }
}

/** Counts one scan's visible and found trunks and its detections into the range bands. */
void scoreScan(const std::vector<core::TrunkObservation>& obs, const ScanView& view, const sim::ForestWorld& world,
               Band* band)
{
  // True trunks in the scan frame; greedy one-to-one matching by distance within the gate.
  const Eigen::Rotation2Dd to_scan(-view.yaw);
  std::vector<Eigen::Vector2d> truth;
  for (const auto& t : world.trunks)
    truth.push_back(to_scan * (Eigen::Vector2d(t.x, t.y) - view.origin));
  std::vector<int> match, matched_by;
  matchDetections(obs, truth, &match, &matched_by);
  for (std::size_t k = 0; k < truth.size(); ++k)
  {
    const int b = bandOf(truth[k].norm());
    if (b < 0 || view.hits[k] < 1)
      continue;
    ++band[b].visible;
    band[b].visible2 += view.hits[k] >= 2;
    if (matched_by[k] >= 0)
    {
      ++band[b].found;
      band[b].found2 += view.hits[k] >= 2;
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

/** The table: one line per range band and one over all, then the detector's rejections. */
void printTable(const Band* band, const core::TrunkDetectorStats& total)
{
  std::printf("%-8s %8s %9s %12s %10s %11s %9s %11s\n", "band [m]", "visible", "recall", "recall >=2b", "detections",
              "clutter", "RMS [cm]", "in 3 sigma");
  Band all;
  const auto line = [](const char* label, const Band& b)
  {
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
}  // namespace

int main(int argc, char** argv)
{
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);  // PCL reports every failed RANSAC as an error
  Options opt;
  if (!parseOptions(argc, argv, &opt))
    return 2;
  try
  {
    if (opt.world_path.empty())
      opt.world_path = tools::packageFile("config/worlds/park.yaml");
    if (opt.cars_path.empty())
      opt.cars_path = tools::packageFile("config/worlds/park.cars.txt");
    const sim::ForestWorld world = sim::loadForestWorld(opt.world_path);
    // Parked cars: boxes of the default size (4.5 x 1.8 x 1.5 m).
    const std::vector<sim::BoxSpec> cars =
        opt.cars_path == "none" ? std::vector<sim::BoxSpec>() : sim::loadBoxList(opt.cars_path);

    sim::SimulatorConfig sim_config = scannerConfig();
    core::TrunkDetector detector(detectorConfig(sim_config.lidar2d, opt));
    const std::vector<core::Pose2> poses = sensorPoses(world, cars, opt.step);

    Band band[kNumBands];
    core::TrunkDetectorStats total;
    core::Random car_noise(9);
    for (const auto& pose : poses)
    {
      const ScanView view = simulateScan(world, cars, pose, &sim_config, &car_noise);
      core::TrunkDetectorStats stats;
      const auto obs = detector.detectScan(view.scan, &stats);
      addStats(stats, &total);
      scoreScan(obs, view, world, band);
    }

    std::printf(
        "2D trunk extraction: %s, %zu trunks (trees and poles), %zu cars, %zu scans\n"
        "scanner 180 deg, 0.5 deg step, 80 m, 0.5 m high, sigma 2 cm; recall over trunks hit by >= 1 beam "
        "(>= 2 beams);\nclutter = detections with no true trunk within %.1f m; 'in 3 sigma' = matched "
        "detections whose error is inside the covariance's 99.7 %% ellipse\n",
        opt.world_path.substr(opt.world_path.find_last_of('/') + 1).c_str(), world.trunks.size(), cars.size(),
        poses.size(), kGate);
    printTable(band, total);
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "scan_trunk_benchmark: %s\n", e.what());
    return 1;
  }
  return 0;
}
