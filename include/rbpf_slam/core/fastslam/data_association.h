#ifndef RBPF_SLAM_CORE_FASTSLAM_DATA_ASSOCIATION_H
#define RBPF_SLAM_CORE_FASTSLAM_DATA_ASSOCIATION_H

#include <cstddef>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/fastslam/landmark_map.h"
#include "rbpf_slam/core/fastslam/landmark_observation.h"
#include "rbpf_slam/core/filter/pose2.h"
#include "rbpf_slam/core/fastslam/visibility_scope.h"

namespace rbpf_slam
{
namespace core
{
/** @brief A landmark of a particle's map that may take an observation, with its predicted observation. */
struct AssociationCandidate
{
  std::size_t index;          ///< in the particle's map
  Eigen::Vector2d z;          ///< predicted (range [m], bearing [rad])
  Eigen::Matrix2d H;          ///< Jacobian of z with respect to the landmark
  Eigen::Matrix2d pose_term;  ///< Hx Sx Hx^T (Gaussian pose only, else zero)
  Eigen::Matrix2d A;          ///< H Sm H^T (+ pose_term): S = A + R of each observation
};

/** @brief Parameters of the gate and of the likelihood table (FastSlamConfig's of the same meaning). */
struct AssociationConfig
{
  /// Squared Mahalanobis distance (2 dof) within which a landmark may take an observation.
  double gate = 13.8;
  bool use_radius = true;            ///< add the trunk radius's consistency to the likelihood
  double radius_sigma_floor = 0.02;  ///< [m] added to the radius variances in that term
  /// An observation with a known id (>= 0) pairs only with the candidate of that id, without a gate.
  bool use_known_ids = false;
};

/**
 * @brief Per-particle data association, in three steps: candidates (the landmarks near the visibility scope,
 * with their predicted observations), a gated likelihood table of observations x candidates, and Gale-Shapley
 * stable matching on that table (maximum likelihood for all observations of a scan at once, no landmark
 * taking two observations).
 *
 * The buffers are kept between calls, so that once they have grown an association allocates nothing. The
 * results of the last call stay readable until the next one.
 */
class DataAssociation
{
public:
  explicit DataAssociation(const AssociationConfig& config = AssociationConfig()) : config_(config) {}

  const AssociationConfig& config() const { return config_; }

  /**
   * @brief Candidate selection: the landmarks of @p map that @p scope admits (its ring and view plus margins)
   * from the sensor at @p sensor_in_base on the base pose @p base, in ascending map index, with their predicted
   * observations. With @p pose_covariance (the base pose carried as a Gaussian) each candidate's A includes
   * the pose's part of the innovation covariance.
   */
  void selectCandidates(const LandmarkMap& map, const Pose2& base, const Pose2& sensor_in_base,
                        const VisibilityScope& scope, const Eigen::Matrix3d* pose_covariance = nullptr);

  /**
   * @brief Known association (use_known_ids): adds as candidates the landmarks whose id an observation of @p obs
   * names and that selectCandidates() left out (predicted outside the scope), so that an observation with an id
   * is never dropped for where its landmark is predicted. Keeps the candidates in ascending map index.
   */
  void addNamedCandidates(const LandmarkMap& map, const Pose2& base, const Pose2& sensor_in_base,
                          const std::vector<LandmarkObservation>& obs, const Eigen::Matrix3d* pose_covariance = nullptr);

  /**
   * @brief Gating and the likelihood table of @p obs (noise @p R per observation, with any floor) against the
   * candidates, then stable matching. A pair is inside the gate when its squared Mahalanobis distance is below
   * the gate and, when both radii are known and use_radius is set, so is the radius's; its likelihood is then
   * log N(v; 0, S) (+ the radius term).
   */
  void associate(const LandmarkMap& map, const std::vector<LandmarkObservation>& obs,
                 const std::vector<Eigen::Matrix2d>& R);

  /**
   * @brief Predicts every candidate again from the sensor pose @p sensor (a pose drawn after the association)
   * and recomputes the innovation and S^-1 of each matched pair; with @p rescore also its likelihood.
   */
  void repredict(const LandmarkMap& map, const Pose2& sensor, const std::vector<LandmarkObservation>& obs,
                 const std::vector<Eigen::Matrix2d>& R, bool rescore);

  /** @brief The candidates of the last selectCandidates(), in ascending map index. */
  const std::vector<AssociationCandidate>& candidates() const { return cand_; }
  /** @brief Candidate matched to observation @p i, or -1. */
  int match(std::size_t i) const { return match_[i]; }
  /** @brief Candidate @p k took an observation. */
  bool taken(std::size_t k) const { return taken_[k] != 0; }
  /** @brief Some candidate lay inside observation @p i's gate (whether or not it won the matching). */
  bool gated(std::size_t i) const { return prefs_begin_[i + 1] > prefs_begin_[i]; }
  /** @brief log-likelihood of observation @p i and candidate @p k; -inf outside the gate. */
  double logLikelihood(std::size_t i, std::size_t k) const { return ll_[i * cand_.size() + k]; }
  /** @brief S^-1 of a gated pair (innovation covariance, landmark + observation [+ pose]). */
  const Eigen::Matrix2d& innovationInverse(std::size_t i, std::size_t k) const { return s_inv_[i * cand_.size() + k]; }
  /** @brief Innovation (range [m], bearing [rad]) of a gated pair: observed minus predicted. */
  const Eigen::Vector2d& innovation(std::size_t i, std::size_t k) const { return v_[i * cand_.size() + k]; }

  /**
   * @brief Duplicate suppression: whether a trunk of radius @p radius centred at @p centre (map frame) would
   * come nearer than @p min_gap [m] to a candidate's trunk. Trunks do not overlap: such an observation is a
   * known trunk seen badly (e.g. with a heading error at long range), not a new one.
   */
  bool overlapsCandidate(const LandmarkMap& map, const Eigen::Vector2d& centre, double radius, double min_gap) const;

  /** @brief Gale-Shapley on a likelihood table (rows observations, columns landmarks; -inf = not allowed). */
  static std::vector<int> stableMatching(const std::vector<std::vector<double>>& log_likelihood);

private:
  AssociationConfig config_;
  std::size_t n_obs_ = 0;
  std::vector<std::size_t> near_;
  std::vector<AssociationCandidate> cand_;
  std::vector<std::pair<double, std::size_t>> by_range_;  ///< (predicted range, candidate), ascending
  std::vector<double> ll_;           ///< observations x candidates, row-major (-inf: outside the gate)
  std::vector<Eigen::Matrix2d> s_inv_;  ///< S^-1 of each gated pair, reused by the EKF update
  std::vector<Eigen::Vector2d> v_;   ///< innovation of each gated pair
  std::vector<double> radius_term_;  ///< the radius's part of each gated pair's likelihood
  std::vector<int> match_, holder_, free_, prefs_;
  std::vector<std::size_t> next_, prefs_begin_;
  std::vector<char> taken_;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FASTSLAM_DATA_ASSOCIATION_H
