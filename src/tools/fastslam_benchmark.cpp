// FastSLAM on the simulated forest through the in-process runner, over seeds; prints a table with the same
// runs' dead reckoning. Not a test. --particles, --method and --proposal take comma-separated lists: every
// combination runs on the same simulated data of each seed (one simulation per seed, paired comparisons),
// each with its own table and, with --out, its own directory DIR/<proposal>_<method>_p<particles>.
//
//   rosrun rbpf_slam fastslam_benchmark [--world FILE] [--drive straight|loop|FILE] [--particles N]
//                                       [--seeds K] [--method circle|centroid] [--first-seed S]
//                                       [--proposal fastslam1|fastslam2] [--mixture F]
//                                       [--odometry-noise K] [--sim-config FILE] [--config FILE]...
//                                       [--extraction-config FILE] [--start X Y YAW_DEG] [--gate M] [--fail-ate M]
//                                       [--loop-closure on|off|both]
//
// --sim-config: simulator, follower and relay keys (config/forest_sim.yaml); the robot, its odometry and the
//   sensor: with the 3D lidar disabled and the 2D scanner enabled the runs use the scanner.
// --config: filter keys (config/fastslam.yaml), repeatable, later files over earlier ones (e.g. config/fastslam.yaml
//   then config/odometry/car.yaml); --extraction-config: extraction keys (config/trunk_extraction.yaml). Without them
//   the built-in defaults; --particles, --method, --proposal and --mixture override the files where given.
// --start: the start pose in the world (default: the simulator configuration's, (0, 15, 0)); the drive's waypoints
//   are in the start frame.
// --gate: a feature counts as a tree within this distance [m] (default 0.5).
// --loop-closure: loop closure on, off, or both as two variants on the same data (default: the configuration's, on).
//   With it on, each seed's row has a second line (loops closed, false, refused; the run smoothed at its end).
// A run FAILS when its final error exceeds 1 m (with --fail-ate M: when its ATE exceeds M m instead) or when the
// robot collided (a collision ends the run; it is printed with the run).
#include <pcl/console/print.h>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <sys/stat.h>
#include <string>
#include <vector>

#include "package_dir.h"
#include "rbpf_slam/eval/forest_slam_runner.h"
#include "rbpf_slam/sim/path_follower.h"
#include "rbpf_slam/io/fastslam_config.h"
#include "rbpf_slam/io/files.h"
#include "rbpf_slam/io/run_output.h"
#include "rbpf_slam/sim/sim_config.h"
#include "rbpf_slam/io/trunk_detector_config.h"
#include "rbpf_slam/sim/waypoints_file.h"
#include "rbpf_slam/sim/drive_check.h"
#include "rbpf_slam/sim/world_file.h"

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

std::vector<std::string> splitList(const std::string& s)
{
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty())
      out.push_back(item);
  return out;
}

/** Figures of one variant over the seeds. */
struct Series
{
  std::string label, proposal, method;
  int particles = 0;
  std::vector<double> fin, fin_dr, ate, ate_dr, dist, recall, rad, dup, spur, rate, filter_rate, driven, speed, coverage;
  bool loops = false;  ///< loop closure on
  std::vector<double> fin_smoothed, ate_smoothed, loop_seconds;
  int loops_closed = 0, loops_rejected = 0, false_loops = 0, failed_smoothed = 0;
  std::vector<std::string> rows;
  int failed = 0, collided = 0;
  int warned = 0, failed_warned = 0;  ///< runs whose filter health warned; failed runs among them
};

