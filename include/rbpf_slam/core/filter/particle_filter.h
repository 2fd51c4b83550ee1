#ifndef RBPF_SLAM_CORE_FILTER_PARTICLE_FILTER_H
#define RBPF_SLAM_CORE_FILTER_PARTICLE_FILTER_H

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/filter/pose2.h"
#include "rbpf_slam/core/filter/random.h"

namespace rbpf_slam
{
namespace core
{
/**
 * @brief Noise of the odometry motion model rot1 - trans - rot2 (Thrun, Burgard, Fox: Probabilistic
 * Robotics, 5.4): standard deviations
 *   rot1, rot2: alpha1 |rot| + alpha2 trans,   trans: alpha3 trans + alpha4 (|rot1| + |rot2|).
 * (Standard deviations, not variances, so that the alphas read as "m per m" and "rad per rad".)
 */
struct OdometryMotionNoise
{
  // Defaults: the accuracy class "skid-steer wheel odometry on rough ground": 5 % of a rotation, 0.02 rad
  // (1.1 deg) of heading per metre driven, 2 % of the distance, 1 cm per radian turned; per odometry step as
  // the filter takes them (one per sweep, about 0.1 m). A class, not the simulator's true noise.
  double alpha1 = 0.05;  ///< [rad/rad] rotation noise from rotation
  double alpha2 = 0.02;  ///< [rad/m] rotation noise from translation
  double alpha3 = 0.02;  ///< [m/m] translation noise from translation
  double alpha4 = 0.01;  ///< [m/rad] translation noise from rotation

  /** @brief Empty when valid, else a message naming the bad parameter. */
  std::string validate() const;
};

/** @brief The rot1, trans, rot2 decomposition of the odometry increment from @p a to @p b. */
struct OdometryIncrement
{
  double rot1 = 0.0, trans = 0.0, rot2 = 0.0;
};
OdometryIncrement decomposeOdometry(const Pose2& a, const Pose2& b);

/** @brief Standard deviations of the rot1, trans and rot2 noise of increment @p u under @p noise. */
struct OdometryNoiseSigmas
{
  double rot1 = 0.0, trans = 0.0, rot2 = 0.0;
};
OdometryNoiseSigmas odometryNoiseSigmas(const OdometryIncrement& u, const OdometryMotionNoise& noise);

/** @brief The noise-free successor of @p pose for increment @p u (the motion model's mean). */
Pose2 applyOdometry(const Pose2& pose, const OdometryIncrement& u);

/**
 * @brief Samples a successor of @p pose for the odometry increment (a -> b). Small translations (below
 * 1 cm) keep rot1 = 0 so that turning on the spot does not get a random heading for its translation.
 */
Pose2 sampleOdometryMotion(const Pose2& pose, const OdometryIncrement& u, const OdometryMotionNoise& noise,
                           Random& random);

/**
 * @brief The noise scale of a step that is the fraction @p fraction (in (0, 1)) of a full step (motion_step or
 * motion_step_angle, or the velocity model's motion_noise_time): the noise of a full step adds up as a random walk,
 * so a part of it carries the same share of its variance. The standard deviations of a partial step u, linear in u,
 * are multiplied by 1 / sqrt(fraction); 1 for a full step or no motion.
 */
double partialStepNoiseScale(double fraction);

/**
 * @brief One piece of odometry that is a commanded (or measured) velocity integrated: the arc a unicycle drives
 * between two odometry samples. @p delta is the odometry's own increment (the mean of the motion model), distance
 * the arc's length [m] (negative when driving backwards) and turn its heading change [rad].
 */
struct ArcStep
{
  double distance = 0.0;
  double turn = 0.0;
  Pose2 delta;
};
/** @brief The arc from odometry pose @p a to @p b (a turn on the spot below 1e-9 m). */
ArcStep arcStep(const Pose2& a, const Pose2& b);
/** @brief The increment of an arc of length @p distance turning @p turn, in its start's frame. */
Pose2 arcIncrement(double distance, double turn);

/**
 * @brief Velocity motion model (Probabilistic Robotics 5.3, with the errors of a command held over a block):
 * the velocities a robot drives differ from those it was commanded (or measured) by errors that persist over
 * a block of motion_noise_time seconds. Over one block of arcs, with two standard normal draws z_v, z_w for the
 * whole block, each arc's length gets z_v (alpha3 |distance| + alpha4 |turn|) and its turn
 * z_w (alpha1 |turn| + alpha2 |distance|): the alphas are those of a rate (m/s per m/s, ...) and their meaning is
 * that of the odometry model's (1: rotation from rotation, 2: rotation from translation, 3: translation from
 * translation, 4: translation from rotation). @p scale multiplies the standard deviations (partialStepNoiseScale).
 * Returns the pose after the block for the given draws.
 */
Pose2 applyVelocityBlock(const Pose2& pose, const std::vector<ArcStep>& block, const OdometryMotionNoise& noise,
                         double scale, double z_v, double z_w);
/** @brief applyVelocityBlock with z_v, z_w drawn from @p random. */
Pose2 sampleVelocityBlock(const Pose2& pose, const std::vector<ArcStep>& block, const OdometryMotionNoise& noise,
                          double scale, Random& random);

/**
 * @brief Turns log-weights into normalised weights (in place, the max subtracted first so nothing
 * underflows); returns the log of the normaliser (the log of the sum of the input weights).
 */
double normalizeLogWeights(std::vector<double>* log_weights, std::vector<double>* weights);

/** @brief 1 / sum w^2 of normalised weights. */
double effectiveSampleSize(const std::vector<double>& weights);

/**
 * @brief Low-variance (systematic) resampling: indices of the particles to keep, count = weights.size().
 * One uniform draw; particle i is copied about N w_i times.
 */
std::vector<int> lowVarianceResample(const std::vector<double>& weights, Random& random);

/**
 * @brief Multinomial resampling (N independent draws from the weights): more
 * variance than low-variance resampling, kept as an option for comparison.
 */
std::vector<int> multinomialResample(const std::vector<double>& weights, Random& random);

/** @brief The resampling strategies of the skeleton. */
enum class ResamplingMethod
{
  kLowVariance,
  kMultinomial
};
/** @brief "low_variance" or "multinomial"; false (and @p method untouched) for anything else. */
bool parseResamplingMethod(const std::string& name, ResamplingMethod* method);
const char* resamplingMethodName(ResamplingMethod method);
/** @brief Indices of the particles to keep by @p method. */
std::vector<int> resample(const std::vector<double>& weights, ResamplingMethod method, Random& random);

/** @brief When and how the filter skeleton resamples (one policy for every filter). */
struct ResamplingPolicy
{
  ResamplingMethod method = ResamplingMethod::kLowVariance;
  double neff_ratio = 0.5;  ///< [-] resample when Neff < neff_ratio * particles (0: never, 1: at every update)

