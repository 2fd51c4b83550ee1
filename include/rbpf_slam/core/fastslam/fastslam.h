#ifndef RBPF_SLAM_CORE_FASTSLAM_FASTSLAM_H
#define RBPF_SLAM_CORE_FASTSLAM_FASTSLAM_H

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/fastslam/data_association.h"
#include "rbpf_slam/core/filter/history_chain.h"
#include "rbpf_slam/core/fastslam/landmark_evidence.h"
#include "rbpf_slam/core/fastslam/landmark_map.h"
#include "rbpf_slam/core/fastslam/landmark_observation.h"
#include "rbpf_slam/core/filter/odometry_buffer.h"
#include "rbpf_slam/core/filter/particle_filter.h"
#include "rbpf_slam/core/filter/pose2.h"
#include "rbpf_slam/core/filter/random.h"
#include "rbpf_slam/core/fastslam/visibility_scope.h"

namespace rbpf_slam
{
namespace core
{
struct TrunkObservation;

/** @brief How each particle's pose is drawn at an update. */
enum class PoseProposal
{
  kFastSlam1,  ///< the motion model alone, sampled at each odometry step (FastSLAM 1.0)
  kFastSlam2,  ///< the motion prior conditioned on the matched observations (FastSLAM 2.0)
};
/** @brief "fastslam1" or "fastslam2"; false (and @p out unchanged) otherwise. */
bool parsePoseProposal(const std::string& name, PoseProposal* out);
const char* toString(PoseProposal p);

/** @brief What the odometry is, and so which motion model takes it. */
enum class MotionModel
{
  kOdometry,  ///< measured increments (wheel encoders): rot1 - trans - rot2 per step of motion_step
  kVelocity,  ///< commanded (or measured) velocities integrated: errors of the velocity held over motion_noise_time
};
/** @brief "odometry" or "velocity"; false (and @p out unchanged) otherwise. */
bool parseMotionModel(const std::string& name, MotionModel* out);
const char* toString(MotionModel m);

/** @brief Range-bearing form of a detected trunk (its Cartesian covariance carried through the Jacobian). */
LandmarkObservation toLandmarkObservation(const TrunkObservation& trunk);

/** @brief Which pose the filter gives as its estimate. */
enum class PoseEstimate
{
  kMean,  ///< the weighted mean of the particles' poses (circular mean of the heading)
  kBest,  ///< the pose of the best particle
};
/** @brief "mean" or "best"; false (and @p out unchanged) otherwise. */
bool parsePoseEstimate(const std::string& name, PoseEstimate* out);
const char* toString(PoseEstimate e);

struct FastSlamConfig
{
  /// Upper bound of `particles`: 100000 particles hold ~100 MB per 1000 landmarks, beyond any robot's use.
  static constexpr int kMaxParticles = 100000;
  int particles = 100;
  /// Bounds from the sensor's physics, so that no message can take the memory. A trunk needs at least two beams of
  /// a scan ring: a lidar of 2048 columns sees at most 1024 trunks per sweep, and arrays with more are dropped.
  int max_trunks_per_sweep = 1000;
  /// Landmarks per particle's map: 20000 trees are 40 ha of a dense stand (500 stems/ha); beyond it no landmark is
  /// made (the filter says so) and a saved map with more trees is refused. The filter's memory grows with the map
  /// (about 5 MB per 1000 landmarks with 100 particles, measured on a one-hour drive over new ground).
  int max_landmarks = 20000;
  /// Keep each particle's pose history (bestHistory(): the run folder's estimate_best_history.tum); it grows by one
  /// pose per update, so a node that writes no run folder does without it.
  bool keep_history = true;
  OdometryMotionNoise motion;
  /// The motion noise is that of one odometry step of at most this length [m] and turn [rad]: the motion between
  /// two updates is predicted in steps of about this size along the odometry's own path, so that the noise grows
  /// with the distance and turning between observations, whatever the sensor's rate, and a long gap follows the
  /// path the odometry drove rather than one straight chord.
  double motion_step = 0.2;
  double motion_step_angle = 0.2;
  /// The motion model: kOdometry (the alphas per step of motion_step) or kVelocity (applyVelocityBlock: the odometry
  /// is a commanded velocity integrated, its error held over blocks of motion_noise_time seconds; the alphas per
  /// such block, as rates). A step or block cut short by an update carries its share of the variance
  /// (partialStepNoiseScale), so the noise does not depend on how often the sensor looks.
  MotionModel motion_model = MotionModel::kOdometry;
  double motion_noise_time = 1.0;  ///< [s]

