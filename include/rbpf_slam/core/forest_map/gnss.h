#ifndef RBPF_SLAM_CORE_FOREST_MAP_GNSS_H
#define RBPF_SLAM_CORE_FOREST_MAP_GNSS_H

#include <string>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/forest_map/geodesy.h"
#include "rbpf_slam/core/filter/pose2.h"
#include "rbpf_slam/core/filter/random.h"

namespace rbpf_slam
{
namespace core
{
/** @brief One satellite fix as a receiver reports it (sensor_msgs/NavSatFix without ROS). */
struct GnssFix
{
  double stamp = 0.0;    ///< [s]
  bool valid = false;    ///< false: no fix (an outage)
  double latitude = 0.0, longitude = 0.0, altitude = 0.0;  ///< [deg], [deg], [m] of the antenna
  /// [m^2] the receiver's covariance of east and north (NavSatFix's ENU covariance, its horizontal part)
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();
};

/**
 * @brief What is wrong with @p fix as an input, or "" when it can be used: no fix, coordinates out of range or not
 * finite, a covariance that is not finite, not symmetric positive definite or larger than @p max_sigma [m].
 */
std::string gnssFixProblem(const GnssFix& fix, double max_sigma);

/**
 * @brief A satellite receiver on the robot under canopy (the simulator's): white noise and a slowly wandering
 * multipath bias (first-order Gauss-Markov), both growing from their open-sky values to their canopy values with
 * the canopy over the antenna, and outages that come and last longer under canopy. The canopy over the antenna is the
 * share of the circle of canopy_radius covered by the crowns of the trunks in it (crown_ratio times the trunk's radius
 * each), at most 1. The receiver reports the covariance of its white noise and bias together, as receivers inflate
 * theirs under canopy.
 */
struct GnssConfig
{
  bool enabled = false;
  double rate = 1.0;               ///< [Hz] fixes per second
  GeoPoint origin{ 47.0, 8.0, 500.0 };  ///< WGS84 position of the world frame's origin (on the ground)
  double world_yaw = 0.0;          ///< [rad] of the world frame's x axis from east, counter-clockwise
  double open_sigma = 0.8;         ///< [m] white noise per axis under open sky
  double canopy_sigma = 1.5;       ///< [m] ... under full canopy
  double open_bias_sigma = 0.5;    ///< [m] multipath bias per axis (stationary) under open sky
  double canopy_bias_sigma = 2.5;  ///< [m] ... under full canopy
  double bias_time = 30.0;         ///< [s] correlation time of the bias
  double vertical_factor = 1.5;    ///< vertical errors this many times the horizontal ones
  double canopy_radius = 10.0;     ///< [m] around the antenna
  double crown_ratio = 15.0;       ///< crown radius over trunk radius
  double outage_interval = 120.0;  ///< [s] mean time between outages under full canopy (0: none)
  double outage_duration = 10.0;   ///< [s] mean length of an outage
  Eigen::Vector3d antenna = Eigen::Vector3d(0.0, 0.0, 1.5);  ///< [m] on base_link

  bool validate(std::string* error) const;
};

/** @brief The fix of the simulator's receiver and the truth of the same instant. */
struct GnssSample
{
  GnssFix fix;     ///< as the receiver reports it (valid = false in an outage)
  GnssFix truth;   ///< the antenna's true position (covariance 0)
  double canopy = 0.0;  ///< the canopy cover over the antenna, 0..1
};

/**
 * @brief The simulator's receiver (GnssConfig): call sample() at its rate with the antenna's true position in the
 * world frame and the canopy over it. Its own random stream: enabling it changes nothing else of a run.
 */
class GnssReceiver
{
public:
  GnssReceiver(const GnssConfig& config, std::uint64_t seed);
  GnssSample sample(double stamp, const Eigen::Vector3d& antenna_world, double canopy);
  const GnssConfig& config() const { return config_; }

private:
  GnssConfig config_;
  Random random_;
  LocalTangentPlane plane_;
  Eigen::Vector3d bias_unit_ = Eigen::Vector3d::Zero();  ///< the bias in units of its stationary sigma
  double last_stamp_ = -1.0;
  double outage_until_ = -1.0;
};

/** @brief How a SLAM filter uses satellite fixes. */
struct GnssFusionConfig
{
  bool enabled = true;
  double max_sigma = 50.0;        ///< [m] fixes whose reported sigma exceeds this are dropped
  double sigma_floor = 1.0;       ///< [m] no fix is taken as surer than this (per axis)
  /// [s] fixes closer than this are taken as one: a receiver's errors under canopy wander slowly (multipath), so
  /// fixes a second apart are not independent; the filter is weighed by at most one fix per interval.
  double correlation_time = 30.0;
  /// The anchor of a new map: fitted to the fixes (antenna in the map, from the filter's estimate) once they span
  /// this much [m] (the standard deviation of their map positions along their longest axis: the heading's lever) ...
  double anchor_min_spread = 5.0;
  int anchor_min_fixes = 20;      ///< ... and this many fixes
  /// The particles are weighed by the fixes once the anchor's origin is known to this [m] (a saved map's anchor
  /// with sigma 0 counts as known); 0: fixes never weigh the particles (the anchor is still fitted).
  double weigh_max_anchor_sigma = 3.0;

