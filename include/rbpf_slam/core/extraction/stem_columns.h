#ifndef RBPF_SLAM_CORE_EXTRACTION_STEM_COLUMNS_H
#define RBPF_SLAM_CORE_EXTRACTION_STEM_COLUMNS_H

#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/filter/random.h"

namespace rbpf_slam
{
namespace core
{
/**
 * @brief Settings of findStems(): stems in a whole point cloud (terrestrial or mobile scans) by their vertical
 * continuity. Lengths in metres, heights above the local ground.
 */
struct StemColumnsConfig
{
  // Ground: per cell the mean of the lowest ground_min_points heights that lie within ground_band (stray points
  // below the ground do not count); a cell whose value stands more than max_ground_slope per metre above its
  // neighbours' shows no ground (a stem, a shrub), and takes theirs.
  double ground_cell = 0.25;      ///< [m] side of the ground grid's cells
  double ground_band = 0.1;       ///< [m]
  int ground_min_points = 3;      ///< points within ground_band that make a cell's ground
  double max_ground_slope = 0.5;  ///< [-] rise per metre
  double ground_search = 3.0;     ///< [m] a cell without ground takes the ground of cells this near, else the prior
  /// [m] prior ground height where no cell within ground_search shows ground; NaN: the median of the cells' ground
  double ground_height = std::numeric_limits<double>::quiet_NaN();

  // Horizontal slices: centres slice_min, slice_min + slice_step, ... up to slice_max, each slice_thickness thick.
  double slice_min = 0.5;        ///< [m]
  double slice_max = 3.0;        ///< [m]
  double slice_step = 0.1;       ///< [m]
  double slice_thickness = 0.1;  ///< [m] at most slice_step

  // Clusters of a slice: points in connected grid cells of this side.
  double cluster_tolerance = 0.08;  ///< [m] bridges the gaps a twig in front leaves in a ring
  int min_cluster_points = 8;

  // Circle per cluster: RANSAC on 3 points, geometric least squares on its inliers.
  double min_dbh = 0.06;       ///< [m]
  double max_dbh = 1.2;        ///< [m]
  double inlier_band = 0.015;  ///< [m] a point within this of the circle is an inlier
  int ransac_iterations = 300;
  int min_inliers = 8;
  double min_coverage = 0.3;         ///< [-] share of the circle's 24 sectors that hold an inlier (all-sides clouds)
  double min_coverage_sensor = 0.2;  ///< [-] the same for a single-viewpoint scan (has_sensor)
  /// [-] points inside the band, as a share of the inliers (bark is opaque); times the disc's area over the band's
  /// where that is below 1 (thin stems)
  double max_interior_share = 0.15;
  int max_circles_per_cluster = 8;  ///< a cluster may join several stems through clutter

  // Columns: circles of consecutive slices whose centres and radii agree.
  double max_lean_deg = 8.0;            ///< [deg] the centre moves at most tan(lean) per metre of height
  double centre_tolerance = 0.03;       ///< [m] plus the lean's share
  double radius_tolerance = 0.02;       ///< [m] radii of linked circles differ by at most this ...
  double radius_tolerance_share = 0.1;  ///< [-] ... plus this share of the radius ...
  double max_taper = 0.05;              ///< [m/m] ... plus this per metre of height (taper)
  double max_gap = 0.5;                 ///< [m] height a column may skip (a whorl or a shrub hiding the stem)
  int min_slices = 8;                   ///< circles that make a stem
  double breast_height = 1.3;           ///< [m] where the DBH is taken
  /// [m] the radius line takes the slices this near breast height (all when fewer than three are): the butt swell
  /// and the crown's taper stay out of it
  double dbh_window = 0.5;

  /// Single-viewpoint scan: where the sensor stood. The rings then face it and need less coverage.
  bool has_sensor = false;
  Eigen::Vector3d sensor = Eigen::Vector3d::Zero();

  std::uint64_t seed = 1;  ///< RANSAC's generator: the same cloud gives the same stems

