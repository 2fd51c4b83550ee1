// The trunk extractors on a PCD file. By default the stem finder (core/extraction/stem_columns.h): the computing
// half of `extract_trunks`, which reads the other formats, shows the progress and writes the user's CSV and plot.
// With --detector sweep the robot's per-sweep detector (core/extraction/trunk_detector.h) on one lidar sweep, for
// `tree_view_benchmark`.
//
//   cloud_trunks CLOUD.pcd OUT_DIR [--sensor X,Y,Z] [--ground-height H] [--progress]
//   cloud_trunks CLOUD.pcd OUT_DIR --detector sweep [--config FILE] [--sensor-height H]
//
// Reads the PCD (ascii, binary, binary_compressed; fields x y z as float32 or float64) with PCL's reader and writes
// into the existing folder OUT_DIR. The stem finder: stems.csv (x, y, dbh, dbh_sigma, points, z_min, z_max,
// lean_deg, ground; the file's frame, metres), density.f32 (points per cell of the top view, float32, row after row
// from the lowest y) and summary.txt ("key value" lines: point counts, the density grid, the finder's counts).
// The sweep detector takes the points in the sensor's frame (origin at the sensor, z up, no levelling by TF) with the
// detector keys of a trunk extraction YAML (--config, e.g. config/trunk_extraction.yaml; else the built-in values)
// and the sensor's height above the ground under it (--sensor-height, over the file's sensor_height) and writes
// trunks.csv (x, y, radius, radius_sigma, range, bearing, points, inliers, score, method, height; the levelled sensor
// frame, metres and radians) and summary.txt (point counts and the detector's counts, TrunkDetectorStats).
// Points whose coordinates are not finite are dropped, with a "warning:" line on stderr saying how many. With
// --progress, "progress F" lines (F the share done) on stderr. Exit code 1 and one "error:" line for a file that
// cannot be read, is empty or holds no finite point, or a configuration that cannot be used; 2 for a wrong command
// line.
#include <pcl/PCLPointCloud2.h>
#include <pcl/console/print.h>
#include <pcl/io/pcd_io.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "rbpf_slam/core/extraction/stem_columns.h"
#include "rbpf_slam/core/extraction/trunk_detector.h"
#include "rbpf_slam/io/param_source.h"
#include "rbpf_slam/io/trunk_detector_config.h"

using namespace rbpf_slam;

namespace
{
constexpr int kDensityCells = 800;  // the top view's grid has at most this many cells a side

/** @brief A cloud in single precision about an offset, so that large (projected) coordinates keep their mm. */
struct Cloud
{
  std::vector<Eigen::Vector3f> points;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  std::size_t read = 0;     ///< points in the file
  std::size_t dropped = 0;  ///< of them, with a coordinate that is not finite
};

struct Options
{
  std::string cloud, out_dir;
  core::StemColumnsConfig config;
  bool progress = false;
  bool sweep = false;           ///< --detector sweep: the per-sweep detector instead of the stem finder
  std::string detector_config;  ///< --config: a trunk extraction YAML
  double sensor_height = -1.0;  ///< --sensor-height [m]; negative: the configuration's
  bool stem_options = false;    ///< --sensor or --ground-height given (the stem finder's only)
};

void usage(const char* prog)
{
  std::fprintf(stderr,
               "usage: %s CLOUD.pcd OUT_DIR [--sensor X,Y,Z] [--ground-height H] [--progress]\n"
               "       %s CLOUD.pcd OUT_DIR --detector sweep [--config FILE] [--sensor-height H] [--progress]\n",
               prog, prog);
}

bool parseNumbers(const std::string& text, std::vector<double>* values)
{
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ','))
  {
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0' || !std::isfinite(v))
      return false;
    values->push_back(v);
  }
  return true;
}

