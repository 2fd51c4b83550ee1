#ifndef RBPF_SLAM_CORE_EXTRACTION_TRUNK_FIT_H
#define RBPF_SLAM_CORE_EXTRACTION_TRUNK_FIT_H

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/extraction/trunk_clustering.h"
#include "rbpf_slam/core/extraction/trunk_detector.h"

namespace rbpf_slam
{
namespace core
{
/** @brief A trunk fitted to one cluster's horizontal projection (sensor at the origin). */
struct TrunkFit
{
  bool ok = false;  ///< false when the least squares failed
  Eigen::Vector2d center = Eigen::Vector2d::Zero();          ///< [m]
  double radius = 0.0;                                       ///< [m]
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();  ///< of (cx, cy, r) [m^2]
  int inliers = 0;         ///< points within the RANSAC threshold of the circle (all points for a centroid)
  double arc_angle = 0.0;  ///< [rad] angle the inliers subtend at the centre
  TrunkMethod method = TrunkMethod::kCircle;
};

/**
 * @brief Centroid (the method of the paper this package reproduces): the centre of the visible points, the
 * radius half their extent across the line of sight. Its covariance adds the method's own error (about half a
 * radius, towards the sensor) to the spread of the mean.
 */
TrunkFit fitTrunkCentroid(const std::vector<Eigen::Vector2d>& points, const TrunkDetectorConfig& config);

/**
 * @brief A circle: the algebraic fit when it already explains nearly every point, else RANSAC; the arc fallback
 * (a centre one prior radius behind the arc's middle) when neither gives a circle behind the points or there are
 * too few points. Then least squares on the inliers, the inliers chosen again around the refined circle and
 * refined once more. The method is kArc for few points or a narrow arc (the prior then carries the radius).
 */
TrunkFit fitTrunkCircle(const std::vector<Eigen::Vector2d>& points, const TrunkDetectorConfig& config);

/**
 * @brief A 2D arc of too few beams to fit a circle (method kArc): the radius is the prior (config.arc_radius_prior,
 * arc_radius_sigma) truncated to at least half the chord, the centre one radius behind the arc's middle. The
 * covariance holds the radius prior's uncertainty along the ray, the beams' width (@p beam_spacing [rad], at least
 * one spacing over sqrt(12) across the ray) and the range noise; the derivation is at the definition.
 */
TrunkFit fitShortArc(const std::vector<Eigen::Vector2d>& points, double beam_spacing, const TrunkDetectorConfig& config);

/**
 * @brief A silhouette edge of a 2D arc: on a side not hidden behind a nearer object, the trunk's outline ends
 * between the arc's last beam there and the next beam (which passes beside it).
 */
struct SilhouetteEdge
{
  Eigen::Vector2d direction = Eigen::Vector2d::UnitX();  ///< unit ray halfway between the two beams
  double spacing = 0.0;                                  ///< [rad] angle between the two beams
};

/**
 * @brief A trunk from a 2D arc partly hidden behind a nearer object: its visible points are a piece of the circle
 * that does not reach the silhouette on the hidden side, so the centre is not one radius behind the arc's middle.
 *
 * Least squares for (cx, cy, r) by Gauss-Newton from a centre one prior radius behind the arc's middle, with
 *  - each point's distance to the circle, standard deviation config.range_sigma,
 *  - the radius prior (config.arc_radius_prior, arc_radius_sigma),
 *  - each silhouette edge in @p edges: the ray is tangent to the circle (distance from the centre = r), uncertain by
 *    the beams' spacing there (uniform: range * spacing / sqrt(12)) and as much again for the beam's own width.
 * The covariance is the inverse of the information (Jacobian and prior). The fit is kept (ok) only when
 *  - the residuals are consistent with the noise: their normalised sum of squares is within the 99.9 % quantile of
 *    chi-square with (n + 1 + edges - 3) degrees of freedom,
 *  - the points show the trunk's front (the centre's bearing lies within theirs, widened by a mean beam spacing of
 *    the arc and two standard deviations of the centre's bearing): the front pins the depth, the silhouette edge
 *    the side; a few beams beside an occluder or a wall's end show none,
 *  - the radius is within three of the prior's standard deviations of the prior (the piece hardly measures it),
 *  - every point lies on the half of the circle that faces the sensor (within 3 range_sigma): the centre lies
 *    behind the points.
 * The method is kArc for fewer than config.min_fit_points points or an arc narrower than config.min_fit_arc, else
 * kCircle.
 */
TrunkFit fitPartialArc(const std::vector<Eigen::Vector2d>& points, const std::vector<SilhouetteEdge>& edges,
                       const TrunkDetectorConfig& config);

/**
 * @brief Whether a short 2D arc can be a trunk's visible side: no wider (chord) than 2 config.max_radius, and, with
 * three points or more, bulging towards the sensor at least as a circle of config.max_radius through its ends does,
 * within the range noise (a straight wall or a car's side does not; a box's corner bulges away).
 */
bool isTrunkShapedArc(const std::vector<Eigen::Vector2d>& points, const TrunkDetectorConfig& config);

/** @brief fitTrunkCentroid() or fitTrunkCircle(), as config.method says. */
TrunkFit fitTrunk(const std::vector<Eigen::Vector2d>& points, const TrunkDetectorConfig& config);

/** @brief Why a fitted cluster is not a trunk. */
enum class TrunkRejection : std::uint8_t
{
  kNone = 0,     ///< accepted
  kShape = 1,    ///< the fit failed, or the centre is outside the range limits
  kRadius = 2,   ///< radius outside the limits
  kInliers = 3,  ///< too few points on the circle
};

/** @brief Accepts or rejects a fit of @p num_points points against the configured limits. */
TrunkRejection checkTrunkFit(const TrunkFit& fit, int num_points, const TrunkDetectorConfig& config);

/** @brief Bumps the stats counter of a rejection (none for kNone). */
void countRejection(TrunkRejection rejection, TrunkDetectorStats* stats);

/** @brief Two touching trunks fitted to one cluster (fitTrunkPair()). */
struct TrunkPairFit
{
  bool ok = false;
  TrunkFit fits[2];
  std::vector<int> members[2];  ///< indices into the cluster's points, ascending: the points of each trunk
};

/**
 * @brief Whether a cluster's single fit may stand for two touching trunks: it was rejected, or at least
 * config.min_fit_points points and 5 % of them lie beyond config.ransac_threshold of its circle, or its residuals (each capped at that
 * threshold) exceed 1.5 config.range_sigma (RMS).
 */
bool isPoorSingleFit(const std::vector<Eigen::Vector2d>& points, const TrunkFit& fit, TrunkRejection rejection,
                     const TrunkDetectorConfig& config);

/**
 * @brief Two trunks whose bark nearly touches merge into one cluster; this splits it where the points allow.
 *
 * Seen from the sensor (the origin), each bearing meets one trunk: the nearer one hides what lies behind it, so the
 * visible points of two trunks fall into bearing intervals, one for each, or the far trunk's on both sides of the
 * near one's. Every such partition at a bearing (one cut, or two cuts with the outer pieces together) is scored by
 * the algebraic circles of its two parts (from running sums; their residuals scaled to distances, a part too short to
 * show its curvature by its straight line's). The better of the best one-cut and two-cut partitions (the other only
 * when it fails; neither when its sum of squares does not beat the single circle's) is fitted by fitTrunkCircle()
 * part by part, every point is given to the circle it lies nearer to, and the parts are fitted again until they
 * stay. Two trunks are kept (ok) only when
 *  - each part has at least max(config.min_fit_points, config.min_points) points and its fit passes checkTrunkFit()
 *    on them as a circle (kCircle: a wide enough arc);
 *  - the circles are two trunks side by side: their centres lie at least r1 + r2 - 0.75 ransac_threshold apart (the
 *    two sides of one trunk fit the same circle twice; a trunk and a sliver of its own points fit overlapping ones);
 *  - each circle's silhouette (its bearing interval) ends within the points' bearings, widened by 2 ransac_threshold
 *    at its range and about a beam: a noisy thin trunk fits two wide circles whose outlines the points do not show;
 *  - two circles explain the points clearly better than @p single: with every residual capped at ransac_threshold,
 *    the sum of squares falls to at most half and the Bayesian information criterion with the noise unknown,
 *    n ln(RSS1 / RSS2) - 4 ln n (three more parameters and the cut), is positive.
 * Only for config.method kCircle.
 */
TrunkPairFit fitTrunkPair(const std::vector<Eigen::Vector2d>& points, const TrunkFit& single,
                          const TrunkDetectorConfig& config);

/**
 * @brief Verticality: the centroids of the candidate's lower and upper halves, after levelling, sit above each other
 * within what config.max_tilt allows (a lying branch or a slanted bush does not).
 * @param levelled the candidate's points projected horizontally after levelling, in the order of candidate.points
 */
bool isUpright(const TrunkCandidate& candidate, const std::vector<Eigen::Vector2d>& levelled,
               const TrunkDetectorConfig& config);

/** @brief The observation of an accepted fit; @p height [m] of its centre above the sensor. */
TrunkObservation toTrunkObservation(const TrunkFit& fit, int num_points, double height);

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_EXTRACTION_TRUNK_FIT_H
