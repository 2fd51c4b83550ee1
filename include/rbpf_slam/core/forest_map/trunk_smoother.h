#ifndef RBPF_SLAM_CORE_FOREST_MAP_TRUNK_SMOOTHER_H
#define RBPF_SLAM_CORE_FOREST_MAP_TRUNK_SMOOTHER_H

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/fastslam/fastslam.h"
#include "rbpf_slam/core/forest_map/loop_closure_config.h"

namespace rbpf_slam
{
namespace core
{
/** @brief A smoothed path and tree map, and how the solve went. */
struct SmoothedRun
{
  bool ok = false;     ///< solved, converged within the budget and consistent; else nothing is to be applied
  /// refused because the graph could not bring the loop's trees together: their residuals beyond the bound after the
  /// solve, or no convergence with them (the map disagrees with the revisit; not a refusal for the graph's size)
  bool inconsistent = false;
  std::string reason;  ///< why not (or empty)
  std::vector<double> stamps;  ///< [s] one per filter update recorded
  std::vector<Pose2> poses;    ///< base_link in the map frame at each of them
  std::vector<Landmark> trees; ///< the trees, moved by the solve; the trees of each identity merged into one
  Eigen::Matrix3d last_covariance = Eigen::Matrix3d::Zero();  ///< marginal of the last pose (x, y, theta)
  bool has_covariance = false;
  int keyframes = 0;
  int trees_solved = 0;   ///< trees that observations tie to the path (the others move with their keyframe)
  int observations = 0;   ///< observations given to a tree
  int factors = 0;        ///< their factors (one per keyframe and tree)
  int identities = 0;     ///< identity factors (the loop's matched trees) in the last solve
  int identities_dropped = 0;  ///< pairs of the loop dropped as not fitting the others (solved again without them)
  int iterations = 0;
  double identity_chi2 = 0.0;  ///< sum of the identity factors' squared whitened residuals after the solve
  double identity_bound = 0.0; ///< the chi-square quantile they are held to
  double seconds = 0.0;            ///< the whole solve: graph, Levenberg-Marquardt, marginal covariance
  double seconds_covariance = 0.0; ///< ... of which the marginal covariance
};

/**
 * @brief A factor graph over the best particle's path and trees, solved with Ceres (Levenberg-Marquardt, sparse
 * Cholesky, one thread: deterministic).
 *
 * - Keyframes: the filter updates at about every keyframe_distance of odometry travel (or keyframe_angle of turn).
 *   Each update's observations join the keyframe before it, their sensor carried there by the odometry.
 * - Odometry factors between consecutive keyframes: the odometry's increment with the covariance of the filter's
 *   motion noise class, propagated along the updates between them in steps of motion_step (each carrying its
 *   share, as the filter's prediction does).
 * - Tree factors: each observation given to the tree of the map it falls on from the particle's own pose (within
 *   association_gate); its covariance the filter's (the noise floor added, divided by the sweep's evidence share:
 *   one independent look per view, as in the filter); carried into its keyframe's frame as a point, and a
 *   keyframe's points of one tree fused into one factor (information summed); a Cauchy loss.
 * - Identity factors: two trees a loop matched are one (their difference, with both covariances and loop_sigma).
 * - The first keyframe is held (the map frame).
 * ROS-free.
 */
class TrunkSmoother
{
public:
  TrunkSmoother(const SmootherConfig& config, const FastSlamConfig& filter);

  /** @brief One filter update, as the filter took it: its odometry, its sensor mount on base_link, its observations
   * (sensor frame) and their evidence share. */
  void add(double stamp, const Pose2& odometry, const Pose2& mount, const std::vector<LandmarkObservation>& observations,
           double evidence_share);
  void clear()
  {
    records_.clear();
    thinned_ = 0;
  }
  /**
   * @brief Forgets the observations of the updates recorded before @p before that revisit a place: those within
   * keyframe_distance and keyframe_angle (on the path @p path, one pose per update) of a first visit at least
   * @p pass_gap earlier, except one per keyframe_distance (or keyframe_angle) of travel, which keeps every keyframe
   * tied to the trees. Their odometry stays. A revisit then costs one look per keyframe, not every sweep: the
   * records grow with the distance driven, not with the sweeps. Nothing is done when the path does not match the
   * records. Returns how many updates were thinned by this call.
   */
  std::size_t thin(const std::vector<Pose2>& path, double before, double pass_gap);
  /** @brief Updates whose observations were forgotten since the start (or clear()). */
  std::size_t thinned() const { return thinned_; }
  std::size_t size() const { return records_.size(); }

