// Clusters that may be trunks: Euclidean clusters of a sweep's height band (on a grid), arcs of a planar scan.
#include "rbpf_slam/core/extraction/trunk_clustering.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>

#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "rbpf_slam/core/extraction/ground_model.h"

namespace rbpf_slam
{
namespace core
{
namespace
{
// [-] cells of the projection are this fraction of the tolerance: small enough that a cell's representative stands
// for its points, large enough to shorten the neighbour searches.
constexpr double kCellsPerTolerance = 3.0;
// [-] blocks of the neighbour search are this much wider than the tolerance, so that two points closer than the
// tolerance (in single precision) always lie in the same or adjacent blocks.
constexpr double kBlockPerTolerance = 1.001;

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

namespace
{
/** The cells of the horizontal projection: a representative of each, each point's cell. */
struct CellProjection
{
  std::vector<Eigen::Vector2f> reps;  // each cell's representative
  std::vector<int> point_cell;        // each point's cell
};

/** The cells, tolerance / kCellsPerTolerance wide (clusterHorizontal's step 1). */
CellProjection projectToCells(const std::vector<Eigen::Vector3f>& points, double tolerance)
{
  CellProjection cells;
  const double leaf = tolerance / kCellsPerTolerance;
  std::unordered_map<std::int64_t, int> cell_of;
  cell_of.reserve(points.size());
  cells.point_cell.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    const auto& q = points[i];
    const std::int64_t key = packCell(static_cast<std::int64_t>(std::floor(q.x() / leaf)),
                                      static_cast<std::int64_t>(std::floor(q.y() / leaf)));
    const auto inserted = cell_of.emplace(key, static_cast<int>(cells.reps.size()));
    if (inserted.second)
      cells.reps.emplace_back(q.x(), q.y());
    cells.point_cell[i] = inserted.first->second;
  }
  return cells;
}

/**
 * The representatives closer than the tolerance, linked into a union-find forest (each set's root its smallest
 * representative) by a sweep over square blocks (clusterHorizontal's step 2).
 */
class RepresentativeLinks
{
public:
  RepresentativeLinks(const std::vector<Eigen::Vector2f>& reps, double tolerance) : reps_(reps)
  {
    const float tol = static_cast<float>(tolerance);
    tol2_ = static_cast<float>(static_cast<double>(tol) * static_cast<double>(tol));
    const double block = kBlockPerTolerance * tolerance;
    entries_.resize(reps.size());
    for (std::size_t r = 0; r < reps.size(); ++r)
      entries_[r] = { static_cast<std::int64_t>(std::floor(reps[r].y() / block)),
                      static_cast<std::int64_t>(std::floor(reps[r].x() / block)), static_cast<int>(r) };
    std::sort(entries_.begin(), entries_.end(), [](const Entry& a, const Entry& b) {
      return a.by != b.by ? a.by < b.by : a.bx != b.bx ? a.bx < b.bx : a.rep < b.rep;
    });
    for (std::size_t i = 0; i < entries_.size(); ++i)
    {
      if (blocks_.empty() || blocks_.back().by != entries_[i].by || blocks_.back().bx != entries_[i].bx)
        blocks_.push_back({ entries_[i].by, entries_[i].bx, i, i });
      blocks_.back().end = i + 1;
    }
    parent_.resize(reps.size());
    for (std::size_t r = 0; r < parent_.size(); ++r)
      parent_[r] = static_cast<int>(r);
  }

  /** Links every pair of representatives closer than the tolerance. */
  void linkAll()
  {
    std::size_t below = 0;  // first block of the next row that may neighbour the current block
    for (std::size_t k = 0; k < blocks_.size(); ++k)
    {
      const Block& b = blocks_[k];
      linkBlocks(b, b, true);
      if (k + 1 < blocks_.size() && blocks_[k + 1].by == b.by && blocks_[k + 1].bx == b.bx + 1)
        linkBlocks(b, blocks_[k + 1], false);
      // Blocks (by + 1, bx - 1 .. bx + 1): the row's blocks are sorted, and so are the current ones.
      below = std::max(below, k + 1);
      while (below < blocks_.size() &&
             (blocks_[below].by < b.by + 1 || (blocks_[below].by == b.by + 1 && blocks_[below].bx < b.bx - 1)))
        ++below;
      for (std::size_t m = below; m < blocks_.size() && blocks_[m].by == b.by + 1 && blocks_[m].bx <= b.bx + 1; ++m)
        linkBlocks(b, blocks_[m], false);
    }
  }