bool parseOptions(int argc, char** argv, Options* opt)
{
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i)
  {
    const std::string arg = argv[i];
    std::vector<double> v;
    if (arg == "--progress")
      opt->progress = true;
    else if (arg == "--sensor" && i + 1 < argc)
    {
      if (!parseNumbers(argv[++i], &v) || v.size() != 3)
        return false;
      opt->config.has_sensor = true;
      opt->config.sensor = Eigen::Vector3d(v[0], v[1], v[2]);
      opt->stem_options = true;
    }
    else if (arg == "--ground-height" && i + 1 < argc)
    {
      if (!parseNumbers(argv[++i], &v) || v.size() != 1)
        return false;
      opt->config.ground_height = v[0];
      opt->stem_options = true;
    }
    else if (arg == "--detector" && i + 1 < argc)
    {
      const std::string name = argv[++i];
      if (name != "stems" && name != "sweep")
        return false;
      opt->sweep = name == "sweep";
    }
    else if (arg == "--config" && i + 1 < argc)
      opt->detector_config = argv[++i];
    else if (arg == "--sensor-height" && i + 1 < argc)
    {
      if (!parseNumbers(argv[++i], &v) || v.size() != 1 || v[0] < 0.0)
        return false;
      opt->sensor_height = v[0];
    }
    else if (!arg.empty() && arg[0] == '-')
      return false;
    else
      positional.push_back(arg);
  }
  // Each detector's options belong to it alone.
  if (positional.size() != 2 || (opt->sweep && opt->stem_options) ||
      (!opt->sweep && (!opt->detector_config.empty() || opt->sensor_height >= 0.0)))
    return false;
  opt->cloud = positional[0];
  opt->out_dir = positional[1];
  return true;
}

/** @brief The byte offset and type of field @p name (x, y or z); throws unless float32 or float64 with count 1. */
const pcl::PCLPointField& coordinateField(const pcl::PCLPointCloud2& cloud, const std::string& name)
{
  for (const auto& f : cloud.fields)
    if (f.name == name)
    {
      if ((f.datatype != pcl::PCLPointField::FLOAT32 && f.datatype != pcl::PCLPointField::FLOAT64) || f.count != 1)
        throw std::runtime_error("field " + name + " is not a float32 or float64 number");
      return f;
    }
  throw std::runtime_error("the cloud has no field " + name + " (fields x, y and z are needed)");
}

double fieldValue(const std::uint8_t* point, const pcl::PCLPointField& f)
{
  if (f.datatype == pcl::PCLPointField::FLOAT32)
  {
    float v;
    std::memcpy(&v, point + f.offset, sizeof v);
    return v;
  }
  double v;
  std::memcpy(&v, point + f.offset, sizeof v);
  return v;
}

/** @brief The cloud of a PCD file; with @p keep_frame its coordinates as they are (no offset), whatever their size. */
Cloud readCloud(const std::string& path, bool keep_frame)
{
  {
    std::ifstream probe(path);
    if (!probe)
      throw std::runtime_error("cannot open the file");
  }
  pcl::PCLPointCloud2 raw;
  pcl::PCDReader reader;
  if (reader.read(path, raw) < 0)
    throw std::runtime_error("not a readable PCD file (truncated or malformed)");
  const std::size_t n = static_cast<std::size_t>(raw.width) * raw.height;
  if (n == 0)
    throw std::runtime_error("the cloud holds no points");
  if (raw.data.size() < n * raw.point_step)
    throw std::runtime_error("the file holds fewer points than its header says");
  const pcl::PCLPointField& fx = coordinateField(raw, "x");
  const pcl::PCLPointField& fy = coordinateField(raw, "y");
  const pcl::PCLPointField& fz = coordinateField(raw, "z");
  Cloud cloud;
  cloud.read = n;
  cloud.points.reserve(n);
  bool have_offset = false;
  for (std::size_t i = 0; i < n; ++i)
  {
    const std::uint8_t* p = raw.data.data() + i * raw.point_step;
    const Eigen::Vector3d q(fieldValue(p, fx), fieldValue(p, fy), fieldValue(p, fz));
    if (!q.allFinite())
    {
      ++cloud.dropped;
      continue;
    }
    if (!have_offset && !keep_frame)
    {
      // Coordinates of kilometres (a projection's) lose their millimetres in single precision; metres do not.
      cloud.offset = q.cwiseAbs().maxCoeff() > 1000.0 ? Eigen::Vector3d(q.array().round()) : Eigen::Vector3d::Zero();
      have_offset = true;
    }
    cloud.points.push_back((q - cloud.offset).cast<float>());
  }
  if (cloud.points.empty())
    throw std::runtime_error("no point has finite coordinates");
  return cloud;
}

