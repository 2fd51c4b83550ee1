// The trunk detector's 2D path on real data: Claus Brenner's LEGO robot logs (660-beam scanner, six
// cylinders of radius 55 mm). Per scan: cylinders found against those that the reference pose says are in
// view, and the radius estimates. Prints a summary (and per-scan lines with --verbose).
//
//   rosrun rbpf_slam lego_trunks [--data DIR] [--robot YAML] [--method circle|centroid] [--verbose]
//
//   --dump CSV writes every detection (scan index, centre in the scanner frame, radius, points, method).
//   --robot YAML: the robot's constants (default config/lego/robot.yaml of the package, which lego_to_bag
//   reads too: tick, track width, the scanner's offset and mounting angle, beam step, valid ranges, start pose).
//
// Layout: robot4_scan.txt "S ts n r0 ... r(n-1)" [mm], beam i at
// (i - n/2) * beam_increment + scanner_yaw rad, ranges below range_min invalid; robot4_reference.txt
// "P ts x y" [mm] (overhead camera); robot4_motors.txt "M ts left . . . right ..." cumulative ticks;
// robot_arena_landmarks.txt "L C x y r". The heading for "in view" comes from the wheel ticks (the reference
// has positions only), replaced by the reference's direction of travel where the robot drives straight (the
// ticks' heading drifts).
#include <pcl/console/print.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "package_dir.h"
#include "rbpf_slam/core/extraction/trunk_detector.h"
#include "rbpf_slam/io/files.h"
#include "rbpf_slam/io/param_source.h"
#include "rbpf_slam/io/trunk_detector_config.h"

using namespace rbpf_slam;

namespace
{
constexpr double kGate = 0.3;  // [m] a detection within this of a true cylinder is that cylinder (ranges here run ~0.1 m short)
constexpr double kInViewRange = 2.5;  // [m] cylinders nearer than this inside the field of view count as in view

/** @brief The robot's constants of config/lego/robot.yaml [m, rad]. */
struct LegoRobot
{
  double tick = 0.0, track = 0.0, scanner_x = 0.0, scanner_yaw = 0.0, beam_increment = 0.0, range_min = 0.0,
         range_max = 0.0, start_yaw = 0.0;
};

LegoRobot readRobot(const std::string& path)
{
  const io::YamlParamSource params(path);
  LegoRobot robot;
  double start_yaw_deg = 0.0;
  const std::pair<const char*, double*> keys[] = {
    { "tick", &robot.tick },
    { "track", &robot.track },
    { "scanner_x", &robot.scanner_x },
    { "scanner_yaw", &robot.scanner_yaw },
    { "beam_increment", &robot.beam_increment },
    { "range_min", &robot.range_min },
    { "range_max", &robot.range_max },
    { "start_scanner_pose/yaw_deg", &start_yaw_deg },
  };
  for (const auto& k : keys)
    if (!params.get(k.first, k.second))
      throw std::runtime_error(path + ": missing key '" + k.first + "'");
  robot.start_yaw = start_yaw_deg * M_PI / 180.0;
  return robot;
}

std::vector<std::vector<double>> readRecords(const std::string& path, char tag, int skip)
{
  std::ifstream in(path);
  if (!in)
    throw std::runtime_error(path + ": cannot open");
  std::vector<std::vector<double>> out;
  std::string line;
  int number = 0;
  while (std::getline(in, line))
  {
    ++number;
    if (line.empty() || line[0] != tag)
      continue;
    std::istringstream ss(line.substr(1));
    std::vector<double> v;
    std::string tok;
    int k = 0;
    while (ss >> tok)
    {
      if (k++ < skip)
        continue;
      try
      {
        v.push_back(std::stod(tok));
      }
      catch (const std::exception&)
      {
        throw std::runtime_error(path + ":" + std::to_string(number) + ": not a number: '" + tok + "'");
      }
    }
    out.push_back(v);
  }
  return out;
}
}  // namespace

