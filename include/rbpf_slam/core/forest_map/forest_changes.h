#ifndef RBPF_SLAM_CORE_FOREST_MAP_FOREST_CHANGES_H
#define RBPF_SLAM_CORE_FOREST_MAP_FOREST_CHANGES_H

#include <limits>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/fastslam/landmark_map.h"
#include "rbpf_slam/core/filter/pose2.h"
#include "rbpf_slam/core/fastslam/visibility_scope.h"

namespace rbpf_slam
{
namespace core
{
/** @brief When a difference between a saved map and the map of a later visit is reported as a change. */
struct ChangeConfig
{
  int min_observations = 10;    ///< a new tree, or a tree's new radius, needs this many matches of this visit
  double growth_sigmas = 3.0;   ///< a radius change beyond this many combined standard deviations ...
  double growth_floor = 0.005;  ///< [m] ... plus this (the fit's bias between visits) is reported
  /// [m] a felled tree and a new one closer than this with radii that agree are one tree that the filter removed
  /// and made again (its saved position was off): neither is reported
  double remade_distance = 1.0;
  /// With the saved map's viewpoints: a tree of this visit where the saved map has none is new only where the
  /// saved map had it in view (inside the scope, not hidden behind a saved trunk) from at least this many
  /// viewpoints; elsewhere it is a tree the map had not reached, added to the map and not reported
  int min_views = 3;
  double view_range_margin = 0.5;  ///< [m] in view: this far inside the scope's ring
};

/** @brief Where a map was looked at from: the sensor's pose in the map frame and the scope it saw. */
struct Viewpoint
{
  Pose2 sensor;
  VisibilityScope scope;
};

/** @brief [m] Viewpoints are kept this far apart at least (per eighth of a turn for a partial view). */
constexpr double kViewpointCell = 1.0;

/**
 * @brief How many of @p viewpoints had the point @p p (a trunk of radius @p radius) in view: inside the scope's
 * ring by @p range_margin and its bearings, not hidden behind a confirmed tree of @p trees (occludedBy). Stops
 * counting at @p enough.
 */
int timesInView(const std::vector<Viewpoint>& viewpoints, const std::vector<Landmark>& trees, const Eigen::Vector2d& p,
                double radius, double range_margin, int enough = std::numeric_limits<int>::max());

/**
 * @brief The viewpoints of a map as it is driven: a new one only kViewpointCell from every other (of the same eighth
 * of a turn when the scope is not all round), so that driving the same ground again does not grow them.
 */
class ViewpointLog
{
public:
  /** @brief Starts from a saved map's viewpoints (or none). */
  void reset(const std::vector<Viewpoint>& saved = std::vector<Viewpoint>());
  /** @brief Adds the sensor at @p sensor (map frame) with @p scope unless its cell has one; true when added. */
  bool add(const Pose2& sensor, const VisibilityScope& scope);
  const std::vector<Viewpoint>& viewpoints() const { return viewpoints_; }

private:
  std::vector<Viewpoint> viewpoints_;
  std::map<std::tuple<long, long, int>, std::vector<std::size_t>> cells_;  ///< viewpoints by cell and heading
};

enum class ChangeKind
{
  kFelled,   ///< a confirmed tree of the saved map that this visit removed by the expected-miss rule
  kNew,      ///< a confirmed tree of this visit where the saved map had none
  kChanged,  ///< a tree of both whose radius of this visit differs from the saved one beyond its uncertainty
};
const char* toString(ChangeKind kind);

/** @brief One reported change, with its evidence. */
struct TreeChange
{
  ChangeKind kind = ChangeKind::kNew;
  int id = 0;
  Eigen::Vector2d center = Eigen::Vector2d::Zero();             ///< [m] map frame
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();         ///< [m^2]
  double dbh_before = NAN, sigma_dbh_before = NAN;              ///< [m] saved (NaN for a new tree)
  double dbh_after = NAN, sigma_dbh_after = NAN;                ///< [m] this visit's (NaN for a felled tree)
  int observations = 0;      ///< matches of this visit
  double first_seen = NAN;   ///< [s]
  double last_seen = NAN;    ///< [s] the last sighting (of the saved map for a felled tree)
  std::string evidence;      ///< in words
};

/**
 * @brief The changes between the trees of a saved map (@p before, as it was loaded) and the best particle's map at
 * the end of a later visit started from it (@p after; ids of saved trees are kept, new trees have new ids): felled
 * (confirmed saved trees that are gone: the filter removes a tree only after it was expected inside the sensor's
 * scope, not hidden behind a nearer trunk, and not seen, sweep after sweep), new (confirmed trees of this visit
 * with min_observations matches and an id the saved map does not have), and changed radii (trees of both whose
 * radius from this visit's observations alone differs from the saved one beyond growth_sigmas combined standard
 * deviations plus growth_floor). Saved trees this visit never came near stay as they were and are not reported. A
 * felled and a new tree within remade_distance whose radii agree are one tree removed and made again: not reported.
 * With @p viewpoints (where the saved map was looked at from), a tree is new only where the saved map had it in
 * view (min_views); without them (a survey, an older file) every place counts as looked at.
 */
std::vector<TreeChange> detectChanges(const std::vector<Landmark>& before, const std::vector<Landmark>& after,
                                      const ChangeConfig& config = ChangeConfig(),
                                      const std::vector<Viewpoint>& viewpoints = std::vector<Viewpoint>());

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FOREST_MAP_FOREST_CHANGES_H
