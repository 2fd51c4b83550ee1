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
struct Options
{
  std::string dir;         // default: $RBPF_SLAM_DATA/brenner_lego
  std::string robot_path;  // default: the package's config/lego/robot.yaml
  std::string method;
  std::string config_path, dump_path;
  bool verbose = false;
};

/** Reads the options; false (after printing the usage) for an unknown option or one without its value. */
bool parseOptions(int argc, char** argv, Options* opt)
{
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    if (a == "--data" && i + 1 < argc)
      opt->dir = argv[++i];
    else if (a == "--robot" && i + 1 < argc)
      opt->robot_path = argv[++i];
    else if (a == "--method" && i + 1 < argc)
      opt->method = argv[++i];
    else if (a == "--config" && i + 1 < argc)
      opt->config_path = argv[++i];
    else if (a == "--dump" && i + 1 < argc)
      opt->dump_path = argv[++i];
    else if (a == "--verbose")
      opt->verbose = true;
    else
    {
      std::fprintf(stderr,
                   "usage: %s [--data DIR] [--robot YAML] [--config YAML] [--method circle|centroid] [--dump CSV] "
                   "[--verbose]\n"
                   "  --data DIR   the LEGO robot logs (default: $RBPF_SLAM_DATA/brenner_lego)\n",
                   argv[0]);
      return false;
    }
  }
  return true;
}

/** The logs, each record's numbers after its tag; n is the number of scans with a reference and ticks. */
struct Logs
{
  std::vector<std::vector<double>> scans, refs, motors, marks;
  std::size_t n = 0;
};

Logs readLogs(const std::string& dir)
{
  Logs logs;
  logs.scans = readRecords(dir + "/robot4_scan.txt", 'S', 0);
  logs.refs = readRecords(dir + "/robot4_reference.txt", 'P', 0);
  logs.motors = readRecords(dir + "/robot4_motors.txt", 'M', 0);
  logs.marks = readRecords(dir + "/robot_arena_landmarks.txt", 'L', 1);  // skip the "C"
  logs.n = std::min({ logs.scans.size(), logs.refs.size(), logs.motors.size() });
  if (logs.n == 0 || logs.marks.empty())
    throw std::runtime_error(dir + ": empty logs");
  return logs;
}

/** One configuration for small 2D scanners in a lab arena (stated once, not searched on the reference). */
core::TrunkDetectorConfig detectorConfig(const Options& opt)
{
  core::TrunkDetectorConfig cfg;
  if (!core::parseTrunkMethod(opt.method.empty() ? "circle" : opt.method, &cfg.method))
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
  if (!opt.config_path.empty())
  {
    cfg = core::TrunkDetectorConfig();
    io::readTrunkDetectorConfig(io::YamlParamSource(opt.config_path), &cfg);
    if (!opt.method.empty() && !core::parseTrunkMethod(opt.method, &cfg.method))
      throw std::runtime_error("--method must be circle or centroid");
  }
  return cfg;
}

/** The scanner's heading and the last wheel ticks, and its position at the current scan [m]. */
struct ScannerTrack
{
  double heading = 0.0;
  double prev_l = 0.0, prev_r = 0.0;
  double sx = 0.0, sy = 0.0;
};

/**
 * Moves @p track to scan @p k: the heading from the wheel ticks, or the reference's direction of travel where the
 * robot drives straight; the position from the reference.
 */
void advanceTrack(const Logs& logs, const LegoRobot& robot, std::size_t k, ScannerTrack* track)
{
  const auto& motors = logs.motors;
  const auto& refs = logs.refs;
  // Heading from the wheel ticks (positions from the reference).
  const double l = (motors[k].at(1) - track->prev_l) * robot.tick,
               r = (motors[k].at(5) - track->prev_r) * robot.tick;  // [m]
  track->prev_l = motors[k].at(1);
  track->prev_r = motors[k].at(5);
  track->heading += (r - l) / robot.track;
  // Where the reference moves, its direction of travel is the better heading (the ticks drift).
  if (k > 0 && k + 1 < logs.n)
  {
    const double dx = refs[k + 1].at(1) - refs[k - 1].at(1), dy = refs[k + 1].at(2) - refs[k - 1].at(2);
    if (std::hypot(dx, dy) > 40.0 && std::abs(r - l) < 0.5 * std::abs(r + l))  // [mm] of the reference
      track->heading = std::atan2(dy, dx);
  }
  track->sx = refs[k].at(1) / 1000.0 + robot.scanner_x * std::cos(track->heading);
  track->sy = refs[k].at(2) / 1000.0 + robot.scanner_x * std::sin(track->heading);
}