  /** @return empty when the settings are usable, else what is wrong (naming the key). */
  std::string validate() const;
};

/** @brief A stem found by findStems(). Positions in the cloud's frame. */
struct Stem
{
  Eigen::Vector2d center = Eigen::Vector2d::Zero();  ///< [m] axis at breast height
  double dbh = 0.0;        ///< [m] diameter at breast height, from the line fit of the radii along the column
  double dbh_sigma = 0.0;  ///< [m] its standard error, from the fit's residuals
  double ground = 0.0;     ///< [m] ground height under the stem
  int points = 0;          ///< points on the column's circles
  double z_min = 0.0;      ///< [m] lowest and highest of those points
  double z_max = 0.0;      ///< [m]
  int slices = 0;          ///< circles in the column that the fit kept
  double lean_deg = 0.0;   ///< [deg] the axis' angle from the vertical
};

/** @brief One slice's circle: a candidate stem section. */
struct StemCircle
{
  int slice = 0;        ///< index of the slice
  double height = 0.0;  ///< [m] the slice's centre above the ground
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double radius = 0.0;
  int inliers = 0;
  double coverage = 0.0;            ///< [-] share of the 24 sectors holding an inlier
  double z_min = 0.0, z_max = 0.0;  ///< [m] of the inliers
};

/** @brief What findStems() did, for a report. */
struct StemColumnsStats
{
  std::size_t input_points = 0;
  std::size_t finite_points = 0;
  std::size_t slice_points = 0;
  int clusters = 0;
  int circles = 0;
  int columns = 0;
  int stems = 0;
};

/**
 * @brief Ground heights on a grid over a cloud (see StemColumnsConfig), interpolated bilinearly between cell
 * centres.
 */
class GroundGrid
{
public:
  /** @brief Builds the grid from the finite points; an empty cloud gives a flat ground at the prior (or 0). */
  void build(const std::vector<Eigen::Vector3f>& points, const StemColumnsConfig& config);

  /** @brief Ground height [m] at (x, y); outside the grid, the nearest cell's. */
  double heightAt(double x, double y) const;

  double cell() const { return cell_; }

private:
  void fillFromNeighbours(const std::vector<float>& lowest, const StemColumnsConfig& config);
  double cellHeight(long ix, long iy) const;

  double x0_ = 0.0, y0_ = 0.0, cell_ = 1.0;
  long nx_ = 0, ny_ = 0;
  std::vector<float> ground_;
  double flat_ = 0.0;
};

/**
 * @brief The ground of a cell: the mean of the lowest @p min_points of its @p n heights @p z that lie within
 * @p band (stray points below the ground are passed over); the lowest height when no such group is among the
 * lowest 64. @p z is reordered.
 * NaN for an empty cell.
 */
float lowestDenseHeight(float* z, std::size_t n, int min_points, double band);

/** @brief The points of every slice (index = slice), as selected by the ground and the slice settings. */
std::vector<std::vector<Eigen::Vector3f>> slicePoints(const std::vector<Eigen::Vector3f>& points,
                                                      const GroundGrid& ground, const StemColumnsConfig& config);

/** @brief Clusters of a slice: indices of points in connected cells of side @p tolerance, at least min_points each. */
std::vector<std::vector<int>> clusterSlice(const std::vector<Eigen::Vector3f>& slice, double tolerance, int min_points);

/**
 * @brief Stem circles in one cluster: RANSAC on 3 points (sampled near each other) scored by inliers less the
 * points inside the ring, a geometric refit on the inliers, and acceptance by radius, inliers, coverage and an
 * empty interior; repeated on the remaining points for clusters that hold more than one stem.
 * @param slice, height the slice's index and its centre above the ground, copied into the circles
 * @param rng RANSAC's generator, advanced
 */
std::vector<StemCircle> fitStemCircles(const std::vector<Eigen::Vector3f>& cluster, int slice, double height,
                                       const StemColumnsConfig& config, Random* rng);

/** @brief Links the circles (any order) into columns, each ordered by slice. */
std::vector<std::vector<StemCircle>> linkColumns(std::vector<StemCircle> circles, const StemColumnsConfig& config);

/**
 * @brief A stem from a column: lines of centre and radius over height, fitted after dropping slices that stand
 * out; false when the column is too short or not consistent (residuals, lean, taper, DBH range).
 */
bool stemFromColumn(const std::vector<StemCircle>& column, const StemColumnsConfig& config, Stem* stem);

/**
 * @brief The stems of a cloud: ground, slices, clusters, circles, columns, stems (sorted by x, then y).
 * Non-finite points are skipped.
 * @param progress called with the share done, in [0, 1], now and then (may be empty)
 * @throws std::invalid_argument when config.validate() is not empty.
 */
std::vector<Stem> findStems(const std::vector<Eigen::Vector3f>& points, const StemColumnsConfig& config,
                            StemColumnsStats* stats = nullptr,
                            const std::function<void(double)>& progress = std::function<void(double)>());

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_EXTRACTION_STEM_COLUMNS_H