  /** @brief Empty when valid, else a message naming the bad parameter. */
  std::string validate() const;
};

/** @brief What one weighting step did. */
struct WeightingStep
{
  double neff = 0.0;       ///< effective sample size of the normalised weights, before resampling
  std::size_t best = 0;    ///< the particle of the largest normalised weight, before resampling (first of ties)
  bool resampled = false;
  std::vector<int> keep;   ///< when resampled: new particle n copies old particle keep[n]
};

/**
 * @brief The step every particle filter of the package shares after it has scored its particles: normalises
 * @p log_weights (in place; the normalised weights into @p weights), computes Neff and, when it is below
 * policy.neff_ratio * N, draws the survivors with policy.method; the weights are then uniform again. The caller
 * rebuilds its per-particle state with applyResampling(step.keep). @p before_resampling, when given, runs after
 * the weights are normalised and before any resampling (e.g. to write the scan into the maps of the particles as
 * they were weighed, once per particle rather than once per copy).
 */
WeightingStep weighAndResample(std::vector<double>* log_weights, std::vector<double>* weights,
                               const ResamplingPolicy& policy, Random& random,
                               const std::function<void(const WeightingStep&)>& before_resampling = nullptr);

/**
 * @brief Rebuilds per-particle state after resampling: element n becomes the old element keep[n]. The last copy
 * of an element takes it by move, the others copy it (a copy-on-write map then shares its storage).
 */
template <typename T>
void applyResampling(std::vector<T>* items, const std::vector<int>& keep)
{
  std::vector<int> last_use(items->size(), -1);
  for (std::size_t n = 0; n < keep.size(); ++n)
    last_use[static_cast<std::size_t>(keep[n])] = static_cast<int>(n);
  std::vector<T> next;
  next.reserve(keep.size());
  for (std::size_t n = 0; n < keep.size(); ++n)
  {
    T& src = (*items)[static_cast<std::size_t>(keep[n])];
    if (last_use[static_cast<std::size_t>(keep[n])] == static_cast<int>(n))
      next.push_back(std::move(src));
    else
      next.push_back(src);
  }
  items->swap(next);
}

/** @brief Weighted mean and covariance of particle poses (x, y, heading). */
struct PoseMoments
{
  Pose2 mean;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
};
/**
 * @brief The weighted mean (heading averaged on the circle) and covariance (heading differences wrapped) of
 * @p poses; @p weights need not be normalised. Without positive total weight every pose counts the same.
 */
PoseMoments poseMoments(const std::vector<Pose2>& poses, const std::vector<double>& weights);

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FILTER_PARTICLE_FILTER_H