/** Command-line options; the filter's defaults come from the configuration files where an option is not given. */
struct Options
{
  std::string world_path;  // default: the package's config/worlds/paper_forest.yaml
  std::string drive = "straight", methods = "circle", particle_list = "100", proposals = "fastslam1";
  int seeds = 20, first_seed = 1;
  bool ideal = false;  // diagnostic: odometry without noise, mismatch or latency
  double mixture = 0.0;
  double odometry_noise = 1.0;  // --odometry-noise K: the simulated wheel noise and scale mismatch times K
  std::string out_dir;          // --out DIR: TUM trajectories, maps and summary.json
  std::string sim_config_path, detector_config_path;
  std::vector<std::string> filter_config_paths;
  bool particles_given = false, method_given = false, proposal_given = false, mixture_given = false;
  bool start_given = false;
  std::string loop_closure;  // --loop-closure on|off|both (default: the configuration's)
  core::Pose2 start_pose;
  double gate = 0.5, fail_ate = 0.0;
};

const char* const kHeader = "%5s %9s %9s %8s %8s %8s %7s %5s %5s %8s %7s %8s %6s %6s\n";

/** The number an option takes; exits with the usage status when @p text is not one. */
double number(const char* option, const char* text)
{
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0' || !std::isfinite(v))
  {
    std::fprintf(stderr, "fastslam_benchmark: %s takes a number, got '%s'\n", option, text);
    std::exit(2);
  }
  return v;
}

/** Reads the options; false (after printing the usage) for an unknown option or one without its value. */
bool parseOptions(int argc, char** argv, Options* opt)
{
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    if (a == "--sim-config" && has)
      opt->sim_config_path = argv[++i];
    else if (a == "--config" && has)
      opt->filter_config_paths.push_back(argv[++i]);
    else if (a == "--extraction-config" && has)
      opt->detector_config_path = argv[++i];
    else if (a == "--start" && i + 3 < argc)
    {
      opt->start_pose.x = number("--start", argv[++i]);
      opt->start_pose.y = number("--start", argv[++i]);
      opt->start_pose.theta = number("--start", argv[++i]) * M_PI / 180.0;
      opt->start_given = true;
    }
    else if (a == "--gate" && has)
      opt->gate = number("--gate", argv[++i]);
    else if (a == "--fail-ate" && has)
      opt->fail_ate = number("--fail-ate", argv[++i]);
    else if (a == "--world" && has)
      opt->world_path = argv[++i];
    else if (a == "--drive" && has)
      opt->drive = argv[++i];
    else if (a == "--particles" && has)
    {
      opt->particle_list = argv[++i];
      opt->particles_given = true;
    }
    else if (a == "--seeds" && has)
      opt->seeds = std::atoi(argv[++i]);
    else if (a == "--first-seed" && has)
      opt->first_seed = std::atoi(argv[++i]);
    else if (a == "--out" && has)
      opt->out_dir = argv[++i];
    else if (a == "--ideal-odometry")
      opt->ideal = true;
    else if (a == "--method" && has)
    {
      opt->methods = argv[++i];
      opt->method_given = true;
    }
    else if (a == "--proposal" && has)
    {
      opt->proposals = argv[++i];
      opt->proposal_given = true;
    }
    else if (a == "--mixture" && has)
    {
      opt->mixture = std::atof(argv[++i]);
      opt->mixture_given = true;
    }
    else if (a == "--odometry-noise" && has)
      opt->odometry_noise = std::atof(argv[++i]);
    else if (a == "--loop-closure" && has)
      opt->loop_closure = argv[++i];
    else
    {
      std::fprintf(stderr,
                   "usage: %s [--world FILE] [--drive straight|loop|FILE] [--particles N[,N...]] [--seeds K] "
                   "[--method circle|centroid[,...]] [--first-seed S] [--ideal-odometry] [--out DIR]\n"
                   "       [--proposal fastslam1|fastslam2[,...]] [--mixture F] [--odometry-noise K]\n"
                   "       [--sim-config FILE] [--config FILE]... [--extraction-config FILE] [--start X Y YAW_DEG]\n"
                   "       [--gate M] [--fail-ate M] [--loop-closure on|off|both]\n"
                   "A run fails when its final error exceeds 1 m (with --fail-ate M: its ATE exceeds M m) or the robot "
                   "collided.\n",
                   argv[0]);
      return false;
    }
  }
  return true;
}

