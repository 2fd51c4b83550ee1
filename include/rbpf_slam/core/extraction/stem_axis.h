#ifndef RBPF_SLAM_CORE_EXTRACTION_STEM_AXIS_H
#define RBPF_SLAM_CORE_EXTRACTION_STEM_AXIS_H

#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/extraction/trunk_detector.h"
#include "rbpf_slam/core/filter/random.h"

namespace rbpf_slam
{
namespace core
{
/**
 * @brief A stem fitted to the points of one cluster of a sweep as a leaning cylinder: its axis passes through
 * @p center at @p height and moves by @p lean per metre of height.
 */
struct StemAxisFit
{
  bool ok = false;
  Eigen::Vector2d center = Eigen::Vector2d::Zero();          ///< [m] axis at height
  double height = 0.0;                                       ///< [m] z of center (levelled frame, sensor at 0)
  Eigen::Vector2d lean = Eigen::Vector2d::Zero();            ///< [m/m] horizontal shift of the axis per metre up
  double radius = 0.0;                                       ///< [m]
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();  ///< of (cx, cy, r) at height [m^2]
  int inliers = 0;         ///< points within config.ransac_threshold of the cylinder
  int slices = 0;          ///< slices (config.slice_height) holding at least two inliers
  double z_lo = 0.0;       ///< [m] lowest and highest inlier
  double z_hi = 0.0;       ///< [m]
  double arc_angle = 0.0;  ///< [rad] angle the inliers subtend at the axis
  double coverage = 0.0;   ///< [-] mean share of its silhouette its slices show (one sweep)
  double rms = 0.0;        ///< [m] RMS distance of the inliers to the bark
  int interior = 0;        ///< points inside the cylinder by more than the threshold (bark is opaque)
  std::vector<int> members;  ///< indices of the inliers into the points given
};

/**
 * @brief What a sweep saw nearest in each direction: the least horizontal range per cell of elevation and azimuth
 * (levelled frame, sensor at the origin), to tell a stem hidden in part behind something nearer from a circle that
 * meets a few scattered points.
 */
class NearestReturns
{
public:
  /** @param elevation_cell, azimuth_cell [rad] sides of the cells */
  NearestReturns(double elevation_cell = 0.01, double azimuth_cell = 0.004);
  void build(const std::vector<Eigen::Vector3d>& points);
  /** @brief The least horizontal range [m] in the cell of (@p elevation, @p azimuth); +infinity where none. */
  double nearest(double elevation, double azimuth) const;
  double azimuthCell() const { return azimuth_cell_; }

private:
  std::int64_t key(double elevation, double azimuth) const;
  double elevation_cell_, azimuth_cell_;
  std::unordered_map<std::int64_t, float> nearest_;
};

/** @brief Why a cluster gave no further stem (fitStemAxes()). */
enum class StemAxisRejection
{
  kNone,       ///< a stem was accepted
  kSize,       ///< too few points left
  kRadius,     ///< no circle of a trunk's radius
  kShape,      ///< too short (slices or height span), leaning, or a centre in front of the points
  kInliers,    ///< too few points on the cylinder
  kClutter,    ///< points inside the cylinder: foliage or a bush, no bark
};

/**
 * @brief Stems in one cluster by their vertical continuity: a stem is a near-vertical column of consistent
 * cross-sections. The points fall into slices along the sensor's rings (a new slice where the elevation angle jumps
 * between rings, or after config.slice_height in a dense cloud). A circle hypothesis (RANSAC on three nearby points of
 * the horizontal projection) is scored by its inliers, each weighted by the share of the circle's silhouette (the
 * bearings it covers from the sensor, the origin) that its slice's inliers span, less the points inside the bark and
 * the beams of the sweep that pass through it (@p occluders). The best one is refined as a leaning cylinder by
 * Gauss-Newton for (cx, cy, lean x, lean y, r), with the noise config.range_sigma, a weak radius prior
 * (arc_radius_prior, arc_radius_sigma) and a lean prior of standard deviation config.max_stem_lean / 2; the inliers
 * are chosen again around each refit, within three robust standard deviations of the residuals (between half and all
 * of config.ransac_threshold).
 *
 * It is kept when its radius is at least config.min_radius and at most max_radius (within two of its standard
 * deviations), at least config.min_slices slices and config.min_vertical_extent of height hold its inliers, there are
 * at least config.min_points of them, its axis leans at most config.max_stem_lean, and its bark is opaque: at most
 * config.max_interior_share of its inliers' number of points lie inside it or (one sweep) behind it within its
 * silhouette. From one sensor (not config.seen_from_all_sides) also: at most config.max_see_through of its
 * silhouette's cells hold a return from behind it; its slices show on average config.min_silhouette_coverage of its
 * width where nothing nearer returned; its inliers go round no more than the half facing the sensor, widened by
 * the noise at the silhouette; and its axis lies behind them. A stem overlapping one already found is no new stem.
 * Two touching trunks fitted as one wide cylinder are split by fitTrunkPair() on the points near it. The inliers of
 * a stem, and the points within twice the threshold of its bark, are then taken out (of a rejected hypothesis its
 * inliers) and the rest tried again, up to config.max_stems_per_cluster stems and twice as many hypotheses.
 *
 * @param points a cluster's points in the levelled frame (sensor at the origin, z up)
 * @param rng RANSAC's generator, advanced
 * @param last why the search ended (kNone when max_stems_per_cluster stems were found)
 * @param occluders the sweep's nearest returns (same frame): the part of a stem's silhouette where something nearer
 *        returned counts as shown (a stem partly hidden behind another), a return from behind it as a beam through
 *        it; none: only the inliers show it, and no beam is known to pass
 */
std::vector<StemAxisFit> fitStemAxes(const std::vector<Eigen::Vector3d>& points, const TrunkDetectorConfig& config,
                                     Random* rng, StemAxisRejection* last = nullptr,
                                     const NearestReturns* occluders = nullptr);

/** @brief The observation of an accepted stem fit (method kCircle). */
TrunkObservation toTrunkObservation(const StemAxisFit& fit, int num_points);

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_EXTRACTION_STEM_AXIS_H