int main(int argc, char** argv)
{
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);  // PCL reports every failed RANSAC as an error
  std::string dir;         // default: $RBPF_SLAM_DATA/brenner_lego
  std::string robot_path;  // default: the package's config/lego/robot.yaml
  std::string method;
  std::string config_path, dump_path;
  bool verbose = false;
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    if (a == "--data" && i + 1 < argc)
      dir = argv[++i];
    else if (a == "--robot" && i + 1 < argc)
      robot_path = argv[++i];
    else if (a == "--method" && i + 1 < argc)
      method = argv[++i];
    else if (a == "--config" && i + 1 < argc)
      config_path = argv[++i];
    else if (a == "--dump" && i + 1 < argc)
      dump_path = argv[++i];
    else if (a == "--verbose")
      verbose = true;
    else
    {
      std::fprintf(stderr,
                   "usage: %s [--data DIR] [--robot YAML] [--config YAML] [--method circle|centroid] [--dump CSV] "
                   "[--verbose]\n"
                   "  --data DIR   the LEGO robot logs (default: $RBPF_SLAM_DATA/brenner_lego)\n",
                   argv[0]);
      return 2;
    }
  }
  try
  {
    dir = tools::dataDir(dir, "brenner_lego", "lego_trunks");
    if (robot_path.empty())
      robot_path = tools::packageFile("config/lego/robot.yaml");
    const LegoRobot robot = readRobot(robot_path);
    const auto scans = readRecords(dir + "/robot4_scan.txt", 'S', 0);
    const auto refs = readRecords(dir + "/robot4_reference.txt", 'P', 0);
    const auto motors = readRecords(dir + "/robot4_motors.txt", 'M', 0);
    const auto marks = readRecords(dir + "/robot_arena_landmarks.txt", 'L', 1);  // skip the "C"
    const std::size_t n = std::min({ scans.size(), refs.size(), motors.size() });
    if (n == 0 || marks.empty())
      throw std::runtime_error(dir + ": empty logs");

    // One configuration for small 2D scanners in a lab arena (stated once, not searched on the reference).
    core::TrunkDetectorConfig cfg;
    if (!core::parseTrunkMethod(method.empty() ? "circle" : method, &cfg.method))
      throw std::runtime_error("--method must be circle or centroid");
    cfg.cluster_tolerance = 0.08;
    cfg.min_points = 3;
    cfg.min_radius = 0.02;
    cfg.max_radius = 0.3;
    cfg.arc_radius_prior = 0.1;
    cfg.arc_radius_sigma = 0.1;
    cfg.range_sigma = 0.01;
    cfg.min_range = 0.1;
    cfg.max_range = 10.0;
    cfg.ransac_threshold = 0.02;
    if (!config_path.empty())
    {
      cfg = core::TrunkDetectorConfig();
      io::readTrunkDetectorConfig(io::YamlParamSource(config_path), &cfg);
      if (!method.empty() && !core::parseTrunkMethod(method, &cfg.method))
        throw std::runtime_error("--method must be circle or centroid");
    }
    core::TrunkDetector detector(cfg);

    std::ostringstream dump;  // written (atomically) after the last scan
    dump << "scan,x,y,radius,points,method\n";  // each detection in the scanner frame [m]
    double heading = robot.start_yaw;
    double prev_l = motors[0].at(1), prev_r = motors[0].at(5);
    int expected = 0, found = 0, found_expected = 0, false_pos = 0, scans_used = 0;
    std::vector<double> radii, errors;  // errors: centre errors [m] of the cylinders in view that were found
    // Recall by the cylinder's distance from the scanner: < 0.5 m, 0.5-1 m, 1-2.5 m.
    const double band_edges[] = { 0.5, 1.0, kInViewRange };
    int band_expected[3] = { 0, 0, 0 }, band_found[3] = { 0, 0, 0 };
    int clusters = 0, rej_size = 0, rej_radius = 0, rej_inliers = 0, rej_shape = 0;
    for (std::size_t k = 0; k < n; ++k)
    {
      // Heading from the wheel ticks (positions from the reference).
      const double l = (motors[k].at(1) - prev_l) * robot.tick, r = (motors[k].at(5) - prev_r) * robot.tick;  // [m]
      prev_l = motors[k].at(1);
      prev_r = motors[k].at(5);
      heading += (r - l) / robot.track;
      // Where the reference moves, its direction of travel is the better heading (the ticks drift).
      if (k > 0 && k + 1 < n)
      {
        const double dx = refs[k + 1].at(1) - refs[k - 1].at(1), dy = refs[k + 1].at(2) - refs[k - 1].at(2);
        if (std::hypot(dx, dy) > 40.0 && std::abs(r - l) < 0.5 * std::abs(r + l))  // [mm] of the reference
          heading = std::atan2(dy, dx);
      }
      const double sx = refs[k].at(1) / 1000.0 + robot.scanner_x * std::cos(heading);
      const double sy = refs[k].at(2) / 1000.0 + robot.scanner_x * std::sin(heading);

      core::PlanarScan scan;
      const int beams = static_cast<int>(scans[k].at(1));
      scan.angle_min = -(beams / 2) * robot.beam_increment + robot.scanner_yaw;
      scan.angle_increment = robot.beam_increment;
      scan.range_min = robot.range_min;
      scan.range_max = robot.range_max;
      for (int b = 0; b < beams && 2 + b < static_cast<int>(scans[k].size()); ++b)
      {
        const double m = scans[k][static_cast<std::size_t>(2 + b)] / 1000.0;
        scan.ranges.push_back(m < robot.range_min ? std::numeric_limits<float>::quiet_NaN() : static_cast<float>(m));
      }
      core::TrunkDetectorStats st;
      const auto obs = detector.detectScan(scan, &st);
      clusters += st.clusters;
      rej_size += st.rejected_size;
      rej_radius += st.rejected_radius;
      rej_inliers += st.rejected_inliers;
      rej_shape += st.rejected_shape;
      ++scans_used;

      const double fov_lo = scan.angle_min, fov_hi = scan.angle_min + scan.angle_increment * (beams - 1);
      std::vector<bool> in_view(marks.size(), false), seen(marks.size(), false);
      std::vector<int> band(marks.size(), 0);
      int expected_here = 0;
      for (std::size_t m = 0; m < marks.size(); ++m)
      {
        const double dx = marks[m].at(0) / 1000.0 - sx, dy = marks[m].at(1) / 1000.0 - sy;
        const double bearing = std::remainder(std::atan2(dy, dx) - heading, 2.0 * M_PI);
        in_view[m] = std::hypot(dx, dy) < kInViewRange && bearing > fov_lo && bearing < fov_hi;
        expected_here += in_view[m];
        while (band[m] < 2 && std::hypot(dx, dy) >= band_edges[band[m]])
          ++band[m];
        band_expected[band[m]] += in_view[m];
      }
      int found_here = 0, false_here = 0;
      for (const auto& o : obs)
      {
        if (!dump_path.empty())
          dump << k << ',' << o.center.x() << ',' << o.center.y() << ',' << o.radius << ',' << o.num_points << ','
               << core::trunkMethodName(o.method) << '\n';
        const double wx = sx + std::cos(heading) * o.center.x() - std::sin(heading) * o.center.y();
        const double wy = sy + std::sin(heading) * o.center.x() + std::cos(heading) * o.center.y();
        int best = -1;
        double best_d = kGate;
        for (std::size_t m = 0; m < marks.size(); ++m)
        {
          const double d = std::hypot(marks[m].at(0) / 1000.0 - wx, marks[m].at(1) / 1000.0 - wy);
          if (d < best_d)
          {
            best_d = d;
            best = static_cast<int>(m);
          }
        }
        if (best < 0)
        {
          ++false_here;
          continue;
        }
        if (!seen[static_cast<std::size_t>(best)])
        {
          seen[static_cast<std::size_t>(best)] = true;
          ++found_here;
          if (in_view[static_cast<std::size_t>(best)])
          {
            ++found_expected;
            ++band_found[band[static_cast<std::size_t>(best)]];
            errors.push_back(best_d);
          }
          radii.push_back(o.radius);
        }
      }
      expected += expected_here;
      found += found_here;
      false_pos += false_here;
      if (verbose)
        std::printf("scan %3zu: %d in view, %d found, %d unmatched detections\n", k, expected_here, found_here,
                    false_here);
    }
    if (!dump_path.empty())
      io::writeFileAtomic(dump_path, dump.str());
    double mean = 0.0, sd = 0.0;
    for (double r : radii)
      mean += r;
    mean /= std::max<std::size_t>(1, radii.size());
    for (double r : radii)
      sd += (r - mean) * (r - mean);
    sd = std::sqrt(sd / std::max<std::size_t>(1, radii.size()));
    std::vector<double> sorted = radii;
    std::sort(sorted.begin(), sorted.end());
    std::printf("LEGO robot logs (%s), %d scans, method %s:\n", dir.c_str(), scans_used,
                core::trunkMethodName(cfg.method));
    std::printf("  cylinders in view (< %.1f m, inside the scanner's field of view): %d; of those found: %d (%.1f%%)\n",
                kInViewRange, expected, found_expected, expected ? 100.0 * found_expected / expected : 0.0);
    std::printf("  detections matched to a true cylinder (%.2f m gate): %d; unmatched detections: %d (%.1f%% of all)\n",
                kGate, found, false_pos, found + false_pos ? 100.0 * false_pos / (found + false_pos) : 0.0);
    std::printf("  arcs %d: rejected for size %d, radius %d, inlier ratio %d, shape (occluded edge, range, arc) %d\n",
                clusters, rej_size, rej_radius, rej_inliers, rej_shape);
    const char* band_names[] = { "< 0.5 m", "0.5-1 m", "1-2.5 m" };
    for (int b = 0; b < 3; ++b)
      std::printf("  recall %s: %d of %d (%.1f%%)\n", band_names[b], band_found[b], band_expected[b],
                  band_expected[b] ? 100.0 * band_found[b] / band_expected[b] : 0.0);
    if (!errors.empty())
    {
      std::sort(errors.begin(), errors.end());
      double mean_error = 0.0;
      for (double e : errors)
        mean_error += e;
      mean_error /= static_cast<double>(errors.size());
      std::printf("  centre error of the cylinders found [mm] (reference pose, heading from ticks): mean %.1f, median "
                  "%.1f, 90th percentile %.1f\n",
                  1000.0 * mean_error, 1000.0 * errors[errors.size() / 2], 1000.0 * errors[errors.size() * 9 / 10]);
    }
    if (!sorted.empty())
      std::printf("  radius estimates [mm] (true 55): mean %.1f, sd %.1f, median %.1f\n", 1000.0 * mean, 1000.0 * sd,
                  1000.0 * sorted[sorted.size() / 2]);
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "lego_trunks: %s\n", e.what());
    return 1;
  }
  return 0;
}