  // Observation noise floor (added in quadrature to each observation's own covariance): the detector's
  // covariance is that of its fit and does not know of the sensor's systematic errors.
  double range_sigma_floor = 0.03;     ///< [m]
  double bearing_sigma_floor = 0.005;  ///< [rad]

  // Visibility scope of the sensor (landmarks outside are neither matched nor missed): each sweep brings its
  // sensor's own (TrunkArray's min_range, max_range, fov_min, fov_max, detection_probability); a value set here
  // (> 0) bounds it, 0 leaves it to the sensor. Where neither says, the fallback scope below holds.
  double min_range = 0.0;      ///< [m]
  double max_range = 0.0;      ///< [m]
  double field_of_view = 0.0;  ///< [rad], centred on the sensor's x axis
  double detection_probability = 0.0;  ///< share of the landmarks in scope the sensor reports, in (0, 1]
  /// [m], [m], [rad], [-]: the scope of a sensor that says nothing of its own and is not configured.
  static constexpr double kFallbackMinRange = 1.0, kFallbackMaxRange = 12.0, kFallbackFieldOfView = 2.0 * M_PI,
                          kFallbackDetectionProbability = 1.0;

  // Association: squared Mahalanobis distance (2 dof) within which a landmark may take an observation; an
  // observation whose best landmark is further (likelihood below that of the gate) makes a new landmark.
  double association_gate = 13.8;  ///< 99.9 % of a true match
  bool use_radius = true;          ///< add the trunk radius's consistency to the likelihood
  /// Associate by the detector's landmark id where it gives one (>= 0; e.g. a data set with known association):
  /// an observation updates the landmark of its id, without a gate and wherever it is predicted (inside the scope or
  /// not), or starts it; a landmark named by an id is never deleted by the miss rule.
  bool use_known_ids = false;
  double radius_sigma_floor = 0.02;  ///< [m] added to the radius variances in that term
  double min_trunk_gap = 0.1;  ///< [m] no new landmark whose trunk would come nearer than this to a known one
  /// Tracking in a saved map (TrunkSlamPipeline::setPriorMap): search the map again by constellation when the health
  /// warns that its trees are not re-observed (a lost pose), and move the particles where it finds the robot.
  bool relocalize_when_lost = true;

  // Landmark existence (log odds): + evidence_hit per match, - evidence_miss per expected miss (inside the
  // scope, not hidden behind a nearer landmark); removed below delete_evidence; provisional until seen
  // confirm_observations times.
  double evidence_hit = 1.0;
  double evidence_miss = 1.0;
  double evidence_max = 6.0;
  double delete_evidence = -1.5;
  int confirm_observations = 3;
  /// [rad] Evidence counted once per view. A sweep's likelihood is tempered by the share of a new view it brings
  /// (the sensor's travel over this angle times its trunks' median range, or its turn over this angle:
  /// evidenceShare()), and a hit or a miss changes a landmark's existence, and counts towards its confirmation,
  /// only when its direction from the landmark has turned by this angle, or its range changed by this share, since
  /// the last counted look (EvidenceConfig::view_change). 10 degrees: the line of sight then passes other parts of
  /// the occluders near the tree and fits another part of its bark. 0: every sweep counts as an independent look.
  double evidence_view_change = 0.17;
  // A provisional landmark that leaves the visibility scope before it is confirmed is dropped: a tentative
  // track that did not make it (a trunk-like object glimpsed once at the scope's edge), not a tree.
  bool drop_unconfirmed_leaving_scope = true;
  /// Whether an observation matched to a provisional landmark weighs the particle by its likelihood (true) or as
  /// one that made a new landmark (false: a landmark not yet confirmed is no evidence for or against a pose, so a
  /// bush or a car's side that passes for a trunk in a few sweeps cannot pull the particles). false costs the
  /// observations of trees until they are confirmed: right for a 2D scanner's clutter (config/scanner_2d.yaml),
  /// wrong for a clean detector.
  bool provisional_weighs = true;

