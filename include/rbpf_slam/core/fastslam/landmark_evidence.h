#ifndef RBPF_SLAM_CORE_FASTSLAM_LANDMARK_EVIDENCE_H
#define RBPF_SLAM_CORE_FASTSLAM_LANDMARK_EVIDENCE_H

#include <cstddef>
#include <vector>

#include "rbpf_slam/core/fastslam/data_association.h"
#include "rbpf_slam/core/fastslam/landmark_map.h"
#include "rbpf_slam/core/fastslam/visibility_scope.h"

namespace rbpf_slam
{
namespace core
{
/** @brief Parameters of a landmark's existence (log odds; FastSlamConfig's evidence_* and the like). */
struct EvidenceConfig
{
  double hit = 1.0;           ///< added per match
  double miss = 1.0;          ///< subtracted per expected miss, times the scope's detection probability
  double max = 6.0;           ///< ceiling, so that a long-seen landmark can still be removed
  double delete_below = -1.5; ///< removed below this
  int confirm_observations = 3;  ///< provisional until seen this many times
  /// Drop a provisional landmark that leaves the scope's far edge before it is confirmed.
  bool drop_unconfirmed_leaving_scope = true;
  /// [rad] Looks at a landmark count as evidence once per view: a hit or a miss changes its existence, and a hit
  /// brings it nearer confirmation, only when the sensor sees it from a new viewpoint, one whose direction from
  /// the landmark differs from that of the last counted look by this angle or whose range differs by this share
  /// (the distance sqrt(d_direction^2 + d_ln(range)^2)). Looks from about the same place repeat the same
  /// occlusions, the same clutter and the same fit, and are not independent evidence. 0: every look counts.
  double view_change = 0.0;
};

/** @brief What becomes of a candidate that took no observation. */
enum class MissOutcome
{
  kOutOfScope,          ///< outside the visibility scope (within the candidate margins): kept as it is
  kLeavingUnconfirmed,  ///< provisional, just beyond the far edge: dropped
  kHidden,              ///< in the shadow of a nearer landmark: kept as it is
  kMissed,              ///< should have been seen: loses evidence
};

/**
 * @brief Existence of the landmarks of one particle's map: evidence for each match, the expected-miss test
 * (inside the visibility scope and not hidden behind a nearer landmark) and the removal of landmarks whose
 * evidence fell too low. Keeps its buffer between calls, so that an update allocates nothing.
 */
class LandmarkEvidence
{
public:
  explicit LandmarkEvidence(const EvidenceConfig& config = EvidenceConfig()) : config_(config) {}

  const EvidenceConfig& config() const { return config_; }

  /** @brief A new landmark's existence after its first sighting from @p sensor (map frame; NaN: not known). */
  void initialize(Landmark* l, const Eigen::Vector2d& sensor = kNoView) const;
  /**
   * @brief One more match of @p l seen from @p sensor (map frame): evidence up to the ceiling and one view nearer
   * confirmation when the view is new (always when @p sensor is NaN or view_change is 0).
   */
  void recordHit(Landmark* l, const Eigen::Vector2d& sensor = kNoView) const;
  /** @brief Whether a look at @p l from @p sensor (map frame) is a new view (view_change). */
  bool isNewView(const Landmark& l, const Eigen::Vector2d& sensor) const;
  /** @brief isNewView(), and if so marks the look as the last counted one. */
  bool takeView(Landmark* l, const Eigen::Vector2d& sensor) const;
  static const Eigen::Vector2d kNoView;

  /**
   * @brief Expected-miss test of candidate @p k (of @p candidates, predicted in @p map) that took no
   * observation: out of the scope, leaving it unconfirmed, hidden behind a nearer candidate, or missed.
   */
  MissOutcome classifyUnseen(const std::vector<AssociationCandidate>& candidates, const LandmarkMap& map,
                             std::size_t k, const VisibilityScope& scope) const;

  /**
   * @brief Applies the misses of the candidates of @p association that took no observation to @p map and
   * removes the landmarks dropped or below delete_below. Returns how many were removed. Landmarks added to
   * @p map after the association are not candidates and are left alone. With @p removed, the positions of the
   * confirmed landmarks removed are added to it. A miss counts once per view from @p sensor (map frame).
   */
  std::size_t applyMisses(LandmarkMap* map, const DataAssociation& association, const VisibilityScope& scope,
                          std::vector<Eigen::Vector2d>* removed = nullptr, const Eigen::Vector2d& sensor = kNoView);

private:
  EvidenceConfig config_;
  std::vector<std::size_t> to_delete_;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FASTSLAM_LANDMARK_EVIDENCE_H