/** Configuration files: each key a file gives must be one its reader knows. */
void warnUnused(const io::YamlParamSource& params, const std::string& path)
{
  for (const auto& k : params.unusedKeys())
    if (std::find(io::nodeOnlyKeys().begin(), io::nodeOnlyKeys().end(), k) == io::nodeOnlyKeys().end())
      std::fprintf(stderr, "fastslam_benchmark: warning: %s: unknown key '%s' ignored\n", path.c_str(), k.c_str());
}

/**
 * Reads the configuration files into the scenario, the filter and the extraction; the filter's and the extraction's
 * settings become the defaults of the options not given.
 */
void readConfigs(Options* opt, sim::ScenarioConfig* scenario, core::TrunkSlamConfig* base_filter,
                 core::TrunkDetectorConfig* base_detector)
{
  if (!opt->sim_config_path.empty())
  {
    io::YamlParamSource params(opt->sim_config_path);
    sim::readScenarioConfig(params, scenario);
    warnUnused(params, opt->sim_config_path);
  }
  if (opt->start_given)
    scenario->sim.start = opt->start_pose;
  for (const std::string& path : opt->filter_config_paths)
  {
    io::YamlParamSource params(path);
    io::readFastSlamConfig(params, base_filter);
    warnUnused(params, path);
  }
  if (!opt->detector_config_path.empty())
  {
    io::YamlParamSource params(opt->detector_config_path);
    io::readTrunkDetectorConfig(params, base_detector);
    warnUnused(params, opt->detector_config_path);
  }
  if (!opt->particles_given)
    opt->particle_list = std::to_string(base_filter->particles);
  if (!opt->method_given)
    opt->methods = core::trunkMethodName(base_detector->method);
  if (!opt->proposal_given)
    opt->proposals = base_filter->proposal == core::PoseProposal::kFastSlam2 ? "fastslam2" : "fastslam1";
  if (!opt->mixture_given)
    opt->mixture = base_filter->mixture_fraction;
}

/** The drive and the odometry the options ask for. */
void setDriveAndOdometry(const Options& opt, sim::ScenarioConfig* scenario)
{
  std::string error;
  scenario->drive = sim::namedDrive(opt.drive, &error);
  if (!error.empty())
    throw std::runtime_error(error);
  if (opt.ideal)
  {
    scenario->sim.odometry.left_scale = scenario->sim.odometry.right_scale = 1.0;
    scenario->sim.odometry.wheel_sigma = 0.0;
    scenario->sim.robot.turn_slip = 0.0;
  }
  {
    auto& o = scenario->sim.odometry;
    o.wheel_sigma *= opt.odometry_noise;
    o.left_scale = 1.0 + opt.odometry_noise * (o.left_scale - 1.0);
    o.right_scale = 1.0 + opt.odometry_noise * (o.right_scale - 1.0);
  }
}

/** Every combination of the listed loop settings, proposals, methods and particle counts, with its series. */
void makeVariants(const Options& opt, const core::TrunkDetectorConfig& base_detector,
                  const core::TrunkSlamConfig& base_filter, std::vector<eval::ForestSlamVariant>* variants,
                  std::vector<Series>* series)
{
  std::vector<std::string> loop_settings{ "" };
  if (opt.loop_closure == "both")
    loop_settings = { "off", "on" };
  else if (opt.loop_closure == "on" || opt.loop_closure == "off")
    loop_settings = { opt.loop_closure };
  else if (!opt.loop_closure.empty())
    throw std::runtime_error("--loop-closure must be on, off or both, not '" + opt.loop_closure + "'");
  for (const std::string& loops : loop_settings)
    for (const std::string& proposal : splitList(opt.proposals))
      for (const std::string& method : splitList(opt.methods))
        for (const std::string& np : splitList(opt.particle_list))
        {
          eval::ForestSlamVariant v;
          v.detector = base_detector;
          v.filter = base_filter;
          if (!core::parseTrunkMethod(method, &v.detector.method))
            throw std::runtime_error("--method must be circle or centroid");
          if (!core::parsePoseProposal(proposal, &v.filter.proposal))
            throw std::runtime_error("--proposal must be fastslam1 or fastslam2");
          v.filter.particles = std::atoi(np.c_str());
          v.filter.mixture_fraction = opt.mixture;
          if (!loops.empty())
            v.filter.loop_closure.enabled = loops == "on";
          const std::string err = v.filter.validate();
          if (!err.empty())
            throw std::runtime_error(err);
          variants->push_back(v);
          Series s;
          s.proposal = proposal;
          s.method = method;
          s.particles = v.filter.particles;
          s.label = proposal + "_" + method + "_p" + np + (loops.empty() ? "" : "_loops_" + loops);
          s.loops = v.filter.loop_closure.enabled;
          series->push_back(s);
        }
}