  // Resampling (the skeleton's policy): low-variance resampling when Neff < resample_neff_ratio * N.
  ResamplingPolicy resampling;
  bool roughening = false;          ///< jitter resampled poses (bends the factorisation)
  double roughening_sigma_xy = 0.01;     ///< [m]
  double roughening_sigma_theta = 0.002; ///< [rad]

  // Proposal distribution of the pose.
  PoseProposal proposal = PoseProposal::kFastSlam1;
  /// Mixture MCL (Thrun, Fox, Burgard, Dellaert 2001): the probability that a particle's pose is drawn at an
  /// update from the dual proposal instead, the pose that best explains the matched observations in the
  /// particle's own map; the weights are those of the mixture (see FastSlam). 0: off.
  double mixture_fraction = 0.0;

  /// The published pose: the weighted mean of the particles, or the best particle (the one of the largest weight
  /// before resampling, followed through its copies).
  PoseEstimate estimate = PoseEstimate::kMean;

  std::uint64_t seed = 0;

  /** @brief The scope limits set here, as a SensorScope (NaN where left to the sensor). */
  SensorScope configuredScope() const;
  /** @brief The scope where neither the sensor nor the configuration says. */
  static VisibilityScope fallbackScope();

  /** @brief Empty when valid, else a message naming the first bad parameter. */
  std::string validate() const;
};

struct Particle
{
  Pose2 pose;               ///< base_link in the map frame
  double log_weight = 0.0;  ///< normalised after each update
  LandmarkMap map;
  /// Covariance of the pose gathered by predict() since the last update, when the pose is carried as a
  /// Gaussian (FastSLAM 2.0, mixture); zero otherwise.
  Eigen::Matrix3d motion_covariance = Eigen::Matrix3d::Zero();
  /// The particle's own pose after each update, newest first; ancestors shared with the particles that descend
  /// from the same ones (a resampled copy shares its original's history).
  HistoryNode<Pose2>::Ptr history;
};

/** @brief Counters of one update() for diagnostics. */
struct FastSlamUpdateStats
{
  int observations = 0;
  int matched = 0;     ///< in the best particle
  int created = 0;     ///< in the best particle
  int ignored = 0;     ///< lost the matching but inside a gate: neither matched nor new (best particle)
  int deleted = 0;     ///< in the best particle
  int landmarks = 0;   ///< in the best particle's map after the update
  int dual = 0;        ///< particles (all of them) whose pose came from the dual proposal (mixture)
  double neff = 0.0;   ///< before resampling
  bool resampled = false;
  double pose_spread = 0.0;  ///< [m] the particles' position spread before the update (widest axis, 1 sigma)
  /// Always false: the filter no longer gates with the cloud's covariance (kept for the column of updates.csv and
  /// the health's share, so that their layout does not change).
  bool relocalizing = false;
  int matched_confirmed = 0; ///< observations matched to confirmed landmarks (best particle)
  int matched_prior = 0;     ///< ... to landmarks of a saved map (seen before this run)
  int recreated = 0;         ///< new landmarks within a gate's reach of one deleted before (best particle)
  int map_full = 0;          ///< observations that made no landmark because the map held max_landmarks (best particle)
  /// Sum over the best particle's matches of the squared Mahalanobis distance of the innovation: a filter whose
  /// pose error stays within its uncertainty averages 2 per match (chi-square, 2 dof).
  double innovation_nis = 0.0;
  /// The same against all the uncertainty the filter claims (the landmark's, one independent look's noise and
  /// the particle cloud's spread before the update), over claimed_matches matches of the best particle: about 2
  /// per match when the claimed uncertainty covers the errors, far more when the cloud is surer than it should be.
  double claimed_nis = 0.0;
  int claimed_matches = 0;
  /// The particles after the update (weighted; after resampling if it happened): mean and covariance of the
  /// position, and whether they were computed (false for an update that took no sweep).
  bool has_cloud = false;
  Eigen::Vector2d cloud_mean = Eigen::Vector2d::Zero();
  Eigen::Matrix2d cloud_covariance = Eigen::Matrix2d::Zero();
};

/**
 * @brief Whether @p truth lies inside the 95 % region of the position Gaussian (@p mean, @p covariance), the
 * squared Mahalanobis distance within the chi-square 2-dof quantile 5.991. A singular covariance (every particle
 * at one place) covers only its own point.
 */
bool insideRegion95(const Eigen::Vector2d& truth, const Eigen::Vector2d& mean, const Eigen::Matrix2d& covariance);

/**
 * @brief FastSLAM 2.0 proposal step: conditions the pose Gaussian (@p mean, @p covariance) of base_link on
 * one range-bearing observation @p z (noise @p R) of landmark @p l by the sensor at @p sensor on base_link,
 * linearised at the mean (Thrun, Burgard, Fox 13.3: Sigma' = (Hx^T Q^-1 Hx + Sigma^-1)^-1,
 * mu' = mu + Sigma' Hx^T Q^-1 (z - zhat), Q = R + Hm Sigma_m Hm^T), in the gain form that needs no inverse
 * of Sigma (a zero covariance stays zero).
 */
void conditionPoseOnLandmark(Pose2* mean, Eigen::Matrix3d* covariance, const Landmark& l, const Eigen::Vector2d& z,
                             const Eigen::Matrix2d& R, const Pose2& sensor);

/** @brief Propagates a pose Gaussian through the odometry motion model (linearised rot1-trans-rot2). */
void propagatePoseGaussian(Pose2* mean, Eigen::Matrix3d* covariance, const OdometryIncrement& u,
                           const OdometryMotionNoise& noise);

/**
 * @brief FastSLAM over point landmarks with radii: per particle a pose and a map of independent 2D EKFs.
 * Association per particle by maximum likelihood solved for all observations of a scan at once with
 * Gale-Shapley stable matching. ROS-free, deterministic for a given seed.
 *
 * Proposals: FastSLAM 1.0 samples the motion model at each odometry step. FastSLAM 2.0 (Montemerlo et al.
 * 2003) carries each particle's pose as a Gaussian between updates (the motion model linearised), associates
 * with the pose uncertainty in the innovation covariance, conditions the Gaussian on the matched observations
 * one after another and samples the pose from it; the weight is the product of the matched observations'
 * likelihoods under the prior (innovation covariance R + Hm Sm Hm^T + Hx Sx Hx^T).
 *
 * Mixture MCL: with mixture_fraction f > 0 each particle draws its pose with probability f from the dual
 * proposal N(mu_d, S_d), the observation-only pose fit (Gauss-Newton on the matched landmarks of its map,
 * needs two), else from its regular proposal q (the motion prior, or the FastSLAM 2.0 proposal). Weights:
 * Thrun et al.'s dual weighting (dual samples weigh p(x | u), regular ones as usual, the two sets normalised
 * apart to f and 1 - f).
 */
class FastSlam
{
public:
  explicit FastSlam(const FastSlamConfig& config);

