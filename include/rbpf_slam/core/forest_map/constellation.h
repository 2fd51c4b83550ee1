#ifndef RBPF_SLAM_CORE_FOREST_MAP_CONSTELLATION_H
#define RBPF_SLAM_CORE_FOREST_MAP_CONSTELLATION_H

#include <string>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/fastslam/landmark_map.h"
#include "rbpf_slam/core/filter/pose2.h"

namespace rbpf_slam
{
namespace core
{
/** @brief A trunk by its centre and radius (with the radius's standard deviation), in some frame. */
struct TrunkPoint
{
  Eigen::Vector2d center = Eigen::Vector2d::Zero();  ///< [m]
  double radius = 0.0;                               ///< [m]
  double radius_sigma = 0.0;                         ///< [m]
};

/** @brief A tree of a map as the constellation search takes it (centre, radius, the radius's standard deviation). */
TrunkPoint trunkPoint(const Landmark& tree);

/** @brief Parameters of the constellation search (global relocalization from trunk positions and radii). */
struct ConstellationConfig
{
  double pair_tolerance = 0.25;    ///< [m] a pair of seen trunks and a pair of map trees agree in length within this
  double min_pair_length = 2.0;    ///< [m] shorter pairs fix the heading too poorly to be tried
  double max_pair_length = 25.0;   ///< [m] longer pairs are not tried (the sensor's reach, twice)
  double inlier_gate = 0.35;       ///< [m] a seen trunk within this of a map tree (after the transform) is an inlier
  double radius_sigmas = 3.0;      ///< radii agree within this many combined standard deviations ...
  double radius_floor = 0.03;      ///< [m] ... plus this (bark, fit and growth between visits)
  int min_inliers = 5;             ///< a hypothesis needs this many trunks explained
  double min_inlier_share = 0.5;   ///< ... and this share of the seen trunks
  /// Accepted only when no other distinct hypothesis explains nearly as much: the runner-up must have at most
  /// this share of the best's inliers.
  double ambiguity_share = 0.75;
  double distinct_distance = 1.0;  ///< [m] hypotheses closer than this (and distinct_angle) are one
  double distinct_angle = 0.2;     ///< [rad]
  int max_hypotheses = 5;          ///< distinct hypotheses returned, best first
  /// Transforms are drawn from the pairs of the first this many seen trunks (the caller puts the nearest first) and
  /// scored on them; the best are then scored and refitted on all: the search's cost stays bounded in dense stands.
  int max_pair_trunks = 16;
  /// The search's work bound: at most this many transforms are scored per search (under a second on one core of a
  /// small robot computer, for a 20000-tree plantation in rows, the worst case; the searches in the stands measured
  /// score a tenth of it or less), so that no saved map, however large or regular, can stall the filter for long.
  /// Deterministic, unlike a bound in seconds.
  long max_candidates = 200000;
  /// The map's pairs (of trees min_pair_length..max_pair_length apart) are indexed once, 16 bytes each: a map with
  /// more (e.g. 20000 trees at 2.5 per m^2, denser than any stand, 0.5 per m^2 being 5000 stems a hectare) is
  /// refused before any is stored, rather than taking minutes and gigabytes. 20 million: 320 MB.
  long max_pairs = 20000000;
};

/** @brief One transform from the seen trunks' frame to the map, with its support. */
struct PoseHypothesis
{
  Pose2 transform;   ///< local frame -> map frame
  int inliers = 0;   ///< seen trunks within the gate of a distinct map tree
  double rms = 0.0;  ///< [m] of the inliers' distances after a least-squares refit
};

/** @brief What the search found. */
struct ConstellationResult
{
  std::vector<PoseHypothesis> hypotheses;  ///< distinct, best first (most inliers, then smallest rms)
  bool accepted = false;                   ///< the best is supported enough and not ambiguous
  std::string reason;                      ///< why not accepted (or empty)
  long candidates = 0;                     ///< transforms scored
  bool bounded = false;                    ///< the search stopped at max_candidates
};

/**
 * @brief Global relocalization by constellation: where in the saved map do the trunks seen so far lie? Every pair
 * of seen trunks whose length lies in [min_pair_length, max_pair_length] is matched against the map's tree pairs of
 * the same length (a sorted table, built once by the constructor) whose radii agree with theirs; each match
 * fixes a rigid transform, which is scored by the seen trunks it puts within the gate of a map tree of a matching
 * radius (one to one, through a grid of the map). Only the first max_pair_trunks seen trunks make pairs and the first
 * scores; the best distinct transforms are scored again on all. The best distinct transforms are refitted on their inliers by
 * least squares. Deterministic; no random draws.
 */
class ConstellationMatcher
{
public:
  ConstellationMatcher(const std::vector<Landmark>& map, const ConstellationConfig& config = ConstellationConfig());

  /** @brief The hypotheses for the trunks @p seen (a local frame: e.g. the odometry frame). */
  ConstellationResult match(const std::vector<TrunkPoint>& seen) const;

  /** @brief How many of @p seen the transform @p t (seen frame -> map) puts on a map tree (one to one, the gate and
   * the radii as in the search): e.g. to weigh a pose known otherwise against the search's. */
  int inliers(const std::vector<TrunkPoint>& seen, const Pose2& t) const { return score(seen, seen.size(), t, nullptr); }

  /**
   * @brief How well the transform @p t (seen frame -> map) explains @p seen, as a log-likelihood: a seen trunk's
   * distance to its map tree (one to one, as inliers() pairs them) is Gaussian with standard deviation
   * inlier_gate / 3 (the gate lies at 3 sigma); a trunk without a tree within the gate counts as one at the gate.
   * Up to a constant shared by every transform of the same @p seen: hypotheses compare by differences (e.g. 36 of
   * 39 trunks within 0.05 m RMS against 25 within 0.22 m: about 40 apart).
   */
  double logLikelihood(const std::vector<TrunkPoint>& seen, const Pose2& t) const;

  std::size_t mapPairs() const { return pairs_.size(); }

private:
  struct Pair
  {
    double length;
    int a, b;
  };
  bool radiiAgree(const TrunkPoint& s, int tree) const;
  /** @brief Inliers of @p t (one to one) among the first @p count of @p seen, their seen and map indices. */
  int score(const std::vector<TrunkPoint>& seen, std::size_t count, const Pose2& t,
            std::vector<std::pair<int, int>>* matches) const;
  void cellOf(const Eigen::Vector2d& p, long* cx, long* cy) const;

  ConstellationConfig config_;
  std::vector<TrunkPoint> trees_;
  std::vector<Pair> pairs_;  ///< sorted by length
  double cell_ = 1.0;
  std::vector<std::pair<long long, int>> grid_;  ///< (cell key, tree), sorted by key
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FOREST_MAP_CONSTELLATION_H
