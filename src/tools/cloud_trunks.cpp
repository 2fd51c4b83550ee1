// The stem finder (core/extraction/stem_columns.h) on a PCD file: the computing half of `extract_trunks`, which
// reads the other formats, shows the progress and writes the user's CSV and plot.
//
//   cloud_trunks CLOUD.pcd OUT_DIR [--sensor X,Y,Z] [--ground-height H] [--progress]
//
// Reads the PCD (ascii, binary, binary_compressed; fields x y z as float32 or float64) with PCL's reader and writes
// into the existing folder OUT_DIR: stems.csv (x, y, dbh, dbh_sigma, points, z_min, z_max, lean_deg, ground; the
// file's frame, metres), density.f32 (points per cell of the top view, float32, row after row from the lowest y)
// and summary.txt ("key value" lines: point counts, the density grid, the finder's counts). Points whose
// coordinates are not finite are dropped, with a "warning:" line on stderr saying how many. With --progress,
// "progress F" lines (F the share done) on stderr. Exit code 1 and one "error:" line for a file that cannot be
// read, is empty or holds no finite point; 2 for a wrong command line.
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
};

void usage(const char* prog)
{
  std::fprintf(stderr, "usage: %s CLOUD.pcd OUT_DIR [--sensor X,Y,Z] [--ground-height H] [--progress]\n", prog);
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
    }
    else if (arg == "--ground-height" && i + 1 < argc)
    {
      if (!parseNumbers(argv[++i], &v) || v.size() != 1)
        return false;
      opt->config.ground_height = v[0];
    }
    else if (!arg.empty() && arg[0] == '-')
      return false;
    else
      positional.push_back(arg);
  }
  if (positional.size() != 2)
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

Cloud readCloud(const std::string& path)
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
    if (!have_offset)
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
    Cloud cloud = readCloud(opt.cloud);
    if (cloud.dropped > 0)
      std::fprintf(stderr, "warning: %zu of %zu points have coordinates that are not finite, dropped\n", cloud.dropped,
                   cloud.read);
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
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