  /** @brief All particles at @p start with empty maps and equal weights. */
  void initialize(const Pose2& start = Pose2());
  /** @brief All particles at @p start sharing the prior map @p map (copy-on-write), equal weights. */
  void initialize(const Pose2& start, const LandmarkMap& map);
  /**
   * @brief The particles spread over the poses @p starts (in turn, each drawn around its pose with the standard
   * deviations @p sigma_xy [m] and @p sigma_theta [rad] from the filter's generator), sharing the prior map @p map.
   * With @p log_weights (one per start), the particles around a start weigh in proportion to exp(its log weight);
   * without, all weigh the same.
   */
  void initialize(const std::vector<Pose2>& starts, const LandmarkMap& map, double sigma_xy, double sigma_theta,
                  const std::vector<double>& log_weights = {});
  /**
   * @brief After a loop was closed: every particle drawn around @p pose with @p covariance (x, y, theta; from the
   * filter's generator), all sharing @p map and the path @p path (one pose per update, oldest first; its last is
   * each particle's own pose), with equal weights. Landmark ids go on from where they were.
   */
  void redraw(const Pose2& pose, const Eigen::Matrix3d& covariance, const LandmarkMap& map,
              const std::vector<Pose2>& path);
  /**
   * @brief Samples every particle's motion for one odometry increment, the noise's standard deviations
   * multiplied by @p noise_scale (partialStepNoiseScale).
   */
  void predict(const OdometryIncrement& u, double noise_scale = 1.0);
  /** @brief The velocity model's prediction of one block of arcs (applyVelocityBlock). */
  void predictArcs(const std::vector<ArcStep>& block, double noise_scale = 1.0);
  /**
   * @brief Predicts the motion from @p from at @p t_from to @p to at @p t_to along the odometry's own samples in
   * @p odometry: steps of motion_step (odometry model) or blocks of motion_noise_time (velocity model); the last,
   * partial one carries its share of a full one's noise.
   */
  void predictAlong(const OdometryBuffer& odometry, double t_from, const Pose2& from, double t_to, const Pose2& to);
  /**
   * @brief Weights the particles by the observations of one scan, updates their maps, resamples when Neff
   * is low. @p sensor is the sensor's pose on base_link (its planar part). @p evidence_share in (0, 1] is the share
   * of one independent look the observations carry (evidenceShare()): their covariance is divided by it.
   */
  FastSlamUpdateStats update(const std::vector<LandmarkObservation>& observations, const Pose2& sensor,
                             const SensorScope& sensor_scope = SensorScope(), double evidence_share = 1.0);

