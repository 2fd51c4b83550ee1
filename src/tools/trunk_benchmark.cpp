// Trunk extraction benchmark: simulated VLP-16 sweeps of the paper and dense worlds, detections against
// the true trunks, per range band, circle against centroid. Prints a table; not a test.
//
//   rosrun rbpf_slam trunk_benchmark [--world FILE]... [--step M] [--no-level] [--true-level] [--by-class]
//                                    [--cluster-fit] [--no-ground-plane]
// --no-level: no tilt estimation from the trunks; --true-level: the cloud is levelled with the true sensor
// attitude first (what an IMU or a tilt-aware TF tree gives a robot). --by-class: the circle method's per-sweep
// figures by range band (1-4, 4-7, 7-10 m) and DBH class (< 10, 10-20, 20-30, >= 30 cm) as a Markdown table, with
// what the spurious detections stand on; the sensor stands where a robot can (clear of saplings and low foliage).
// --cluster-fit: one circle per cluster instead of the stems as columns (column_fit false), for comparison.
// --no-ground-plane: the ground from the lowest points under the slope's cap alone (ground_relief 0), for comparison.
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <pcl/console/print.h>

#include "package_dir.h"
#include "rbpf_slam/sim/forest_simulator.h"
#include "rbpf_slam/core/filter/random.h"
#include "rbpf_slam/core/extraction/trunk_detector.h"
#include "rbpf_slam/core/extraction/ground_model.h"
#include "rbpf_slam/sim/world_file.h"

using namespace rbpf_slam;

namespace
{
const double kBands[] = { 1.0, 2.0, 5.0, 10.0, 15.0, 20.0 };
constexpr int kNumBands = 5;

struct BandStats
{
  int truth_visible = 0;
  int matched = 0;
  int detections = 0;
  int detections_matched = 0;
  double sum_err = 0.0, sum_err2 = 0.0, sum_rad_err2 = 0.0, sum_rad_err = 0.0;
};

int bandOf(double range)
{
  for (int b = 0; b < kNumBands; ++b)
    if (range >= kBands[b] && range < kBands[b + 1])
      return b;
  return -1;
}

struct TrueTrunk
{
  Eigen::Vector3d base;  // world, on the ground
  Eigen::Vector3d axis;  // unit
  double radius0, taper;
  double dbh;  // [m] diameter 1.3 m above the foot
};

struct Result
{
  BandStats band[kNumBands];
  BandStats within10;  // [1, 10) m, the range figures are given for
  std::vector<double> times_ms;
  int spurious_within10 = 0;
  double stage_ms[4] = { 0.0, 0.0, 0.0, 0.0 };
  int split_clusters = 0;  // clusters split into two touching trunks
  std::vector<double> tilt_error_deg;  // per sweep: the estimated tilt against the true attitude's
  std::vector<double> ground_tilt_error_deg;  // per sweep: the seen ground's plane as the tilt, against the same
  int ground_tilt_used = 0;                   // sweeps whose tilt is the ground's (TrunkDetectorStats)
};

/** CPU time of the calling thread [ms]: what a cloud costs, whatever else runs on a shared machine. */
double threadCpuMs()
{
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return 1e3 * static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_nsec);
}