/** A scan record "ts n r0 ... r(n-1)" [mm] as the detector takes it; @p beams gets n. */
core::PlanarScan planarScanOf(const std::vector<double>& record, const LegoRobot& robot, int* beams_out)
{
  core::PlanarScan scan;
  const int beams = static_cast<int>(record.at(1));
  scan.angle_min = -(beams / 2) * robot.beam_increment + robot.scanner_yaw;
  scan.angle_increment = robot.beam_increment;
  scan.range_min = robot.range_min;
  scan.range_max = robot.range_max;
  for (int b = 0; b < beams && 2 + b < static_cast<int>(record.size()); ++b)
  {
    const double m = record[static_cast<std::size_t>(2 + b)] / 1000.0;
    scan.ranges.push_back(m < robot.range_min ? std::numeric_limits<float>::quiet_NaN() : static_cast<float>(m));
  }
  *beams_out = beams;
  return scan;
}

/** The counts over all scans. */
struct Tally
{
  int expected = 0, found = 0, found_expected = 0, false_pos = 0, scans_used = 0;
  std::vector<double> radii, errors;  // errors: centre errors [m] of the cylinders in view that were found
  // Recall by the cylinder's distance from the scanner: < 0.5 m, 0.5-1 m, 1-2.5 m.
  int band_expected[3] = { 0, 0, 0 }, band_found[3] = { 0, 0, 0 };
  int clusters = 0, rej_size = 0, rej_radius = 0, rej_inliers = 0, rej_shape = 0;
};

/**
 * Which cylinders are in view of the scanner (nearer than kInViewRange, inside the field of view fov_lo..fov_hi) and
 * the distance band of each; returns how many are in view.
 */
int cylindersInView(const std::vector<std::vector<double>>& marks, const ScannerTrack& track, double fov_lo,
                    double fov_hi, std::vector<bool>* in_view, std::vector<int>* band, Tally* tally)
{
  const double band_edges[] = { 0.5, 1.0, kInViewRange };
  int expected_here = 0;
  for (std::size_t m = 0; m < marks.size(); ++m)
  {
    const double dx = marks[m].at(0) / 1000.0 - track.sx, dy = marks[m].at(1) / 1000.0 - track.sy;
    const double bearing = std::remainder(std::atan2(dy, dx) - track.heading, 2.0 * M_PI);
    (*in_view)[m] = std::hypot(dx, dy) < kInViewRange && bearing > fov_lo && bearing < fov_hi;
    expected_here += (*in_view)[m];
    while ((*band)[m] < 2 && std::hypot(dx, dy) >= band_edges[(*band)[m]])
      ++(*band)[m];
    tally->band_expected[(*band)[m]] += (*in_view)[m];
  }
  return expected_here;
}

/** The true cylinder nearest to detection @p o within *best_d (set to its distance), or -1. */
int nearestCylinder(const core::TrunkObservation& o, const std::vector<std::vector<double>>& marks,
                    const ScannerTrack& track, double* best_d)
{
  const double heading = track.heading;
  const double wx = track.sx + std::cos(heading) * o.center.x() - std::sin(heading) * o.center.y();
  const double wy = track.sy + std::sin(heading) * o.center.x() + std::cos(heading) * o.center.y();
  int best = -1;
  for (std::size_t m = 0; m < marks.size(); ++m)
  {
    const double d = std::hypot(marks[m].at(0) / 1000.0 - wx, marks[m].at(1) / 1000.0 - wy);
    if (d < *best_d)
    {
      *best_d = d;
      best = static_cast<int>(m);
    }
  }
  return best;
}

/** Scores scan @p k's detections against the cylinders in view (and dumps them with --dump). */
void scoreScan(const Options& opt, std::size_t k, const std::vector<core::TrunkObservation>& obs,
               const core::PlanarScan& scan, int beams, const Logs& logs, const ScannerTrack& track,
               std::ostringstream* dump, Tally* tally)
{
  const double fov_lo = scan.angle_min, fov_hi = scan.angle_min + scan.angle_increment * (beams - 1);
  std::vector<bool> in_view(logs.marks.size(), false), seen(logs.marks.size(), false);
  std::vector<int> band(logs.marks.size(), 0);
  const int expected_here = cylindersInView(logs.marks, track, fov_lo, fov_hi, &in_view, &band, tally);
  int found_here = 0, false_here = 0;
  for (const auto& o : obs)
  {
    if (!opt.dump_path.empty())
      *dump << k << ',' << o.center.x() << ',' << o.center.y() << ',' << o.radius << ',' << o.num_points << ','
            << core::trunkMethodName(o.method) << '\n';
    double best_d = kGate;
    const int best = nearestCylinder(o, logs.marks, track, &best_d);
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
        ++tally->found_expected;
        ++tally->band_found[band[static_cast<std::size_t>(best)]];
        tally->errors.push_back(best_d);
      }
      tally->radii.push_back(o.radius);
    }
  }
  tally->expected += expected_here;
  tally->found += found_here;
  tally->false_pos += false_here;
  if (opt.verbose)
    std::printf("scan %3zu: %d in view, %d found, %d unmatched detections\n", k, expected_here, found_here, false_here);
}