  /**
   * @brief Weighs the particles by a measurement of a point @p lever on base_link (e.g. a satellite antenna) at
   * @p position in the map with @p covariance (a Gaussian likelihood); the weights are normalised, the next update()
   * resamples when Neff has fallen. Returns Neff / N after. Non-finite input changes nothing (returns -1).
   */
  double weighPosition(const Eigen::Vector2d& position, const Eigen::Matrix2d& covariance,
                       const Eigen::Vector2d& lever = Eigen::Vector2d::Zero());

  /** @brief [s] The time of the observations of the next update(): a landmark's first_seen and last_seen. */
  void setClock(double stamp) { clock_ = stamp; }

  const std::vector<Particle>& particles() const { return particles_; }
  const FastSlamConfig& config() const { return config_; }
  /**
   * @brief Index of the best particle: the one of the largest weight after the last update, or after a
   * resampling the first copy of the one that had the largest weight before it (never simply the first of a set
   * of equal weights).
   */
  std::size_t bestIndex() const { return best_; }
  const Particle& best() const { return particles_[best_]; }
  /** @brief The best particle's landmarks, in map order. */
  std::vector<Landmark> bestTrees() const;
  /** @brief The estimate of base_link in the map (config().estimate: the weighted mean or the best particle's). */
  Pose2 estimate() const { return config_.estimate == PoseEstimate::kBest ? best().pose : meanPose(); }
  /** @brief The pose the best particle had after each update since initialize(), oldest first: its own
   * trajectory (its ancestors' before they were resampled), one pose per update. */
  std::vector<Pose2> bestHistory() const;
  /** @brief The scope of the last update. */
  const VisibilityScope& scope() const { return scope_; }
  /** @brief Weighted mean pose (circular mean of the heading). */
  Pose2 meanPose() const;
  /** @brief Weighted covariance of (x, y, theta). */
  Eigen::Matrix3d poseCovariance() const;
  /** @brief Both at once (core::poseMoments of the particles). */
  PoseMoments moments() const;