/** The title of a series' table (after @p lead) and the column heads. */
void printTableHead(const char* lead, const Options& opt, const std::string& world_name, const Series& q)
{
  std::printf(
      "%sFastSLAM %s, %s drive, %d particles, extraction %s, proposal %s, mixture %.2f, odometry noise "
      "x%.1f, seeds %d..%d\n",
      lead, world_name.c_str(), opt.drive.c_str(), q.particles, q.method.c_str(), q.proposal.c_str(), opt.mixture,
      opt.odometry_noise, opt.first_seed, opt.first_seed + opt.seeds - 1);
  std::printf(kHeader, "seed", "final [m]", "DR [m]", "ATE [m]", "DR ATE", "tree-ft", "recall", "dup", "spur",
              "r RMS cm", "sweeps", "rate Hz", "warned", "cover");
}

/** Adds a run's loop-closure line to its row and counts its loops and its smoothed run. */
void addLoops(const Options& opt, const eval::ForestSlamRunResult& r, Series* series)
{
  Series& q = *series;
  char loop_row[256];
  std::snprintf(loop_row, sizeof(loop_row),
                "      loops: %d closed (%d false), %d refused, longest solve %.3f s; smoothed: final %.3f m, "
                "ATE %.3f m, tree-ft %.3f m, recall %.1f%%, dup %d, spur %d\n",
                r.loops_closed, r.false_loops, r.loops_rejected, r.max_loop_seconds, r.final_error_smoothed,
                r.ate_smoothed, r.map_smoothed.mean_distance, 100.0 * r.map_smoothed.recall, r.map_smoothed.duplicates,
                r.map_smoothed.spurious);
  q.rows.back() += loop_row;
  q.loops_closed += r.loops_closed;
  q.loops_rejected += r.loops_rejected;
  q.false_loops += r.false_loops;
  q.loop_seconds.push_back(r.max_loop_seconds);
  if (r.smoothed)
  {
    q.fin_smoothed.push_back(r.final_error_smoothed);
    q.ate_smoothed.push_back(r.ate_smoothed);
  }
  const bool failed_smoothed =
      !r.smoothed || (opt.fail_ate > 0.0 ? r.ate_smoothed > opt.fail_ate : r.final_error_smoothed > 1.0) || r.collided;
  q.failed_smoothed += failed_smoothed;
}

/** Adds a run's figures to its series. */
void addFigures(const Options& opt, const eval::ForestSlamRunResult& r, double hz, double wall, Series* series)
{
  Series& q = *series;
  q.fin.push_back(r.final_error);
  q.fin_dr.push_back(r.final_error_odometry);
  q.ate.push_back(r.ate);
  q.ate_dr.push_back(r.ate_odometry);
  q.dist.push_back(r.map.mean_distance);
  q.recall.push_back(r.map.recall);
  q.rad.push_back(r.map.radius_rms);
  q.dup.push_back(r.map.duplicates);
  q.spur.push_back(r.map.spurious);
  q.rate.push_back(hz);
  q.coverage.push_back(r.coverage);
  q.filter_rate.push_back(r.sweeps / std::max(1e-9, r.seconds_filter));
  const bool failed = (opt.fail_ate > 0.0 ? r.ate > opt.fail_ate : r.final_error > 1.0) || r.collided;
  q.failed += failed;
  q.collided += r.collided;
  q.warned += r.health_warnings > 0;
  q.failed_warned += failed && r.health_warnings > 0;
  q.driven.push_back(r.distance);
  q.speed.push_back(r.simulated_seconds / std::max(1e-9, wall));
}