/** @brief Points per cell of a top view over the cloud; the grid's origin, cell and size in *info. */
std::vector<float> densityGrid(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& offset,
                               std::ostream* info)
{
  Eigen::Vector2f lo(points[0].x(), points[0].y()), hi = lo;
  for (const auto& p : points)
  {
    lo = lo.cwiseMin(p.head<2>());
    hi = hi.cwiseMax(p.head<2>());
  }
  const double extent = std::max<double>(hi.x() - lo.x(), hi.y() - lo.y());
  const double cell = std::max(0.02, extent / kDensityCells);
  const long nx = static_cast<long>((hi.x() - lo.x()) / cell) + 1, ny = static_cast<long>((hi.y() - lo.y()) / cell) + 1;
  std::vector<float> grid(static_cast<std::size_t>(nx * ny), 0.0f);
  for (const auto& p : points)
  {
    const long ix = std::min(nx - 1, static_cast<long>((p.x() - lo.x()) / cell));
    const long iy = std::min(ny - 1, static_cast<long>((p.y() - lo.y()) / cell));
    grid[static_cast<std::size_t>(iy * nx + ix)] += 1.0f;
  }
  char line[256];
  std::snprintf(line, sizeof line,
                "density_x0 %.6f\ndensity_y0 %.6f\ndensity_cell %.6f\ndensity_nx %ld\ndensity_ny %ld\n",
                lo.x() + offset.x(), lo.y() + offset.y(), cell, nx, ny);
  *info << line;
  return grid;
}

void writeOutputs(const Options& opt, const Cloud& cloud, const std::vector<core::Stem>& stems,
                  const core::StemColumnsStats& stats)
{
  const Eigen::Vector3d& o = cloud.offset;
  std::ofstream csv(opt.out_dir + "/stems.csv");
  csv << "x,y,dbh,dbh_sigma,points,z_min,z_max,lean_deg,ground\n";
  for (const auto& s : stems)
  {
    char line[320];
    std::snprintf(line, sizeof line, "%.4f,%.4f,%.4f,%.4f,%d,%.3f,%.3f,%.2f,%.3f\n", s.center.x() + o.x(),
                  s.center.y() + o.y(), s.dbh, s.dbh_sigma, s.points, s.z_min + o.z(), s.z_max + o.z(), s.lean_deg,
                  s.ground + o.z());
    csv << line;
  }
  std::ostringstream summary;
  summary << "points_read " << cloud.read << "\npoints_dropped " << cloud.dropped << "\nslice_points "
          << stats.slice_points << "\nclusters " << stats.clusters << "\ncircles " << stats.circles << "\ncolumns "
          << stats.columns << "\nstems " << stats.stems << "\n";
  const std::vector<float> density = densityGrid(cloud.points, o, &summary);
  std::ofstream grid(opt.out_dir + "/density.f32", std::ios::binary);
  grid.write(reinterpret_cast<const char*>(density.data()),
             static_cast<std::streamsize>(density.size() * sizeof(float)));
  std::ofstream(opt.out_dir + "/summary.txt") << summary.str();
  if (!csv || !grid)
    throw std::runtime_error("cannot write into " + opt.out_dir);
}

/** @brief The stem finder on a cloud: stems.csv, density.f32 and summary.txt. */
void runStems(Options& opt, const Cloud& cloud)
{
  // The sensor and the prior ground are in the file's frame; the points about the offset.
  opt.config.sensor -= cloud.offset;
  opt.config.ground_height -= cloud.offset.z();
  const std::string problem = opt.config.validate();
  if (!problem.empty())
    throw std::runtime_error(problem);
  const auto progress = [&](double share)
  {
    if (opt.progress)
      std::fprintf(stderr, "progress %.2f\n", 0.1 + 0.9 * share);
  };
  progress(0.0);
  core::StemColumnsStats stats;
  const auto stems = core::findStems(cloud.points, opt.config, &stats, progress);
  writeOutputs(opt, cloud, stems, stats);
}