  /** @brief "" when every value is in range, else what is not. */
  std::string validate() const;
};

/// The innovation gate of satellite fixes: a fix whose squared Mahalanobis distance from where the filter and the
/// anchor put the antenna exceeds this (chi-square, 2 degrees of freedom, 99.9 %) is inconsistent and not used.
constexpr double kGnssGate2 = 13.8;
/// The same as a number of standard deviations (its square root).
constexpr double kGnssGate = 3.7;

/**
 * @brief The squared Mahalanobis distance of @p fix (in the frame of @p anchor, gnssInFrame) from the antenna's
 * position @p predicted there with @p predicted_covariance (the filter's); infinite when it cannot be computed.
 */

/**
 * @brief The anchor of a map frame from satellite fixes: each fix pairs the antenna's position in the map (from the
 * filter's estimate at the fix's instant) with its east-north position in a tangent plane near the fixes; a
 * weighted least-squares rigid fit (rotation and translation, no scale) of the one onto the other gives the map
 * origin's WGS84 position and its x axis's heading. Its sigma: the fit's residual over the square root of the
 * number of correlation times the fixes cover (their errors wander together within one), for the origin and for the
 * heading's lever from the fixes' centre to the origin. Wild fixes (a receiver's jump) are left out: a first fit
 * that fewer than half of them cannot move (the heading most pairs of fixes agree on, the median origin) gates
 * every fix (kGnssGate of its own sigma, and three robust standard deviations of the residuals) before the
 * least-squares fit; @p outliers says how many were left out. The tangent plane follows the fixes: once the median
 * fix lies more than 1 km from the plane's origin (the first fix was wild), the plane moves to it, so wild first
 * fixes do not distort the good ones' geometry.
 */
class GeoAnchorEstimator
{
public:
  explicit GeoAnchorEstimator(const GnssFusionConfig& config = GnssFusionConfig());
  /** @brief Adds a usable fix (see gnssFixProblem) with the antenna's map position @p antenna_map. */
  void add(const GnssFix& fix, const Eigen::Vector2d& antenna_map);
  /** @brief The fitted anchor; not valid until the fixes span anchor_min_spread and number anchor_min_fixes. */
  GeoAnchor anchor(int* outliers = nullptr) const;
  int fixes() const { return static_cast<int>(map_.size()); }
  void clear();

private:
  /** @brief A first fit that fewer than half wild fixes cannot move (see anchor()). */
  bool robustStart(double* yaw, Eigen::Vector2d* origin) const;
  /** @brief Moves the tangent plane to the median fix when that lies more than 1 km from its origin. */
  void followFixes() const;
  GnssFusionConfig config_;
  // The plane the fit works in and the fixes' east-north in it: a working frame that follows the fixes (followFixes),
  // not part of the estimator's state (the anchor is the same in any plane near the fixes).
  mutable LocalTangentPlane plane_;
  mutable std::vector<Eigen::Vector2d> east_north_;
  std::vector<Eigen::Vector2d> map_;
  std::vector<double> weight_, stamp_, altitude_, latitude_, longitude_;
};

/**
 * @brief Two independent estimates of one frame's anchor (e.g. a saved map's and this visit's fit) combined by
 * their sigmas (inverse-variance weights for the origin, the heading and the altitude). An anchor with sigma 0 is
 * taken as exact and returned as it is; a non-valid one is ignored.
 */
GeoAnchor combineAnchors(const GeoAnchor& a, const GeoAnchor& b);

/**
 * @brief The fix's antenna position in the frame anchored at @p anchor [m] and its covariance there (the fix's,
 * floored at @p sigma_floor, plus the anchor's sigma), for weighing particles.
 */
void gnssInFrame(const GnssFix& fix, const GeoAnchor& anchor, double sigma_floor, Eigen::Vector2d* position,
                 Eigen::Matrix2d* covariance);

double gnssInnovation(const GnssFix& fix, const GeoAnchor& anchor, double sigma_floor,
                      const Eigen::Vector2d& predicted, const Eigen::Matrix2d& predicted_covariance);

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FOREST_MAP_GNSS_H