double median(std::vector<double> v)
{
  if (v.empty())
    return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

void add(BandStats* b, bool visible, bool matched, double err, double rad_err)
{
  if (visible)
    ++b->truth_visible;
  if (matched)
  {
    ++b->matched;
    b->sum_err += err;
    b->sum_err2 += err * err;
    b->sum_rad_err += rad_err;
    b->sum_rad_err2 += rad_err * rad_err;
  }
}

bool g_level = true;
bool g_true_level = false;  // level with the true sensor attitude (what a good IMU or TF gives)
bool g_column_fit = true;  // stems as columns of consistent cross-sections (TrunkDetectorConfig::column_fit)
bool g_ground_plane = true;  // the seen ground's plane where the ground is hidden (TrunkDetectorConfig::ground_relief)

std::vector<TrueTrunk> trueTrunks(const sim::ForestWorld& world)
{
  std::vector<TrueTrunk> trunks;
  const sim::Ground ground(world.ground);
  for (const auto& t : world.trunks)
  {
    double breast_radius = 0.0;
    sim::trunkAxisAt(t, 0.0, 1.3, &breast_radius);
    trunks.push_back({ Eigen::Vector3d(t.x, t.y, ground.height(t.x, t.y)),
                       Eigen::Vector3d(t.lean_x, t.lean_y, 1.0).normalized(), t.radius, t.taper, 2.0 * breast_radius });
  }
  return trunks;
}

/** Sensor poses on a grid over the stand, headings drawn from a seeded generator, clear of trunks. */
std::vector<core::Pose2> sensorPoses(const sim::ForestWorld& world, double step)
{
  std::vector<core::Pose2> poses;
  core::Random random(11);
  for (double x = world.min_x + 1.0; x <= world.max_x - 1.0 + 1e-9; x += step)
    for (double y = world.min_y + 1.0; y <= world.max_y - 1.0 + 1e-9; y += step)
    {
      bool clear = true;
      for (const auto& t : world.trunks)
        clear = clear && std::hypot(t.x - x, t.y - y) > t.radius + 0.8;
      const double heading = random.uniform(-M_PI, M_PI);
      if (clear)
        poses.emplace_back(x, y, heading);
    }
  return poses;
}

/**
 * One simulated sweep and the evaluation frame: the sensor's origin, z up, the sensor's heading (what the detector's
 * levelled output approximates).
 */
struct SweepView
{
  sim::LidarSweep sweep;
  std::vector<Eigen::Vector3f> pts;
  Eigen::Isometry3d sensor;
  double yaw = 0.0;
  Eigen::Rotation2Dd to_eval;

  /** The true trunk @p k at a detection's height (sensor-relative z): its axis point in the frame, its radius. */
  std::pair<Eigen::Vector2d, double> truthAt(const std::vector<TrueTrunk>& trunks, std::size_t k, double height) const
  {
    // Axis point at the detection's height (sensor-relative z).
    const double z_world = sensor.translation().z() + height;
    const double s = (z_world - trunks[k].base.z()) / trunks[k].axis.z();
    const Eigen::Vector3d c = trunks[k].base + s * trunks[k].axis;
    const Eigen::Vector2d rel =
        to_eval * Eigen::Vector2d(c.x() - sensor.translation().x(), c.y() - sensor.translation().y());
    return std::make_pair(rel, trunks[k].radius0 - trunks[k].taper * s);
  }
};

SweepView simulateSweep(const sim::ForestWorld& world, const core::Pose2& pose, sim::SimulatorConfig* sim_config)
{
  sim_config->start = pose;
  sim::ForestSimulator sim(world, *sim_config);
  SweepView view;
  sim.castSweep(0.0, &view.sweep);
  view.sensor = sim.bodyPose(pose) * sim_config->lidar3d.mount.transform();
  const Eigen::Vector3d fwd = view.sensor.linear().col(0);
  view.yaw = std::atan2(fwd.y(), fwd.x());
  view.to_eval = Eigen::Rotation2Dd(-view.yaw);
  view.pts.reserve(view.sweep.points.size());
  for (const auto& p : view.sweep.points)
    view.pts.emplace_back(p.x, p.y, p.z);
  return view;
}

/** Visibility: points of the sweep within 5 cm of a trunk's surface at 0.5-2.0 m above its foot, per trunk. */
std::vector<int> trunkHits(const SweepView& view, const std::vector<TrueTrunk>& trunks)
{
  std::vector<int> hits(trunks.size(), 0);
  for (const auto& p : view.sweep.points)
  {
    const Eigen::Vector3d w = view.sensor * Eigen::Vector3d(p.x, p.y, p.z);
    for (std::size_t k = 0; k < trunks.size(); ++k)
    {
      const Eigen::Vector3d rel = w - trunks[k].base;
      if (std::abs(rel.x()) > 1.0 || std::abs(rel.y()) > 1.0)
        continue;
      const double s = rel.dot(trunks[k].axis);
      if (s < 0.5 || s > 2.0)
        continue;
      const double d = (rel - s * trunks[k].axis).norm();
      if (std::abs(d - (trunks[k].radius0 - trunks[k].taper * s)) < 0.05)
        ++hits[k];
    }
  }
  return hits;
}

/** The detector's settings of @p method for the benchmark's options. */
core::TrunkDetectorConfig detectorConfig(core::TrunkMethod method, const sim::SimulatorConfig& sim_config)
{
  core::TrunkDetectorConfig cfg;
  cfg.method = method;
  cfg.sensor_height = sim_config.lidar3d.mount.z;  // from TF on a robot
  cfg.level_by_trunks = g_level;
  cfg.column_fit = g_column_fit;
  if (!g_ground_plane)
    cfg.ground_relief = 0.0;
  return cfg;
}

/** Runs the detector of @p method on the sweep, timing it. */
std::vector<core::TrunkObservation> detect(core::TrunkMethod method, const sim::SimulatorConfig& sim_config,
                                           const SweepView& view, Result* res)
{
  core::TrunkDetector detector(detectorConfig(method, sim_config));
  const double t0 = threadCpuMs();
  core::TrunkDetectorStats stats;
  Eigen::Matrix3d level = Eigen::Matrix3d::Identity();
  if (g_true_level)
    level = Eigen::AngleAxisd(-view.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * view.sensor.linear();
  const auto obs = detector.detect(view.pts, level, &stats);
  res->stage_ms[0] += stats.ms_band;
  res->stage_ms[1] += stats.ms_cluster;
  res->stage_ms[2] += stats.ms_tilt;
  res->stage_ms[3] += stats.ms_fit;
  res->split_clusters += stats.split_clusters;
  res->times_ms.push_back(threadCpuMs() - t0);
  if (!g_true_level)
  {
    // The true tilt: the shift per metre up of a vertical axis in the sensor's frame, removed (x += tilt.x z).
    const Eigen::Vector3d up = view.sensor.linear().transpose() * Eigen::Vector3d::UnitZ();
    const Eigen::Vector2d truth = -up.head<2>() / up.z();
    const Eigen::Vector2d estimate(std::tan(stats.tilt_pitch), -std::tan(stats.tilt_roll));
    res->tilt_error_deg.push_back(std::atan((estimate - truth).norm()) * 180.0 / M_PI);
    if (g_ground_plane)
    {
      const Eigen::Vector2d ground(std::tan(stats.ground_pitch), -std::tan(stats.ground_roll));
      res->ground_tilt_error_deg.push_back(std::atan((ground - truth).norm()) * 180.0 / M_PI);
      res->ground_tilt_used += stats.tilt_from_ground ? 1 : 0;
    }
  }
  return obs;
}

/** Greedy one-to-one matching by distance, 0.5 m gate: the true trunk of each detection, -1 for none. */
std::vector<int> matchTrunks(const std::vector<core::TrunkObservation>& obs, const SweepView& view,
                             const std::vector<TrueTrunk>& trunks)
{
  std::vector<bool> used(trunks.size(), false);
  std::vector<int> match(obs.size(), -1);
  std::vector<std::pair<double, std::pair<int, int>>> pairs;
  for (std::size_t i = 0; i < obs.size(); ++i)
    for (std::size_t k = 0; k < trunks.size(); ++k)
    {
      const double d = (view.truthAt(trunks, k, obs[i].height).first - obs[i].center).norm();
      if (d < 0.5)
        pairs.push_back({ d, { static_cast<int>(i), static_cast<int>(k) } });
    }
  std::sort(pairs.begin(), pairs.end());
  for (const auto& p : pairs)
    if (match[static_cast<std::size_t>(p.second.first)] < 0 && !used[static_cast<std::size_t>(p.second.second)])
    {
      match[static_cast<std::size_t>(p.second.first)] = p.second.second;
      used[static_cast<std::size_t>(p.second.second)] = true;
    }
  return match;
}

/** Per true trunk (recall) and per detection (precision, errors). */
void score(const std::vector<core::TrunkObservation>& obs, const std::vector<int>& match, const SweepView& view,
           const std::vector<TrueTrunk>& trunks, const std::vector<int>& hits, Result* res)
{
  for (std::size_t k = 0; k < trunks.size(); ++k)
  {
    const auto t = view.truthAt(trunks, k, 0.0);
    const double range = t.first.norm();
    const bool visible = hits[k] >= 10;
    const int b = bandOf(range);
    int det = -1;
    for (std::size_t i = 0; i < obs.size(); ++i)
      if (match[i] == static_cast<int>(k))
        det = static_cast<int>(i);
    double err = 0.0, rad_err = 0.0;
    if (det >= 0)
    {
      const auto tt = view.truthAt(trunks, k, obs[static_cast<std::size_t>(det)].height);
      err = (tt.first - obs[static_cast<std::size_t>(det)].center).norm();
      rad_err = obs[static_cast<std::size_t>(det)].radius - tt.second;
    }
    // A detection of a trunk that is not "visible" by the count still counts as matched (not spurious),
    // but recall is over visible trunks only.
    const bool counted_match = det >= 0 && visible;
    if (b >= 0)
      add(&res->band[b], visible, counted_match, err, rad_err);
    if (range >= 1.0 && range < 10.0)
      add(&res->within10, visible, counted_match, err, rad_err);
  }
  for (std::size_t i = 0; i < obs.size(); ++i)
  {
    const int b = bandOf(obs[i].range);
    if (b >= 0)
    {
      ++res->band[b].detections;
      if (match[i] >= 0)
        ++res->band[b].detections_matched;
    }
    if (obs[i].range >= 1.0 && obs[i].range < 10.0)
    {
      ++res->within10.detections;
      if (match[i] >= 0)
        ++res->within10.detections_matched;
      if (match[i] < 0)
        ++res->spurious_within10;
    }
  }
}

void printResults(const std::string& name, int sweeps, std::size_t points_total, std::size_t trunks,
                  const core::TrunkMethod* methods, const Result* res)
{
  std::printf("\n== %s: %d sweeps (%.0f points each), %zu trunks\n", name.c_str(), sweeps,
              sweeps ? static_cast<double>(points_total) / sweeps : 0.0, trunks);
  std::printf("%-9s %-10s %9s %9s %9s %9s %8s %10s %9s\n", "method", "band [m]", "centre", "centre", "radius",
              "radius", "recall", "precision", "visible");
  std::printf("%-9s %-10s %9s %9s %9s %9s %8s %10s %9s\n", "", "", "mean [cm]", "RMS [cm]", "bias [cm]", "RMS [cm]",
              "", "", "trunks");
  for (int m = 0; m < 2; ++m)
  {
    const auto line = [&](const char* band, const BandStats& b) {
      const double n = std::max(1, b.matched);
      std::printf("%-9s %-10s %9.1f %9.1f %9.1f %9.1f %7.1f%% %9.1f%% %9d\n", core::trunkMethodName(methods[m]), band,
                  100.0 * b.sum_err / n, 100.0 * std::sqrt(b.sum_err2 / n), 100.0 * b.sum_rad_err / n,
                  100.0 * std::sqrt(b.sum_rad_err2 / n), b.truth_visible ? 100.0 * b.matched / b.truth_visible : 0.0,
                  b.detections ? 100.0 * b.detections_matched / b.detections : 0.0, b.truth_visible);
    };
    for (int b = 0; b < kNumBands; ++b)
    {
      char label[32];
      std::snprintf(label, sizeof(label), "%.0f-%.0f", kBands[b], kBands[b + 1]);
      line(label, res[m].band[b]);
    }
    line("1-10", res[m].within10);
    const BandStats& w = res[m].within10;
    std::printf("%-9s within 10 m: %d detections, %d spurious (precision %.1f%%); CPU time per cloud median %.2f ms, "
                "worst %.2f ms\n",
                core::trunkMethodName(methods[m]), w.detections, res[m].spurious_within10,
                w.detections ? 100.0 * (w.detections - res[m].spurious_within10) / w.detections : 0.0,
                median(res[m].times_ms), *std::max_element(res[m].times_ms.begin(), res[m].times_ms.end()));
    const double n = std::max<std::size_t>(1, res[m].times_ms.size());
    std::printf("%-9s mean wall time per cloud: ground+band %.2f ms, clustering %.2f ms, tilt %.2f ms, fits %.2f ms; "
                "clusters split into two trunks: %d\n",
                core::trunkMethodName(methods[m]), res[m].stage_ms[0] / n, res[m].stage_ms[1] / n, res[m].stage_ms[2] / n,
                res[m].stage_ms[3] / n, res[m].split_clusters);
  }
}

void run(const std::string& name, const sim::ForestWorld& world, double step)
{
  sim::SimulatorConfig sim_config;
  const std::vector<TrueTrunk> trunks = trueTrunks(world);
  const std::vector<core::Pose2> poses = sensorPoses(world, step);

  Result res[2];
  const core::TrunkMethod methods[2] = { core::TrunkMethod::kCircle, core::TrunkMethod::kCentroid };
  int sweeps = 0;
  std::size_t points_total = 0;
  for (const auto& pose : poses)
  {
    const SweepView view = simulateSweep(world, pose, &sim_config);
    points_total += view.pts.size();
    ++sweeps;
    const std::vector<int> hits = trunkHits(view, trunks);
    for (int m = 0; m < 2; ++m)
    {
      const std::vector<core::TrunkObservation> obs = detect(methods[m], sim_config, view, &res[m]);
      // Truth in the evaluation frame at each detection's height.
      const std::vector<int> match = matchTrunks(obs, view, trunks);
      score(obs, match, view, trunks, hits, &res[m]);
    }
  }
  printResults(name, sweeps, points_total, trunks.size(), methods, res);
}
// --- Per-sweep figures by range band and DBH class (--by-class) ---------------------------------------------

const double kClassBands[] = { 1.0, 4.0, 7.0, 10.0 };
constexpr int kNumClassBands = 3;
const double kDbhClasses[] = { 0.0, 0.10, 0.20, 0.30, 1e9 };  // [m]
constexpr int kNumDbhClasses = 4;

struct ClassStats
{
  int in_scope = 0;  // true trees over the sweeps
  int visible = 0;   // of them with >= 10 returns on the stem 0.5-2 m above its foot
  int found = 0;     // matched, visible or not
  int found_visible = 0;
  int detections = 0;
  int detections_matched = 0;
  int fits = 0;  // matched trees whose errors are summed
  double sum_centre2 = 0.0, sum_dbh = 0.0, sum_dbh2 = 0.0;
};

/** What a spurious detection stands on (the first that applies). */
struct SpuriousKinds
{
  int stem = 0;     // within 1 m of a true stem: its branches, or a second circle on it
  int sapling = 0;  // within 1 m of a sapling
  int foliage = 0;  // within 0.3 m of low foliage (shrubs, bushes, tufts, sapling crowns)
  int other = 0;    // anything else (ground, rocks, fallen wood)
};

struct ClassResult
{
  ClassStats band[kNumClassBands];
  std::vector<double> ground_error[kNumClassBands];  ///< [m] the detector's ground at each tree's foot less the truth
  ClassStats dbh[kNumDbhClasses];
  ClassStats all;
  SpuriousKinds spurious;
  int sweeps = 0;
  std::size_t points = 0;
};

int classOf(double value, const double* edges, int n)
{
  for (int i = 0; i < n; ++i)
    if (value >= edges[i] && value < edges[i + 1])
      return i;
  return -1;
}

/** Foliage low enough to stand in a robot's way or the lidar's (its lowest point below 2.5 m). */
bool lowFoliage(const sim::FoliageSpec& f)
{
  return f.center.z() - f.radius < 2.5;
}

/** The sensor poses of sensorPoses() where a robot can stand: 0.6 m clear of saplings, 0.3 m of low foliage. */
std::vector<core::Pose2> robotPoses(const sim::ForestWorld& world, double step)
{
  std::vector<core::Pose2> poses;
  for (const core::Pose2& p : sensorPoses(world, step))
  {
    bool clear = true;
    for (const auto& s : world.saplings)
      clear = clear && std::hypot(s.x - p.x, s.y - p.y) > s.radius + 0.6;
    for (const auto& f : world.foliage)
      clear = clear && (!lowFoliage(f) || std::hypot(f.center.x() - p.x, f.center.y() - p.y) > f.radius + 0.3);
    if (clear)
      poses.push_back(p);
  }
  return poses;
}

void addTree(ClassStats* s, bool visible, bool found, double centre_err, double dbh_err)
{
  ++s->in_scope;
  s->visible += visible ? 1 : 0;
  s->found += found ? 1 : 0;
  s->found_visible += found && visible ? 1 : 0;
  if (found)
  {
    ++s->fits;
    s->sum_centre2 += centre_err * centre_err;
    s->sum_dbh += dbh_err;
    s->sum_dbh2 += dbh_err * dbh_err;
  }
}

void addDetection(ClassStats* s, bool matched)
{
  ++s->detections;
  s->detections_matched += matched ? 1 : 0;
}

/** Classifies the unmatched detection @p o of the sweep by what stands there. */
void classifySpurious(const core::TrunkObservation& o, const SweepView& view, const std::vector<TrueTrunk>& trunks,
                      const sim::ForestWorld& world, SpuriousKinds* kinds)
{
  for (std::size_t k = 0; k < trunks.size(); ++k)
    if ((view.truthAt(trunks, k, o.height).first - o.center).norm() < 1.0)
    {
      ++kinds->stem;
      return;
    }
  const Eigen::Vector2d at = view.sensor.translation().head<2>() + Eigen::Rotation2Dd(view.yaw) * o.center;
  for (const auto& s : world.saplings)
    if ((Eigen::Vector2d(s.x, s.y) - at).norm() < 1.0)
    {
      ++kinds->sapling;
      return;
    }
  for (const auto& f : world.foliage)
    if (lowFoliage(f) && (f.center.head<2>() - at).norm() < f.radius + 0.3)
    {
      ++kinds->foliage;
      return;
    }
  ++kinds->other;
}

void scoreByClass(const std::vector<core::TrunkObservation>& obs, const std::vector<int>& match, const SweepView& view,
                  const std::vector<TrueTrunk>& trunks, const std::vector<int>& hits, const sim::ForestWorld& world,
                  ClassResult* res)
{
  for (std::size_t k = 0; k < trunks.size(); ++k)
  {
    const int band = classOf(view.truthAt(trunks, k, 0.0).first.norm(), kClassBands, kNumClassBands);
    if (band < 0)
      continue;
    int det = -1;
    for (std::size_t i = 0; i < obs.size(); ++i)
      if (match[i] == static_cast<int>(k))
        det = static_cast<int>(i);
    double centre_err = 0.0, dbh_err = 0.0;
    if (det >= 0)
    {
      const core::TrunkObservation& o = obs[static_cast<std::size_t>(det)];
      const auto truth = view.truthAt(trunks, k, o.height);
      centre_err = (truth.first - o.center).norm();
      dbh_err = 2.0 * (o.radius - truth.second);
    }
    const bool visible = hits[k] >= 10;
    const int dbh = classOf(trunks[k].dbh, kDbhClasses, kNumDbhClasses);
    for (ClassStats* s : { &res->band[band], &res->dbh[dbh], &res->all })
      addTree(s, visible, det >= 0, centre_err, dbh_err);
  }
  for (std::size_t i = 0; i < obs.size(); ++i)
  {
    const int band = classOf(obs[i].range, kClassBands, kNumClassBands);
    if (band < 0)
      continue;
    const int dbh = classOf(2.0 * obs[i].radius, kDbhClasses, kNumDbhClasses);
    for (ClassStats* s : { &res->band[band], &res->all })
      addDetection(s, match[i] >= 0);
    if (dbh >= 0)
      addDetection(&res->dbh[dbh], match[i] >= 0);
    if (match[i] < 0)
      classifySpurious(obs[i], view, trunks, world, &res->spurious);
  }
}

void printClassRow(const char* group, const ClassStats& s)
{
  const auto percent = [](int n, int of) {
    char text[16];
    if (of > 0)
      std::snprintf(text, sizeof(text), "%.1f %%", 100.0 * n / of);
    else
      std::snprintf(text, sizeof(text), "-");
    return std::string(text);
  };
  const auto cm = [&s](double sum) {
    char text[16];
    if (s.fits > 0)
      std::snprintf(text, sizeof(text), "%.1f", 100.0 * sum);
    else
      std::snprintf(text, sizeof(text), "-");
    return std::string(text);
  };
  const double n = std::max(1, s.fits);
  std::printf("| %s | %d | %d | %s | %s | %d | %s | %s | %s | %s |\n", group, s.in_scope, s.visible,
              percent(s.found_visible, s.visible).c_str(), percent(s.found, s.in_scope).c_str(), s.detections,
              percent(s.detections_matched, s.detections).c_str(), cm(std::sqrt(s.sum_centre2 / n)).c_str(),
              cm(std::sqrt(s.sum_dbh2 / n)).c_str(), cm(s.sum_dbh / n).c_str());
}

void printByClass(const std::string& name, const sim::ForestWorld& world, const ClassResult& res,
                  const Result& tilt)
{
  std::printf("\n== %s: %d sweeps (%.0f points each), %zu trees, %zu saplings, %zu branches on stems, "
              "%zu foliage spheres\n\n",
              name.c_str(), res.sweeps, res.sweeps ? static_cast<double>(res.points) / res.sweeps : 0.0,
              world.trunks.size(), world.saplings.size(), world.stubs.size(), world.foliage.size());
  std::printf("| group | trees in scope | visible | recall (visible) | recall (in scope) | detections | precision | "
              "centre RMS [cm] | DBH RMS [cm] | DBH bias [cm] |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  for (int b = 0; b < kNumClassBands; ++b)
  {
    char label[32];
    std::snprintf(label, sizeof(label), "%.0f-%.0f m", kClassBands[b], kClassBands[b + 1]);
    printClassRow(label, res.band[b]);
  }
  const char* const dbh_labels[kNumDbhClasses] = { "DBH < 10 cm", "DBH 10-20 cm", "DBH 20-30 cm", "DBH >= 30 cm" };
  for (int c = 0; c < kNumDbhClasses; ++c)
    printClassRow(dbh_labels[c], res.dbh[c]);
  printClassRow("all, 1-10 m", res.all);
  const SpuriousKinds& k = res.spurious;
  const int spurious = k.stem + k.sapling + k.foliage + k.other;
  std::printf("\nspurious detections within 1-10 m: %d (%.2f per sweep): %d on a true stem's branches (< 1 m from "
              "it), %d on saplings, %d on shrubs and other low foliage, %d elsewhere\n",
              spurious, res.sweeps ? static_cast<double>(spurious) / res.sweeps : 0.0, k.stem, k.sapling, k.foliage,
              k.other);
  const auto print = [](const char* what, const std::vector<double>& errors) {
    if (errors.empty())
      return;
    double ss = 0.0;
    for (double e : errors)
      ss += e * e;
    std::vector<double> sorted = errors;
    std::sort(sorted.begin(), sorted.end());
    std::printf("%s against the true attitude, per sweep: median %.2f deg, RMS %.2f deg, 95 %% %.2f deg\n", what,
                median(sorted), std::sqrt(ss / sorted.size()), sorted[(sorted.size() * 95) / 100]);
  };
  std::string feet;
  for (int b = 0; b < kNumClassBands; ++b)
  {
    std::vector<double> e = res.ground_error[b];
    if (e.empty())
      continue;
    std::sort(e.begin(), e.end());
    char text[96];
    std::snprintf(text, sizeof(text), "%s%.0f-%.0f m %+.2f (%+.2f / %+.2f)", feet.empty() ? "" : ", ", kClassBands[b],
                  kClassBands[b + 1], median(e), e[e.size() / 10], e[(e.size() * 9) / 10]);
    feet += text;
  }
  if (!feet.empty())
    std::printf("ground at the true trees' feet, estimate less truth [m], median (10 %% / 90 %%): %s\n", feet.c_str());
  print("sensor tilt estimated", tilt.tilt_error_deg);
  if (tilt.ground_tilt_error_deg.empty())
    return;
  const std::string ground = "tilt of the seen ground's plane (used in " +
                             std::to_string(100 * tilt.ground_tilt_used / static_cast<int>(tilt.ground_tilt_error_deg.size())) +
                             " % of sweeps)";
  print(ground.c_str(), tilt.ground_tilt_error_deg);
}

/**
 * The ground the detector estimates (its GroundModel with its settings, on the sweep unlevelled) at the foot of every
 * true tree 1-10 m away, less the true height there, into @p res by range band.
 */
void groundAtFeet(const SweepView& view, const std::vector<TrueTrunk>& trunks, const sim::SimulatorConfig& sim_config,
                  ClassResult* res)
{
  const core::TrunkDetectorConfig cfg = detectorConfig(core::TrunkMethod::kCircle, sim_config);
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(view.pts.size());
  for (const auto& p : view.pts)
    if (p.allFinite())
      pts.push_back(p.cast<double>());
  core::GroundModel ground(cfg.ground_cell, cfg.sensor_height, cfg.ground_max_slope, cfg.ground_relief, cfg.max_range);
  ground.build(pts);
  const Eigen::Isometry3d to_sensor = view.sensor.inverse();
  for (const auto& t : trunks)
  {
    const Eigen::Vector3d foot = to_sensor * t.base;
    const int band = classOf(foot.head<2>().norm(), kClassBands, kNumClassBands);
    const double g = band >= 0 ? ground.heightAt(foot.x(), foot.y()) : NAN;
    if (std::isfinite(g))
      res->ground_error[band].push_back(g - foot.z());
  }
}

void runByClass(const std::string& name, const sim::ForestWorld& world, double step)
{
  sim::SimulatorConfig sim_config;
  const std::vector<TrueTrunk> trunks = trueTrunks(world);
  ClassResult res;
  Result timing;  // detect() records its stages here; the table leaves them out
  for (const auto& pose : robotPoses(world, step))
  {
    const SweepView view = simulateSweep(world, pose, &sim_config);
    res.points += view.pts.size();
    ++res.sweeps;
    const std::vector<int> hits = trunkHits(view, trunks);
    const std::vector<core::TrunkObservation> obs = detect(core::TrunkMethod::kCircle, sim_config, view, &timing);
    if (!g_true_level)
      groundAtFeet(view, trunks, sim_config, &res);
    scoreByClass(obs, matchTrunks(obs, view, trunks), view, trunks, hits, world, &res);
  }
  printByClass(name, world, res, timing);
}
}  // namespace

int main(int argc, char** argv)
{
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);  // PCL reports every failed RANSAC as an error
  std::vector<std::string> worlds;
  double step = 3.0;
  bool by_class = false;
  for (int i = 1; i < argc; ++i)
  {
    const std::string arg = argv[i];
    if (arg == "--world" && i + 1 < argc)
      worlds.push_back(argv[++i]);
    else if (arg == "--no-level")
      g_level = false;
    else if (arg == "--true-level")
      g_true_level = true;
    else if (arg == "--cluster-fit")
      g_column_fit = false;
    else if (arg == "--no-ground-plane")
      g_ground_plane = false;
    else if (arg == "--by-class")
      by_class = true;
    else if (arg == "--step" && i + 1 < argc)
      step = std::atof(argv[++i]);
    else
    {
      std::fprintf(stderr,
                   "usage: %s [--world FILE]... [--step M] [--no-level] [--true-level] [--by-class] [--cluster-fit]\n"
                   "          [--no-ground-plane]\n",
                   argv[0]);
      return 2;
    }
  }
  if (worlds.empty())
  {
    worlds.push_back(tools::packageFile("config/worlds/paper_forest.yaml"));
    worlds.push_back(tools::packageFile("config/worlds/dense_forest.yaml"));
  }
  try
  {
    if (by_class)
    {
      std::printf("Trunk extraction (circle%s, %s) on simulated VLP-16 sweeps from poses on a %.1f m grid, per sweep:\n"
                  "trees by their range from the sensor and true DBH, detections by theirs; recall over the trees\n"
                  "with >= 10 returns on the stem 0.5-2 m above its foot (visible) and over all in the band;\n"
                  "errors against the true axis and diameter at the detection's height, over the matched trees.\n",
                  g_column_fit ? ", column fit" : ", cluster fit",
                  g_true_level ? "true levelling" : (g_level ? "tilt from the trunks" : "no levelling"), step);
      for (const auto& path : worlds)
        runByClass(path.substr(path.find_last_of('/') + 1), sim::loadForestWorld(path), step);
      return 0;
    }
    std::printf("Trunk extraction on simulated VLP-16 sweeps (range sigma 2 cm, undulating ground, clutter),\n"
                "sensor poses on a %.1f m grid; errors against the true axis at the detection's height.\n"
                "Precision within a band counts detections there; 'spurious' = matched to no true trunk.\n",
                step);
    for (const auto& path : worlds)
      run(path.substr(path.find_last_of('/') + 1), sim::loadForestWorld(path), step);
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "trunk_benchmark: %s\n", e.what());
    return 1;
  }
  return 0;
}