/** With --out: the run's trajectories, maps and true trees under the series' directory. */
void writeRunFiles(const Options& opt, std::size_t series_count, const Series& q, int s,
                   const eval::ForestSlamRunResult& r)
{
  mkdir(opt.out_dir.c_str(), 0755);
  const std::string dir = series_count == 1 ? opt.out_dir : opt.out_dir + "/" + q.label;
  mkdir(dir.c_str(), 0755);
  const std::string base = dir + "/seed" + std::to_string(s);
  io::writeTum(base + "_estimate.tum", r.stamps, r.estimate);
  io::writeTum(base + "_odometry.tum", r.stamps, r.odometry);
  io::writeTum(base + "_truth.tum", r.stamps, r.truth);
  io::writeLandmarksCsv(base + "_map.csv", r.landmarks);
  if (r.smoothed)
  {
    io::writeTum(base + "_estimate_smoothed.tum", r.stamps_smoothed, r.estimate_smoothed);
    io::writeLandmarksCsv(base + "_map_smoothed.csv", r.landmarks_smoothed);
  }
  std::ostringstream trees;
  trees << "x,y,radius,seen\n";
  for (std::size_t t = 0; t < r.trees.size(); ++t)
    trees << r.trees[t].position.x() << ',' << r.trees[t].position.y() << ',' << r.trees[t].radius << ','
          << (r.tree_seen[t] ? 1 : 0) << '\n';
  io::writeFileAtomic(base + "_trees.csv", trees.str());
}

/**
 * One run of seed @p s: its row (printed at once when there is one series, else a line on stderr), its figures, its
 * collision and, with --out, its files.
 */
void reportRun(const Options& opt, const std::string& world_name, int s, const eval::ForestSlamRunResult& r,
               double wall, std::size_t series_count, Series* series)
{
  Series& q = *series;
  const double hz = r.sweeps / std::max(1e-9, r.seconds_extraction + r.seconds_filter);
  char row[256];
  std::snprintf(row, sizeof(row), "%5d %9.3f %9.3f %8.3f %8.3f %8.3f %6.1f%% %5d %5d %8.2f %7d %8.1f %6d %5.1f%%\n", s,
                r.final_error, r.final_error_odometry, r.ate, r.ate_odometry, r.map.mean_distance, 100.0 * r.map.recall,
                r.map.duplicates, r.map.spurious, 100.0 * r.map.radius_rms, r.sweeps, hz, r.health_warnings,
                100.0 * r.coverage);
  q.rows.push_back(row);
  if (q.loops)
    addLoops(opt, r, &q);
  if (series_count == 1)
  {
    if (s == opt.first_seed)
      printTableHead("", opt, world_name, q);
    std::fputs(q.rows.back().c_str(), stdout);
    std::fflush(stdout);
  }
  else
  {
    std::fprintf(stderr, "seed %d %s: final %.3f m (DR %.3f), ATE %.3f (DR %.3f)\n", s, q.label.c_str(), r.final_error,
                 r.final_error_odometry, r.ate, r.ate_odometry);
  }
  addFigures(opt, r, hz, wall, &q);
  if (r.collided)
    std::printf(
        "seed %d %s: COLLISION at %.1f s, true pose (%.2f, %.2f, %.1f deg) in the world: hit %s; the run "
        "ended there (FAILED)\n",
        s, q.label.c_str(), r.collision.stamp, r.collision.pose.x, r.collision.pose.y,
        r.collision.pose.theta * 180.0 / M_PI, r.collision_what.c_str());
  if (!opt.out_dir.empty())
    writeRunFiles(opt, series_count, q, s, r);
}