/** @brief The detector's configuration: the YAML's detector keys over the built-in values, then --sensor-height. */
core::TrunkDetectorConfig sweepConfig(const Options& opt)
{
  core::TrunkDetectorConfig config;
  if (!opt.detector_config.empty())
  {
    if (!std::ifstream(opt.detector_config))
      throw std::runtime_error(opt.detector_config + ": cannot open the configuration");
    try
    {
      io::readTrunkDetectorConfig(io::YamlParamSource(opt.detector_config), &config);
    }
    catch (const std::exception& e)
    {
      const std::string what = e.what();  // the YAML parser's messages name the file already
      throw std::runtime_error(what.rfind(opt.detector_config, 0) == 0 ? what : opt.detector_config + ": " + what);
    }
  }
  if (opt.sensor_height >= 0.0)
    config.sensor_height = opt.sensor_height;
  const std::string problem = config.validate();
  if (!problem.empty())
    throw std::runtime_error(problem);
  return config;
}

/** @brief The per-sweep detector on a cloud in the sensor's frame: trunks.csv and summary.txt. */
void runSweep(const Options& opt, const Cloud& cloud)
{
  core::TrunkDetector detector(sweepConfig(opt));
  if (opt.progress)
    std::fprintf(stderr, "progress 0.10\n");
  core::TrunkDetectorStats stats;
  const auto trunks = detector.detect(cloud.points, Eigen::Matrix3d::Identity(), &stats);
  std::ofstream csv(opt.out_dir + "/trunks.csv");
  csv << "x,y,radius,radius_sigma,range,bearing,points,inliers,score,method,height\n";
  for (const auto& t : trunks)
  {
    char line[320];
    std::snprintf(line, sizeof line, "%.4f,%.4f,%.4f,%.4f,%.4f,%.5f,%d,%d,%.3f,%s,%.3f\n", t.center.x(), t.center.y(),
                  t.radius, std::sqrt(std::max(0.0, t.radius_variance)), t.range, t.bearing, t.num_points,
                  t.num_inliers, t.score, core::trunkMethodName(t.method), t.height);
    csv << line;
  }
  std::ofstream summary(opt.out_dir + "/summary.txt");
  summary << "points_read " << cloud.read << "\npoints_dropped " << cloud.dropped << "\ninput_points "
          << stats.input_points << "\nfinite_points " << stats.finite_points << "\nband_points " << stats.band_points
          << "\nclusters " << stats.clusters << "\nrejected_size " << stats.rejected_size << "\nrejected_radius "
          << stats.rejected_radius << "\nrejected_inliers " << stats.rejected_inliers << "\nrejected_shape "
          << stats.rejected_shape << "\nsplit_clusters " << stats.split_clusters << "\ntrunks " << stats.trunks
          << "\ntilt_roll " << stats.tilt_roll << "\ntilt_pitch " << stats.tilt_pitch << "\nreach " << stats.reach
          << "\n";
  if (!csv || !summary)
    throw std::runtime_error("cannot write into " + opt.out_dir);
}

}  // namespace

int main(int argc, char** argv)
{
  Options opt;
  if (!parseOptions(argc, argv, &opt))
  {
    usage(argv[0]);
    return 2;
  }
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);  // the reader's complaints become one error line here
  try
  {
    if (opt.progress)
      std::fprintf(stderr, "progress 0.00\n");
    const Cloud cloud = readCloud(opt.cloud, opt.sweep);
    if (cloud.dropped > 0)
      std::fprintf(stderr, "warning: %zu of %zu points have coordinates that are not finite, dropped\n", cloud.dropped,
                   cloud.read);
    if (opt.sweep)
      runSweep(opt, cloud);
    else
      runStems(opt, cloud);
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
