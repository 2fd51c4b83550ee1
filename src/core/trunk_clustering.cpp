// Clusters that may be trunks: Euclidean clusters of a sweep's height band, arcs of a planar scan.
#include "rbpf_slam/core/trunk_clustering.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>

#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>

#include "rbpf_slam/core/ground_model.h"

namespace rbpf_slam
{
namespace core
{
namespace
{
// [-] cells of the projection are this fraction of the tolerance: small enough that a cell's representative stands
// for its points, large enough to shorten the neighbour searches.
constexpr double kCellsPerTolerance = 3.0;

pcl::PointCloud<pcl::PointXYZ>::Ptr toCloud(const std::vector<Eigen::Vector3f>& points)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->points.reserve(points.size());
  for (const auto& q : points)
    cloud->points.emplace_back(q.x(), q.y(), q.z());
  cloud->width = static_cast<std::uint32_t>(cloud->points.size());
  cloud->height = 1;
  cloud->is_dense = true;
  return cloud;
}
}  // namespace

void downsampleVoxels(std::vector<Eigen::Vector3f>* points, double leaf)
{
  if (points->empty())
    return;
  const pcl::PointCloud<pcl::PointXYZ>::Ptr cloud = toCloud(*points);
  pcl::PointCloud<pcl::PointXYZ> down;
  pcl::VoxelGrid<pcl::PointXYZ> voxel;
  voxel.setInputCloud(cloud);
  const float v = static_cast<float>(leaf);
  voxel.setLeafSize(v, v, v);
  voxel.filter(down);
  points->clear();
  for (const auto& q : down.points)
    points->emplace_back(q.x, q.y, q.z);
}

std::vector<std::vector<int>> clusterHorizontal(const std::vector<Eigen::Vector3f>& points, double tolerance)
{
  const double leaf = tolerance / kCellsPerTolerance;
  const auto cellKey = [leaf](float x, float y) {
    return packCell(static_cast<std::int64_t>(std::floor(x / leaf)), static_cast<std::int64_t>(std::floor(y / leaf)));
  };
  std::unordered_map<std::int64_t, int> cell_of;
  cell_of.reserve(points.size());
  pcl::PointCloud<pcl::PointXYZ>::Ptr flat(new pcl::PointCloud<pcl::PointXYZ>);
  std::vector<int> point_cell(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    const auto& q = points[i];
    const auto inserted = cell_of.emplace(cellKey(q.x(), q.y()), static_cast<int>(flat->points.size()));
    if (inserted.second)
      flat->points.emplace_back(q.x(), q.y(), 0.0f);
    point_cell[i] = inserted.first->second;
  }
  flat->width = static_cast<std::uint32_t>(flat->points.size());
  flat->height = 1;
  flat->is_dense = true;
  std::vector<pcl::PointIndices> cell_clusters;
  pcl::search::KdTree<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>);
  tree->setInputCloud(flat);
  pcl::EuclideanClusterExtraction<pcl::PointXYZ> ec;
  ec.setClusterTolerance(tolerance);
  ec.setMinClusterSize(1);
  ec.setMaxClusterSize(std::numeric_limits<int>::max());
  ec.setSearchMethod(tree);
  ec.setInputCloud(flat);
  ec.extract(cell_clusters);
  std::vector<int> cluster_of_cell(flat->points.size(), -1);
  for (std::size_t c = 0; c < cell_clusters.size(); ++c)
    for (int i : cell_clusters[c].indices)
      cluster_of_cell[static_cast<std::size_t>(i)] = static_cast<int>(c);
  std::vector<std::vector<int>> clusters(cell_clusters.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    clusters[static_cast<std::size_t>(cluster_of_cell[static_cast<std::size_t>(point_cell[i])])].push_back(
        static_cast<int>(i));
  return clusters;
}

std::vector<TrunkCandidate> selectTrunkCandidates(const std::vector<Eigen::Vector3f>& points,
                                                  const std::vector<std::vector<int>>& clusters,
                                                  const TrunkDetectorConfig& config, TrunkDetectorStats* stats)
{
  std::vector<TrunkCandidate> candidates;
  for (const auto& idx : clusters)
  {
    const int n = static_cast<int>(idx.size());
    if (n < config.min_points || n > config.max_points)
    {
      ++stats->rejected_size;
      continue;
    }
    TrunkCandidate c;
    c.points.reserve(idx.size());
    c.z_lo = std::numeric_limits<double>::infinity();
    c.z_hi = -std::numeric_limits<double>::infinity();
    for (int i : idx)
    {
      const auto& q = points[static_cast<std::size_t>(i)];
      c.points.emplace_back(q.x(), q.y(), q.z());
      c.z_lo = std::min<double>(c.z_lo, q.z());
      c.z_hi = std::max<double>(c.z_hi, q.z());
    }
    if (c.z_hi - c.z_lo < config.min_vertical_extent)
    {
      ++stats->rejected_shape;
      continue;
    }
    candidates.push_back(std::move(c));
  }
  return candidates;
}

bool isUninformativeRange(double range, double range_min)
{
  return std::isnan(range) || range <= 0.0 || range < range_min;
}

std::vector<ScanArc> splitScanIntoArcs(const PlanarScan& scan, double tolerance, double range_offset, int* valid_beams)
{
  std::vector<ScanArc> arcs;
  ScanArc current;
  int valid = 0;
  Eigen::Vector2d prev(0.0, 0.0);
  const auto close = [&]() {
    if (!current.points.empty())
      arcs.push_back(current);
    current.points.clear();
  };
  for (std::size_t i = 0; i < scan.ranges.size(); ++i)
  {
    const double raw = scan.ranges[i];
    if (isUninformativeRange(raw, scan.range_min))
      continue;
    if (!(std::isfinite(raw) && raw <= scan.range_max))
    {
      close();  // no return: nothing is there
      continue;
    }
    const double r = raw + range_offset;
    ++valid;
    const double a = scan.angle_min + scan.angle_increment * static_cast<double>(i);
    const Eigen::Vector2d p(r * std::cos(a), r * std::sin(a));
    // Beams that told nothing in between widen the gap the surface leaves between two of its points.
    if (!current.points.empty() &&
        (p - prev).norm() > tolerance * static_cast<double>(static_cast<int>(i) - current.last_beam))
      close();
    if (current.points.empty())
      current.first_beam = static_cast<int>(i);
    current.last_beam = static_cast<int>(i);
    current.points.push_back(p);
    prev = p;
  }
  close();
  if (valid_beams)
    *valid_beams = valid;
  return arcs;
}

bool isArcOccluded(const PlanarScan& scan, const ScanArc& arc, double tolerance)
{
  if (arc.points.empty())
    return false;
  const int count = static_cast<int>(scan.ranges.size());
  // The first informative beam from `beam` on in direction `step` is nearer than r by more than the tolerance.
  const auto nearer = [&](int beam, int step, double r) {
    while (beam >= 0 && beam < count && isUninformativeRange(scan.ranges[static_cast<std::size_t>(beam)], scan.range_min))
      beam += step;
    if (beam < 0 || beam >= count)
      return false;
    const double rb = scan.ranges[static_cast<std::size_t>(beam)];
    return std::isfinite(rb) && rb < r - tolerance;
  };
  return nearer(arc.first_beam - 1, -1, arc.points.front().norm()) ||
         nearer(arc.last_beam + 1, 1, arc.points.back().norm());
}

}  // namespace core
}  // namespace rbpf_slam