void printSummary(const std::string& dir, const core::TrunkDetectorConfig& cfg, const Tally& tally)
{
  const std::vector<double>& radii = tally.radii;
  double mean = 0.0, sd = 0.0;
  for (double r : radii)
    mean += r;
  mean /= std::max<std::size_t>(1, radii.size());
  for (double r : radii)
    sd += (r - mean) * (r - mean);
  sd = std::sqrt(sd / std::max<std::size_t>(1, radii.size()));
  std::vector<double> sorted = radii;
  std::sort(sorted.begin(), sorted.end());
  std::printf("LEGO robot logs (%s), %d scans, method %s:\n", dir.c_str(), tally.scans_used,
              core::trunkMethodName(cfg.method));
  std::printf("  cylinders in view (< %.1f m, inside the scanner's field of view): %d; of those found: %d (%.1f%%)\n",
              kInViewRange, tally.expected, tally.found_expected,
              tally.expected ? 100.0 * tally.found_expected / tally.expected : 0.0);
  std::printf("  detections matched to a true cylinder (%.2f m gate): %d; unmatched detections: %d (%.1f%% of all)\n",
              kGate, tally.found, tally.false_pos,
              tally.found + tally.false_pos ? 100.0 * tally.false_pos / (tally.found + tally.false_pos) : 0.0);
  std::printf("  arcs %d: rejected for size %d, radius %d, inlier ratio %d, shape (occluded edge, range, arc) %d\n",
              tally.clusters, tally.rej_size, tally.rej_radius, tally.rej_inliers, tally.rej_shape);
  const char* band_names[] = { "< 0.5 m", "0.5-1 m", "1-2.5 m" };
  for (int b = 0; b < 3; ++b)
    std::printf("  recall %s: %d of %d (%.1f%%)\n", band_names[b], tally.band_found[b], tally.band_expected[b],
                tally.band_expected[b] ? 100.0 * tally.band_found[b] / tally.band_expected[b] : 0.0);
  if (!tally.errors.empty())
  {
    std::vector<double> errors = tally.errors;
    std::sort(errors.begin(), errors.end());
    double mean_error = 0.0;
    for (double e : errors)
      mean_error += e;
    mean_error /= static_cast<double>(errors.size());
    std::printf(
        "  centre error of the cylinders found [mm] (reference pose, heading from ticks): mean %.1f, median "
        "%.1f, 90th percentile %.1f\n",
        1000.0 * mean_error, 1000.0 * errors[errors.size() / 2], 1000.0 * errors[errors.size() * 9 / 10]);
  }
  if (!sorted.empty())
    std::printf("  radius estimates [mm] (true 55): mean %.1f, sd %.1f, median %.1f\n", 1000.0 * mean, 1000.0 * sd,
                1000.0 * sorted[sorted.size() / 2]);
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
    opt.dir = tools::dataDir(opt.dir, "brenner_lego", "lego_trunks");
    if (opt.robot_path.empty())
      opt.robot_path = tools::packageFile("config/lego/robot.yaml");
    const LegoRobot robot = readRobot(opt.robot_path);
    const Logs logs = readLogs(opt.dir);
    const core::TrunkDetectorConfig cfg = detectorConfig(opt);
    core::TrunkDetector detector(cfg);

    std::ostringstream dump;                    // written (atomically) after the last scan
    dump << "scan,x,y,radius,points,method\n";  // each detection in the scanner frame [m]
    ScannerTrack track;
    track.heading = robot.start_yaw;
    track.prev_l = logs.motors[0].at(1);
    track.prev_r = logs.motors[0].at(5);
    Tally tally;
    for (std::size_t k = 0; k < logs.n; ++k)
    {
      advanceTrack(logs, robot, k, &track);
      int beams = 0;
      const core::PlanarScan scan = planarScanOf(logs.scans[k], robot, &beams);
      core::TrunkDetectorStats st;
      const auto obs = detector.detectScan(scan, &st);
      tally.clusters += st.clusters;
      tally.rej_size += st.rejected_size;
      tally.rej_radius += st.rejected_radius;
      tally.rej_inliers += st.rejected_inliers;
      tally.rej_shape += st.rejected_shape;
      ++tally.scans_used;
      scoreScan(opt, k, obs, scan, beams, logs, track, &dump, &tally);
    }
    if (!opt.dump_path.empty())
      io::writeFileAtomic(opt.dump_path, dump.str());
    printSummary(opt.dir, cfg, tally);
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "lego_trunks: %s\n", e.what());
    return 1;
  }
  return 0;
}