/** A series' table (its rows when there are several series), its median and worst lines and its loops. */
void printSeriesTable(const Options& opt, const std::string& world_name, std::size_t series_count, const Series& q)
{
  if (series_count > 1)
  {
    printTableHead("\n", opt, world_name, q);
    for (const auto& row : q.rows)
      std::fputs(row.c_str(), stdout);
  }
  std::printf("median %9.3f %9.3f %8.3f %8.3f %8.3f %6.1f%% %5.0f %5.0f %8.2f %7s %8.1f %6s %5.1f%%\n", median(q.fin),
              median(q.fin_dr), median(q.ate), median(q.ate_dr), median(q.dist), 100.0 * median(q.recall),
              median(q.dup), median(q.spur), 100.0 * median(q.rad), "", median(q.rate), "", 100.0 * median(q.coverage));
  std::printf("worst  %9.3f %9.3f %8.3f %8.3f %8.3f %6.1f%% %5.0f %5.0f %8.2f %7s %8.1f %6s %5.1f%%\n", worst(q.fin),
              best(q.fin_dr), worst(q.ate), best(q.ate_dr), worst(q.dist), 100.0 * best(q.recall), worst(q.dup),
              worst(q.spur), 100.0 * worst(q.rad), "", best(q.rate), "", 100.0 * best(q.coverage));
  if (q.loops)
    std::printf(
        "loop closure: %d loops closed (%d false), %d refused by the smoother; longest solve %.3f s "
        "(worst seed); smoothed at the end: final %.3f / %.3f m, ATE %.3f / %.3f m (median / worst), "
        "failed %d of %d\n",
        q.loops_closed, q.false_loops, q.loops_rejected, worst(q.loop_seconds), median(q.fin_smoothed),
        worst(q.fin_smoothed), median(q.ate_smoothed), worst(q.ate_smoothed), q.failed_smoothed, opt.seeds);
}

/** With --out: the series' summary.json. */
void writeSummary(const Options& opt, std::size_t series_count, const Series& q)
{
  const std::string dir = series_count == 1 ? opt.out_dir : opt.out_dir + "/" + q.label;
  std::ostringstream js;
  js << "{\"world\": \"" << opt.world_path << "\", \"drive\": \"" << opt.drive << "\", \"particles\": " << q.particles
     << ", \"method\": \"" << q.method << "\", \"proposal\": \"" << q.proposal << "\", \"mixture\": " << opt.mixture
     << ", \"odometry_noise\": " << opt.odometry_noise << ", \"first_seed\": " << opt.first_seed
     << ", \"seeds\": " << opt.seeds << ", \"failed\": " << q.failed << ", \"collisions\": " << q.collided
     << ", \"health_warned\": " << q.warned << ", \"failed_and_warned\": " << q.failed_warned
     << ", \"gate_m\": " << opt.gate << ", \"fail_ate_m\": " << opt.fail_ate << ",\n "
     << jsonStats("driven_m", q.driven, false) << ",\n " << jsonStats("real_time_factor", q.speed, false) << ",\n "
     << jsonStats("final_error_m", q.fin) << ",\n " << jsonStats("final_error_dead_reckoning_m", q.fin_dr, false)
     << ",\n " << jsonStats("ate_m", q.ate) << ",\n " << jsonStats("ate_dead_reckoning_m", q.ate_dr, false) << ",\n "
     << jsonStats("tree_to_feature_m", q.dist) << ",\n " << jsonStats("recall", q.recall, false) << ",\n "
     << jsonStats("duplicates", q.dup) << ",\n " << jsonStats("spurious", q.spur) << ",\n "
     << jsonStats("radius_rms_m", q.rad) << ",\n " << jsonStats("rate_hz", q.rate, false) << ",\n "
     << jsonStats("filter_rate_hz", q.filter_rate, false) << ",\n " << jsonStats("coverage_95", q.coverage, false);
  if (q.loops)
    js << ",\n \"loops_closed\": " << q.loops_closed << ", \"false_loops\": " << q.false_loops
       << ", \"loops_refused\": " << q.loops_rejected << ", \"failed_smoothed\": " << q.failed_smoothed << ",\n "
       << jsonStats("final_error_smoothed_m", q.fin_smoothed) << ",\n " << jsonStats("ate_smoothed_m", q.ate_smoothed)
       << ",\n " << jsonStats("longest_loop_solve_s", q.loop_seconds);
  js << "}\n";
  io::writeFileAtomic(dir + "/summary.json", js.str());
  std::printf("wrote %s/summary.json and per-seed TUM trajectories and maps\n", dir.c_str());
}