  /** @brief Gale-Shapley on a likelihood table (rows observations, columns landmarks; -inf = not allowed). */
  static std::vector<int> stableMatching(const std::vector<std::vector<double>>& log_likelihood)
  {
    return DataAssociation::stableMatching(log_likelihood);
  }

private:
  /** @brief Buffers of one update, kept between calls so that an update allocates nothing. */
  struct Scratch
  {
    std::vector<Eigen::Matrix2d> R;  ///< per observation, with the floor
    std::vector<double> log_new;     ///< per observation: the likelihood at the gate
    std::vector<char> dual_flags;  ///< per particle of the current update: pose from the dual proposal
  };

  /**
   * @brief One particle's update, step by step: candidates and data association (association_), the pose
   * draw (Gaussian pose only), the map update by each observation, then the misses (evidence_).
   */
  void updateParticle(Particle* p, const std::vector<LandmarkObservation>& obs, const Pose2& sensor,
                      FastSlamUpdateStats* stats);
  /** @brief Pose carried as a Gaussian between updates (FastSLAM 2.0 or the mixture). */
  bool gaussianPose() const { return config_.proposal == PoseProposal::kFastSlam2 || config_.mixture_fraction > 0.0; }
  /**
   * @brief Pose draw step of a Gaussian-pose particle: draws the pose (drawPose), predicts the candidates
   * again from it, and sets @p dual_weight (the weight of a dual sample under Thrun et al.'s dual weighting).
   */
  void drawPoseAndRepredict(Particle* p, const std::vector<LandmarkObservation>& obs, const Pose2& sensor,
                            double* dual_weight);
  /**
   * @brief Draws the pose of a Gaussian-pose particle for the matched observations; @p log_prior is set to
   * log p(x | u) at the drawn pose for the mixture (0 otherwise).
   */
  void drawPose(Particle* p, const std::vector<LandmarkObservation>& obs, const Pose2& sensor, bool* dual,
                double* log_prior);
  /**
   * @brief Map update step: each observation, in order, updates its matched landmark (EKF, radius, evidence),
   * or is ignored (it lost the matching, or would duplicate a known trunk), or starts a new landmark; its
   * likelihood is added to @p log_w. @p sensor is the sensor's pose in the map frame.
   */
  void updateMap(Particle* p, const std::vector<LandmarkObservation>& obs, const Pose2& sensor, double* log_w,
                 FastSlamUpdateStats* stats);

  FastSlamConfig config_;
  std::vector<Particle> particles_;
  Random random_;
  int next_id_ = 0;
  double evidence_share_ = 1.0;  ///< of the update running (update()'s evidence_share)
  double clock_ = NAN;  ///< [s] the time of the observations of the next update (setClock)
  std::vector<double> weights_;
  std::vector<double> weights_before_;  ///< normalised weights before the last resampling
  std::size_t best_ = 0;
  Scratch scratch_;
  VisibilityScope scope_;
  bool sweep_complete_ = true;  ///< this update's sweep reported all it saw (SensorScope::complete)
  Eigen::Matrix3d cloud_covariance_ = Eigen::Matrix3d::Zero();  ///< of the particles, before this update
  std::vector<Eigen::Vector2d> deleted_positions_;  ///< confirmed landmarks the best particle lost, newest last
  DataAssociation association_;
  LandmarkEvidence evidence_;
};

/**
 * @brief The trees of a saved map as every particle's starting map: confirmed trees with the largest existence
 * evidence (evidence_max), provisional ones with none; covariances made symmetric and positive semidefinite; ids,
 * radii, counts and times kept; this visit's own fields empty. @throws std::invalid_argument for more trees than
 * max_landmarks.
 */
LandmarkMap priorMap(const std::vector<Landmark>& trees, const FastSlamConfig& config);

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FASTSLAM_FASTSLAM_H