  /**
   * @brief Solves the graph from the path @p path (one pose per recorded update, the particle's own) and its trees
   * @p trees, with the identities @p identities (tree ids: (recent, old); the old id is kept). Not ok (and nothing
   * to apply) when the path does not match the records, the graph has more than max_factors factors, the solve fails
   * or does not converge within max_iterations, or the identities' residuals exceed their chi-square bound. When they
   * do, the worst pair, if beyond the 2-dof quantile on its own, is dropped and the rest solved again (at most
   * loop_rounds solves), while more than half of the pairs and at least loop_min_trees remain: one look-alike pair
   * cannot refuse a loop the others agree on, nor pull the map. Its work is bounded by those counts, never by a
   * clock: one input, one answer. Thread-safe (const, no shared state).
   */
  SmoothedRun solve(const std::vector<Pose2>& path, const std::vector<Landmark>& trees,
                    const std::vector<std::pair<int, int>>& identities) const;

  const SmootherConfig& config() const { return config_; }

  /**
   * @brief How far the odometry may have drifted since @p stamp: the covariance (x, y, theta) of its increment from
   * the last update recorded at or before @p stamp to the last one, in the frame of the former (the motion noise
   * class propagated along the updates); @p odometry_then gets the odometry there. Zero before two updates.
   */
  Eigen::Matrix3d driftSince(double stamp, Pose2* odometry_then) const;
  /** @brief The odometry of the last update recorded (identity before the first). */
  Pose2 lastOdometry() const { return records_.empty() ? Pose2() : records_.back().odometry; }

private:
  struct Record
  {
    double stamp;
    Pose2 odometry;
    Pose2 mount;
    std::vector<LandmarkObservation> observations;  ///< covariance with the floor, divided by the evidence share
  };
  /** @brief Covariance of the odometry's increment from record @p a to @p b under the motion noise class. */
  Eigen::Matrix3d odometryCovariance(std::size_t a, std::size_t b) const;

  /** @brief One solve of solve(); @p identity_chi2 gets each identity's squared whitened residual after it (NaN for
   * a pair not tied to the path by an observation). @p start: the parameters a solve of the same graph ended with, to
   * start from (none when empty); it gets this solve's. */
  SmoothedRun solveOnce(const std::vector<Pose2>& path, const std::vector<Landmark>& trees,
                        const std::vector<std::pair<int, int>>& identities, std::vector<double>* identity_chi2,
                        std::vector<double>* start) const;
  /** @brief One solve's keyframes, parameter blocks, problem and identities (defined in the source). */
  struct Graph;
  /** @brief The keyframes of the records, their poses from @p path. */
  void chooseKeyframes(const std::vector<Pose2>& path, Graph* g) const;
  /** @brief The trees' indices by id and by cell, their parameter blocks. */
  static void indexTrees(const std::vector<Landmark>& trees, Graph* g);
  void addOdometryFactors(Graph* g) const;
  void addObservationFactors(const std::vector<Pose2>& path, const std::vector<Landmark>& trees, Graph* g,
                             SmoothedRun* out) const;
  void addIdentityFactors(const std::vector<Landmark>& trees, const std::vector<std::pair<int, int>>& identities,
                          Graph* g) const;
  /** @brief The path at every update, from the keyframes' solved poses @p corrected. */
  void storePath(const Graph& g, const std::vector<Pose2>& corrected, SmoothedRun* out) const;
  /** @brief The trees, moved by the solve (or with their keyframe), each identity's two merged into one. */
  void storeTrees(const Graph& g, const std::vector<Pose2>& corrected, const std::vector<Pose2>& path,
                  const std::vector<Landmark>& trees, SmoothedRun* out) const;

  SmootherConfig config_;
  OdometryMotionNoise motion_;
  double motion_step_, motion_step_angle_;
  double range_floor_, bearing_floor_;
  std::vector<Record> records_;
  std::size_t thinned_ = 0;
};

/** @brief The @p quantile of the chi-square distribution with @p dof degrees of freedom (exact to 1e-9 relative). */
double chiSquareQuantile(double quantile, int dof);

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FOREST_MAP_TRUNK_SMOOTHER_H