  /** The root of representative @p r's set (compressing the path to it). */
  int root(int r)
  {
    while (parent_[static_cast<std::size_t>(r)] != r)
    {
      parent_[static_cast<std::size_t>(r)] = parent_[static_cast<std::size_t>(parent_[static_cast<std::size_t>(r)])];
      r = parent_[static_cast<std::size_t>(r)];
    }
    return r;
  }

private:
  struct Entry
  {
    std::int64_t by, bx;
    int rep;
  };
  struct Block
  {
    std::int64_t by, bx;
    std::size_t begin, end;
  };

  void linkBlocks(const Block& a, const Block& b, bool same)
  {
    for (std::size_t i = a.begin; i < a.end; ++i)
    {
      const Eigen::Vector2f& p = reps_[static_cast<std::size_t>(entries_[i].rep)];
      for (std::size_t j = same ? i + 1 : b.begin; j < b.end; ++j)
      {
        const Eigen::Vector2f& q = reps_[static_cast<std::size_t>(entries_[j].rep)];
        const float dx = p.x() - q.x(), dy = p.y() - q.y();
        if (dx * dx + dy * dy < tol2_)
        {
          const int ra = root(entries_[i].rep), rb = root(entries_[j].rep);
          if (ra != rb)
            parent_[static_cast<std::size_t>(std::max(ra, rb))] = std::min(ra, rb);
        }
      }
    }
  }

