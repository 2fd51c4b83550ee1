#ifndef RBPF_SLAM_CORE_LANDMARK_EVIDENCE_H
#define RBPF_SLAM_CORE_LANDMARK_EVIDENCE_H

#include <cstddef>
#include <vector>

#include "rbpf_slam/core/data_association.h"
#include "rbpf_slam/core/landmark_map.h"
#include "rbpf_slam/core/visibility_scope.h"

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

  /** @brief A new landmark's existence after its first sighting. */
  void initialize(Landmark* l) const;
  /** @brief One more match of @p l: evidence up to the ceiling, confirmed after enough matches. */
  void recordHit(Landmark* l) const;

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
   * confirmed landmarks removed are added to it.
   */
  std::size_t applyMisses(LandmarkMap* map, const DataAssociation& association, const VisibilityScope& scope,
                          std::vector<Eigen::Vector2d>* removed = nullptr);

private:
  EvidenceConfig config_;
  std::vector<std::size_t> to_delete_;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_LANDMARK_EVIDENCE_H