/** The lines under a series' table: distance and speed, health, failures. */
void printSeriesNotes(const Options& opt, const Series& q)
{
  std::printf("driven %.0f m (median), %.1f x real time (median; simulation and all variants of a seed)\n",
              median(q.driven), median(q.speed));
  std::printf(
      "health: warned (any cause: health_cause in a run folder) in %d of %d runs ('warned': updates), in %d of "
      "the %d failed runs; 'cover': updates with the truth inside the published estimate's 95 %% region\n",
      q.warned, opt.seeds, q.failed_warned, q.failed);
  if (opt.fail_ate > 0.0)
    std::printf(
        "failed runs (ATE > %.1f m, or a collision): %d of %d, collisions %d   (DR columns: the same runs' "
        "dead reckoning; 'worst' DR = the smallest drift)\n",
        opt.fail_ate, q.failed, opt.seeds, q.collided);
  else
    std::printf(
        "failed runs (final error > 1 m, or a collision): %d of %d, collisions %d   (DR columns: the same "
        "runs' dead reckoning; 'worst' DR = the smallest drift)\n",
        q.failed, opt.seeds, q.collided);
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
    if (!(opt.gate > 0.0) || opt.fail_ate < 0.0)
      throw std::runtime_error("--gate must be > 0 and --fail-ate >= 0");
    if (opt.world_path.empty())
      opt.world_path = tools::packageFile("config/worlds/paper_forest.yaml");
    const sim::ForestWorld world = sim::loadForestWorld(opt.world_path);
    sim::ScenarioConfig scenario;
    core::TrunkSlamConfig base_filter;
    core::TrunkDetectorConfig base_detector;
    readConfigs(&opt, &scenario, &base_filter, &base_detector);
    setDriveAndOdometry(opt, &scenario);
    std::string refused;
    if (!sim::checkDrive(world, scenario, &refused))
      throw std::runtime_error("the drive '" + opt.drive + "' is refused before it starts: " + refused);
    std::vector<eval::ForestSlamVariant> variants;
    std::vector<Series> series;
    makeVariants(opt, base_detector, base_filter, &variants, &series);
    const std::string world_name = opt.world_path.substr(opt.world_path.find_last_of('/') + 1);
    for (int s = opt.first_seed; s < opt.first_seed + opt.seeds; ++s)
    {
      scenario.sim.seed = static_cast<std::uint64_t>(s);
      for (auto& v : variants)
      {
        v.filter.seed = static_cast<std::uint64_t>(s);
        v.detector.seed = static_cast<std::uint64_t>(s);
      }
      const auto wall_start = std::chrono::steady_clock::now();
      const std::vector<eval::ForestSlamRunResult> results =
          eval::runForestSlamVariants(world, scenario, variants, opt.gate);
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
      for (std::size_t k = 0; k < results.size(); ++k)
        reportRun(opt, world_name, s, results[k], wall, series.size(), &series[k]);
    }
    for (const Series& q : series)
    {
      printSeriesTable(opt, world_name, series.size(), q);
      if (!opt.out_dir.empty())
        writeSummary(opt, series.size(), q);
      printSeriesNotes(opt, q);
    }
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "fastslam_benchmark: %s\n", e.what());
    return 1;
  }
  return 0;
}
