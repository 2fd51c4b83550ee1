#ifndef RBPF_SLAM_CORE_EXTRACTION_TRUNK_CLUSTERING_H
#define RBPF_SLAM_CORE_EXTRACTION_TRUNK_CLUSTERING_H

#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/extraction/trunk_detector.h"

namespace rbpf_slam
{
namespace core
{
/** @brief Replaces the points by the centroid of the points in each cubic voxel of side @p leaf [m] (> 0). */
void downsampleVoxels(std::vector<Eigen::Vector3f>* points, double leaf);

/**
 * @brief Euclidean clusters of the points' horizontal projection (z ignored).
 *
 * Trunks stand upright, and the rings of a far trunk are further apart vertically than any sensible tolerance,
 * so the clustering is 2D. The projection is first reduced to one representative (the first point) per square
 * cell of a third of the tolerance; two cells are linked when their representatives are closer than
 * @p tolerance [m], and each point belongs to the cluster of its cell.
 * @return the clusters as indices into @p points, each in ascending order; the largest (in cells) first.
 */
std::vector<std::vector<int>> clusterHorizontal(const std::vector<Eigen::Vector3f>& points, double tolerance);

/** @brief A cluster that may be a trunk: its points (levelled frame) and their height span. */
struct TrunkCandidate
{
  std::vector<Eigen::Vector3d> points;
  double z_lo = 0.0;  ///< [m] lowest point
  double z_hi = 0.0;  ///< [m] highest point

  /** @brief [m] middle of the height span, where the trunk's centre is given. */
  double zMid() const { return 0.5 * (z_lo + z_hi); }
};

/**
 * @brief The clusters that may be trunks: between config.min_points and config.max_points points, spanning at least
 * config.min_vertical_extent in height. Counts the others in stats (rejected_size, rejected_shape).
 */
std::vector<TrunkCandidate> selectTrunkCandidates(const std::vector<Eigen::Vector3f>& points,
                                                  const std::vector<std::vector<int>>& clusters,
                                                  const TrunkDetectorConfig& config, TrunkDetectorStats* stats);

/** @brief One arc of a planar scan: its points (scan frame) and the beams of its first and last point. */
struct ScanArc
{
  std::vector<Eigen::Vector2d> points;
  int first_beam = -1;
  int last_beam = -1;
};

/**
 * @brief REP-117: NaN (an erroneous reading), −Inf (too close to measure), 0 and readings below range_min tell
 * nothing about what is there (whereas +Inf and readings beyond range_max say that nothing is there).
 */
bool isUninformativeRange(double range, double range_min);

/**
 * @brief Splits a scan into arcs: runs of valid beams whose neighbouring points are closer than @p tolerance [m].
 *
 * Two neighbouring points are linked when they are closer than @p tolerance plus the gap the beams leave on a
 * surface facing the sensor (range times the angle increment), so that a far trunk's two or three beams, further
 * apart than the tolerance, still make one arc. A beam that tells nothing neither ends an arc nor bounds one: the
 * distance allowed grows with the beams skipped between two points, so a dropout does not cut a wall into short arcs
 * that look like trunks. A beam without return ends the arc. @p range_offset [m] is added to every valid range.
 * @param[out] valid_beams number of beams with a valid range (optional)
 */
std::vector<ScanArc> splitScanIntoArcs(const PlanarScan& scan, double tolerance, double range_offset,
                                       int* valid_beams = nullptr);

/** @brief A side of an arc: before its first beam or after its last. */
enum class ArcSide
{
  kFirst,
  kLast,
};

/**
 * @brief The first beam beside @p arc on @p side that tells something (dropouts skipped), or -1 when the field of
 * view ends first; @p end_range [m] is set to the range of the arc's point on that side.
 */
int firstInformativeBeamBeside(const PlanarScan& scan, const ScanArc& arc, ArcSide side, double* end_range);

/**
 * @brief True when the arc is hidden behind a nearer object on @p side: the first informative beam there is nearer
 * than the arc's end by more than @p tolerance [m].
 */
bool isArcSideOccluded(const PlanarScan& scan, const ScanArc& arc, ArcSide side, double tolerance);

/**
 * @brief True when the arc is partly hidden behind a nearer object: isArcSideOccluded() on either side. Such an arc
 * is no whole side of a trunk: its silhouette ends behind the nearer object, not where the arc ends.
 */
bool isArcOccluded(const PlanarScan& scan, const ScanArc& arc, double tolerance);

/**
 * @brief The horizontal angle between neighbouring beams of a 3D lidar [rad], from its points (sensor frame):
 * points are grouped by elevation (one group per ring, @p elevation_bin [rad] wide) and the step is the median
 * gap between neighbouring azimuths within a group. NaN when the points are too few to tell.
 */
double estimateAzimuthStep(const std::vector<Eigen::Vector3f>& points, double elevation_bin = 0.004);

/**
 * @brief How far a trunk of radius @p radius [m] still gives @p min_points points on a single ring of a lidar
 * whose beams are @p azimuth_step [rad] apart: 2 radius / (min_points azimuth_step) [m]. NaN for an unknown step.
 */
inline double singleRingReach(double radius, int min_points, double azimuth_step)
{
  if (!(azimuth_step > 0.0) || min_points < 1)
    return NAN;
  return 2.0 * radius / (static_cast<double>(min_points) * azimuth_step);
}

/**
 * @brief True when the arc stands in front of its background: on either side, the first informative beam returns
 * nothing, or a range at least @p min_jump [m] beyond the arc's end (@p range_offset [m] added to it as to the arc).
 * False when the field of view ends beside the arc (the object may go on beyond it).
 */
bool isArcIsolated(const PlanarScan& scan, const ScanArc& arc, double min_jump, double range_offset);

/** @brief isArcIsolated() on one side: the first informative beam there returns nothing or is @p min_jump beyond. */
bool isArcSideIsolated(const PlanarScan& scan, const ScanArc& arc, ArcSide side, double min_jump,
                       double range_offset);

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_EXTRACTION_TRUNK_CLUSTERING_H