  const std::vector<Eigen::Vector2f>& reps_;
  float tol2_ = 0.0f;
  std::vector<Entry> entries_;  // the representatives' blocks, sorted by row and column
  std::vector<Block> blocks_;   // the blocks' ranges of entries_
  std::vector<int> parent_;
};

/** The points' indices by cluster, the largest first (clusterHorizontal's step 3). */
std::vector<std::vector<int>> clustersBySize(const CellProjection& projection, RepresentativeLinks* links)
{
  struct Component
  {
    std::size_t cells;
    int id;
  };
  const std::size_t num_cells = projection.reps.size();
  const std::vector<int>& point_cell = projection.point_cell;
  std::vector<int> component_of_root(num_cells, -1);
  std::vector<int> component_of_cell(num_cells);
  std::vector<Component> components;
  for (std::size_t r = 0; r < num_cells; ++r)
  {
    int& c = component_of_root[static_cast<std::size_t>(links->root(static_cast<int>(r)))];
    if (c < 0)
    {
      c = static_cast<int>(components.size());
      components.push_back({ 0, c });
    }
    ++components[static_cast<std::size_t>(c)].cells;
    component_of_cell[r] = c;
  }
  std::sort(components.rbegin(), components.rend(),
            [](const Component& a, const Component& b) { return a.cells < b.cells; });
  std::vector<int> rank(components.size());
  for (std::size_t k = 0; k < components.size(); ++k)
    rank[static_cast<std::size_t>(components[k].id)] = static_cast<int>(k);
  std::vector<std::vector<int>> clusters(components.size());
  for (std::size_t k = 0; k < components.size(); ++k)
    clusters[k].reserve(components[k].cells * 4);
  for (std::size_t i = 0; i < point_cell.size(); ++i)
    clusters[static_cast<std::size_t>(rank[static_cast<std::size_t>(
                 component_of_cell[static_cast<std::size_t>(point_cell[i])])])]
        .push_back(static_cast<int>(i));
  return clusters;
}
}  // namespace

std::vector<std::vector<int>> clusterHorizontal(const std::vector<Eigen::Vector3f>& points, double tolerance)
{
  // 1. One representative per cell of the projection (its first point); cells numbered as they first appear.
  const CellProjection cells = projectToCells(points, tolerance);

  // 2. Link representatives closer than the tolerance. They are sorted into square blocks a little wider than the
  //    tolerance, so that linked ones lie in the same or adjacent blocks; each pair of blocks is visited once, in a
  //    sweep over the sorted blocks (no tree, no hashing). Distances in single precision, compared as squares with
  //    a strict <, as a kd-tree radius search over these points does.
  RepresentativeLinks links(cells.reps, tolerance);
  links.linkAll();

  // 3. Clusters numbered by their first cell, then the largest (in cells) first. Ties keep the order that the
  //    same sort of the same sequence gave when a kd-tree (PCL's Euclidean cluster extraction, which sorts its
  //    clusters exactly so) found these clusters, so that detections and their order repeat.
  return clustersBySize(cells, &links);
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
    // The beams leave a gap of range times their angle on a surface facing the sensor; beams that told nothing in
    // between widen it.
    if (!current.points.empty() &&
        (p - prev).norm() > (tolerance + std::min(r, prev.norm()) * std::abs(scan.angle_increment)) *
                                static_cast<double>(static_cast<int>(i) - current.last_beam))
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

int firstInformativeBeamBeside(const PlanarScan& scan, const ScanArc& arc, ArcSide side, double* end_range)
{
  const int count = static_cast<int>(scan.ranges.size());
  const int step = side == ArcSide::kFirst ? -1 : 1;
  int beam = side == ArcSide::kFirst ? arc.first_beam - 1 : arc.last_beam + 1;
  *end_range = side == ArcSide::kFirst ? arc.points.front().norm() : arc.points.back().norm();
  while (beam >= 0 && beam < count && isUninformativeRange(scan.ranges[static_cast<std::size_t>(beam)], scan.range_min))
    beam += step;
  return beam >= 0 && beam < count ? beam : -1;
}

bool isArcSideOccluded(const PlanarScan& scan, const ScanArc& arc, ArcSide side, double tolerance)
{
  if (arc.points.empty())
    return false;
  // The first informative beam beside the arc is nearer than the arc's end by more than the tolerance.
  double r = 0.0;
  const int beam = firstInformativeBeamBeside(scan, arc, side, &r);
  if (beam < 0)
    return false;
  const double rb = scan.ranges[static_cast<std::size_t>(beam)];
  return std::isfinite(rb) && rb < r - tolerance;
}

bool isArcOccluded(const PlanarScan& scan, const ScanArc& arc, double tolerance)
{
  return isArcSideOccluded(scan, arc, ArcSide::kFirst, tolerance) ||
         isArcSideOccluded(scan, arc, ArcSide::kLast, tolerance);
}

double estimateAzimuthStep(const std::vector<Eigen::Vector3f>& points, double elevation_bin)
{
  constexpr std::size_t kMinGaps = 50;  // fewer neighbouring pairs than this tell no resolution
  std::unordered_map<std::int64_t, std::vector<double>> rings;
  for (const auto& p : points)
  {
    const double h = std::hypot(static_cast<double>(p.x()), static_cast<double>(p.y()));
    if (!(h > 0.1) || !p.allFinite())
      continue;
    const auto ring = static_cast<std::int64_t>(std::floor(std::atan2(static_cast<double>(p.z()), h) / elevation_bin));
    rings[ring].push_back(std::atan2(static_cast<double>(p.y()), static_cast<double>(p.x())));
  }
  std::vector<double> gaps;
  for (auto& r : rings)
  {
    std::vector<double>& a = r.second;
    std::sort(a.begin(), a.end());
    for (std::size_t i = 1; i < a.size(); ++i)
      if (a[i] - a[i - 1] > 1e-7)
        gaps.push_back(a[i] - a[i - 1]);
  }
  if (gaps.size() < kMinGaps)
    return NAN;
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2), gaps.end());
  return gaps[gaps.size() / 2];
}

bool isArcSideIsolated(const PlanarScan& scan, const ScanArc& arc, ArcSide side, double min_jump,
                       double range_offset)
{
  if (arc.points.empty())
    return false;
  // The first informative beam beside the arc has no return or one further than the arc's end + min_jump.
  double r = 0.0;
  const int beam = firstInformativeBeamBeside(scan, arc, side, &r);
  if (beam < 0)
    return false;  // the field of view ends: the object may go on beyond it
  const double rb = scan.ranges[static_cast<std::size_t>(beam)];
  if (!(std::isfinite(rb) && rb <= scan.range_max))
    return true;
  return rb + range_offset >= r + min_jump;
}

bool isArcIsolated(const PlanarScan& scan, const ScanArc& arc, double min_jump, double range_offset)
{
  return isArcSideIsolated(scan, arc, ArcSide::kFirst, min_jump, range_offset) &&
         isArcSideIsolated(scan, arc, ArcSide::kLast, min_jump, range_offset);
}

}  // namespace core
}  // namespace rbpf_slam
