#include "rbpf_slam/core/fastslam/fastslam.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>

#include "rbpf_slam/core/fastslam/landmark_ekf.h"
#include "rbpf_slam/core/extraction/trunk_detector.h"

namespace rbpf_slam
{
namespace core
{
namespace
{
constexpr double kNegInf = -std::numeric_limits<double>::infinity();
constexpr double kLog2Pi = 1.8378770664093453;
// Pose draw (FastSLAM 2.0, mixture).
// A motion covariance with a smaller determinant [m^2 m^2 rad^2] is that of a robot at rest: nothing to draw.
constexpr double kRestDeterminant = 1e-24;
// Gauss-Newton iterations of the dual proposal's pose fit, started at the proposal's mean.
constexpr int kDualIterations = 4;
// The fit's information matrix must be this well conditioned (smallest over largest eigenvalue) to pin a pose.
constexpr double kDualMinConditioning = 1e-9;
// [m] A fit further than this from the prior is taken for a wrong association, not a pose.
constexpr double kDualMaxShift = 3.0;
// Health: the positions of the last this many confirmed landmarks the best particle deleted, and how near [m] to
// one of them a new landmark counts as re-created (a trunk is not planted where one was just removed).
constexpr std::size_t kDeletedMemory = 256;
constexpr double kRecreatedDistance = 1.0;

Eigen::Vector3d poseDifference(const Pose2& a, const Pose2& b)
{
  return Eigen::Vector3d(a.x - b.x, a.y - b.y, wrapAngle(a.theta - b.theta));
}

/** log N(x; mean, covariance); -inf when the covariance is not positive definite. */
double logGaussian(const Pose2& x, const Pose2& mean, const Eigen::Matrix3d& covariance)
{
  const Eigen::LLT<Eigen::Matrix3d> llt(covariance);
  if (llt.info() != Eigen::Success)
    return kNegInf;
  const Eigen::Vector3d d = poseDifference(x, mean);
  const Eigen::Matrix3d L = llt.matrixL();
  const double log_det = 2.0 * (std::log(L(0, 0)) + std::log(L(1, 1)) + std::log(L(2, 2)));
  return -0.5 * d.dot(llt.solve(d)) - 1.5 * kLog2Pi - 0.5 * log_det;
}

bool hasLandmarkId(const LandmarkMap& map, int id)
{
  for (std::size_t j = 0; j < map.size(); ++j)
    if (map[j].id == id)
      return true;
  return false;
}

double logSumExp(double a, double b)
{
  const double m = std::max(a, b);
  return m == kNegInf ? kNegInf : m + std::log(std::exp(a - m) + std::exp(b - m));
}
}  // namespace

bool parsePoseProposal(const std::string& name, PoseProposal* out)
{
  if (name == "fastslam1")
    *out = PoseProposal::kFastSlam1;
  else if (name == "fastslam2")
    *out = PoseProposal::kFastSlam2;
  else
    return false;
  return true;
}

const char* toString(PoseProposal p)
{
  return p == PoseProposal::kFastSlam2 ? "fastslam2" : "fastslam1";
}

bool parseMotionModel(const std::string& name, MotionModel* out)
{
  if (name == "odometry")
    *out = MotionModel::kOdometry;
  else if (name == "velocity")
    *out = MotionModel::kVelocity;
  else
    return false;
  return true;
}

const char* toString(MotionModel m)
{
  return m == MotionModel::kVelocity ? "velocity" : "odometry";
}

bool parsePoseEstimate(const std::string& name, PoseEstimate* out)
{
  if (name == "mean")
    *out = PoseEstimate::kMean;
  else if (name == "best")
    *out = PoseEstimate::kBest;
  else
    return false;
  return true;
}

const char* toString(PoseEstimate e)
{
  return e == PoseEstimate::kBest ? "best" : "mean";
}

SensorScope FastSlamConfig::configuredScope() const
{
  SensorScope s;
  if (min_range > 0.0)
    s.min_range = min_range;
  if (max_range > 0.0)
    s.max_range = max_range;
  if (field_of_view > 0.0)
  {
    s.fov_min = -0.5 * std::min(field_of_view, 2.0 * M_PI);
    s.fov_max = 0.5 * std::min(field_of_view, 2.0 * M_PI);
  }
  if (detection_probability > 0.0)
    s.detection_probability = detection_probability;
  return s;
}

VisibilityScope FastSlamConfig::fallbackScope()
{
  VisibilityScope s(kFallbackMinRange, kFallbackMaxRange, kFallbackFieldOfView);
  s.detection_probability = kFallbackDetectionProbability;
  return s;
}

void conditionPoseOnLandmark(Pose2* mean, Eigen::Matrix3d* covariance, const Landmark& l, const Eigen::Vector2d& z,
                             const Eigen::Matrix2d& R, const Pose2& sensor)
{
  const Pose2 s = *mean * sensor;
  Eigen::Matrix2d Hm;
  const Eigen::Vector2d zhat = predictRangeBearing(l.mean, s, &Hm);
  const Matrix23d Hx = rangeBearingPoseJacobian(Hm, *mean, sensor);
  const Eigen::Matrix2d Q = R + Hm * l.covariance * Hm.transpose();
  const Eigen::Matrix3d& P = *covariance;
  const Eigen::Matrix<double, 3, 2> K = P * Hx.transpose() * (Hx * P * Hx.transpose() + Q).inverse();
  const Eigen::Vector3d d = K * Eigen::Vector2d(z.x() - zhat.x(), wrapAngle(z.y() - zhat.y()));
  *mean = Pose2(mean->x + d.x(), mean->y + d.y(), wrapAngle(mean->theta + d.z()));
  const Eigen::Matrix3d next = (Eigen::Matrix3d::Identity() - K * Hx) * P;
  *covariance = 0.5 * (next + next.transpose());
}

void propagatePoseGaussian(Pose2* mean, Eigen::Matrix3d* covariance, const OdometryIncrement& u,
                           const OdometryMotionNoise& n)
{
  const OdometryNoiseSigmas s = odometryNoiseSigmas(u, n);
  const double h = mean->theta + u.rot1, ch = std::cos(h), sh = std::sin(h);
  Eigen::Matrix3d F;
  F << 1, 0, -u.trans * sh, 0, 1, u.trans * ch, 0, 0, 1;
  Eigen::Matrix3d V;  // wrt (rot1, trans, rot2)
  V << -u.trans * sh, ch, 0, u.trans * ch, sh, 0, 1, 0, 1;
  const Eigen::Vector3d m(s.rot1 * s.rot1, s.trans * s.trans, s.rot2 * s.rot2);
  *covariance = F * *covariance * F.transpose() + V * m.asDiagonal() * V.transpose();
  *mean = applyOdometry(*mean, u);
}

LandmarkObservation toLandmarkObservation(const TrunkObservation& t)
{
  LandmarkObservation o;
  const double cx = t.center.x(), cy = t.center.y();
  const double q = std::max(1e-12, cx * cx + cy * cy);
  const double r = std::sqrt(q);
  o.range = r;
  o.bearing = std::atan2(cy, cx);
  Eigen::Matrix2d J;
  J << cx / r, cy / r, -cy / q, cx / q;
  o.covariance = J * t.covariance * J.transpose();
  o.radius = t.radius;
  o.radius_variance = t.method == TrunkMethod::kCircle ? t.radius_variance : 0.0;
  o.id = t.id;
  return o;
}

std::string FastSlamConfig::validate() const
{
  if (particles < 1 || particles > kMaxParticles)
    return "particles must be in 1.." + std::to_string(kMaxParticles) + ", not " + std::to_string(particles);
  if (max_trunks_per_sweep < 1 || max_landmarks < 1)
    return "max_trunks_per_sweep and max_landmarks must be >= 1";
  const std::string m = motion.validate();
  if (!m.empty())
    return "motion: " + m;
  if (!(motion_step > 0.0) || !(motion_step_angle > 0.0))
    return "motion_step and motion_step_angle must be > 0";
  if (!(motion_noise_time > 0.0) || !std::isfinite(motion_noise_time))
    return "motion_noise_time must be > 0";
  if (!(range_sigma_floor > 0.0) || !(bearing_sigma_floor > 0.0))
    return "range_sigma_floor and bearing_sigma_floor must be > 0";
  if (!(min_range >= 0.0) || !(max_range >= 0.0) || (max_range > 0.0 && !(max_range > min_range)))
    return "min_range and max_range must be >= 0 (0: the sensor's), max_range > min_range when both are set";
  if (!(field_of_view >= 0.0))
    return "field_of_view must be >= 0 (0: the sensor's)";
  if (!(detection_probability >= 0.0 && detection_probability <= 1.0))
    return "detection_probability must be in [0, 1] (0: the sensor's)";
  if (!(association_gate > 0.0))
    return "association_gate must be > 0";
  if (!(radius_sigma_floor > 0.0))
    return "radius_sigma_floor must be > 0";
  if (!(min_trunk_gap >= 0.0))
    return "min_trunk_gap must be >= 0";
  if (!(evidence_hit > 0.0) || !(evidence_miss >= 0.0) || !(evidence_max > 0.0))
    return "evidence_hit and evidence_max must be > 0, evidence_miss >= 0";
  if (!(delete_evidence < 0.0))
    return "delete_evidence must be < 0";
  if (confirm_observations < 1)
    return "confirm_observations must be >= 1";
  if (!(evidence_view_change >= 0.0) || !std::isfinite(evidence_view_change))
    return "evidence_view_change must be a finite number >= 0";
  const std::string r = resampling.validate();
  if (!r.empty())
    return r;
  if (!(roughening_sigma_xy >= 0.0) || !(roughening_sigma_theta >= 0.0))
    return "roughening sigmas must be >= 0";
  if (!(mixture_fraction >= 0.0 && mixture_fraction < 1.0))
    return "mixture_fraction must be in [0, 1)";
  return "";
}

FastSlam::FastSlam(const FastSlamConfig& config)
  : config_(config)
  , random_(config.seed)
  , scope_(effectiveScope(config.configuredScope(), SensorScope(), FastSlamConfig::fallbackScope()))
  , association_(AssociationConfig{ config.association_gate, config.use_radius, config.radius_sigma_floor,
                                     config.use_known_ids })
  , evidence_(EvidenceConfig{ config.evidence_hit, config.evidence_miss, config.evidence_max, config.delete_evidence,
                              config.confirm_observations, config.drop_unconfirmed_leaving_scope,
                              config.evidence_view_change })
{
  const std::string error = config.validate();
  if (!error.empty())
    throw std::invalid_argument("FastSlam: " + error);
  initialize();
}

void FastSlam::initialize(const Pose2& start)
{
  particles_.assign(static_cast<std::size_t>(config_.particles), Particle());
  for (auto& p : particles_)
  {
    p.pose = start;
    p.log_weight = -std::log(static_cast<double>(config_.particles));
    p.motion_covariance.setZero();
    p.history.reset();
  }
  best_ = 0;
  next_id_ = 0;
  deleted_positions_.clear();
}

void FastSlam::redraw(const Pose2& pose, const Eigen::Matrix3d& covariance, const LandmarkMap& map,
                      const std::vector<Pose2>& path)
{
  if (particles_.empty())
    return;
  Eigen::Matrix3d c = 0.5 * (covariance + covariance.transpose());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(c);
  const Eigen::Matrix3d L =
      eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  HistoryNode<Pose2>::Ptr shared;
  if (config_.keep_history)
    for (std::size_t i = 0; i + 1 < path.size(); ++i)
      shared = std::make_shared<const HistoryNode<Pose2>>(path[i], std::move(shared));
  const double log_w = -std::log(static_cast<double>(particles_.size()));
  for (Particle& p : particles_)
  {
    const Eigen::Vector3d z(random_.gaussian(1.0), random_.gaussian(1.0), random_.gaussian(1.0));
    const Eigen::Vector3d d = L * z;
    p.pose = Pose2(pose.x + d(0), pose.y + d(1), wrapAngle(pose.theta + d(2)));
    p.map = map;
    p.log_weight = log_w;
    p.motion_covariance.setZero();
    p.history = config_.keep_history && !path.empty() ? std::make_shared<const HistoryNode<Pose2>>(p.pose, shared) :
                                                          HistoryNode<Pose2>::Ptr();
  }
  for (std::size_t j = 0; j < map.size(); ++j)
    next_id_ = std::max(next_id_, map[j].id + 1);
  best_ = 0;
}

void FastSlam::predict(const OdometryIncrement& u, double noise_scale)
{
  OdometryMotionNoise noise = config_.motion;
  noise.alpha1 *= noise_scale;
  noise.alpha2 *= noise_scale;
  noise.alpha3 *= noise_scale;
  noise.alpha4 *= noise_scale;
  if (gaussianPose())
  {
    for (auto& p : particles_)
      propagatePoseGaussian(&p.pose, &p.motion_covariance, u, noise);
    return;
  }
  for (auto& p : particles_)
    p.pose = sampleOdometryMotion(p.pose, u, noise, random_);
}

void FastSlam::predictArcs(const std::vector<ArcStep>& block, double noise_scale)
{
  if (block.empty())
    return;
  // FastSLAM 2.0 carries the block's pose as a Gaussian: the block's motion from the origin and the Jacobian of its
  // end in the two draws (central differences), in the block's start frame; the same for every particle.
  Pose2 local;
  Eigen::Matrix<double, 3, 2> J_local;
  if (gaussianPose())
  {
    local = applyVelocityBlock(Pose2(), block, config_.motion, noise_scale, 0.0, 0.0);
    const double h = 1e-3;
    for (int k = 0; k < 2; ++k)
    {
      const Pose2 up = applyVelocityBlock(Pose2(), block, config_.motion, noise_scale, k == 0 ? h : 0.0,
                                          k == 1 ? h : 0.0);
      const Pose2 down = applyVelocityBlock(Pose2(), block, config_.motion, noise_scale, k == 0 ? -h : 0.0,
                                            k == 1 ? -h : 0.0);
      J_local.col(k) = Eigen::Vector3d(up.x - down.x, up.y - down.y, wrapAngle(up.theta - down.theta)) / (2.0 * h);
    }
  }
  for (auto& p : particles_)
  {
    if (gaussianPose())
    {
      // The pose's covariance moves with the block's rigid motion; the draws add theirs, turned into the map frame.
      const Pose2 start = p.pose;
      const Pose2 end = start * local;
      Eigen::Matrix3d F, R = Eigen::Matrix3d::Identity();
      F << 1, 0, -(end.y - start.y), 0, 1, end.x - start.x, 0, 0, 1;
      const double c = std::cos(start.theta), s = std::sin(start.theta);
      R.topLeftCorner<2, 2>() << c, -s, s, c;
      const Eigen::Matrix<double, 3, 2> J = R * J_local;
      p.motion_covariance = F * p.motion_covariance * F.transpose() + J * J.transpose();
      p.pose = end;
      continue;
    }
    p.pose = sampleVelocityBlock(p.pose, block, config_.motion, noise_scale, random_);
  }
}

void FastSlam::initialize(const Pose2& start, const LandmarkMap& map)
{
  initialize(start);
  for (auto& p : particles_)
    p.map = map;
  for (std::size_t j = 0; j < map.size(); ++j)
    next_id_ = std::max(next_id_, map[j].id + 1);
}

void FastSlam::initialize(const std::vector<Pose2>& starts, const LandmarkMap& map, double sigma_xy,
                          double sigma_theta, const std::vector<double>& log_weights)
{
  initialize(starts.empty() ? Pose2() : starts.front(), map);
  if (starts.empty())
    return;
  const bool weighed = log_weights.size() == starts.size() &&
                       std::all_of(log_weights.begin(), log_weights.end(), [](double w) { return std::isfinite(w); });
  std::vector<double> log_w(particles_.size(), 0.0);
  for (std::size_t i = 0; i < particles_.size(); ++i)
  {
    const std::size_t k = i % starts.size();
    const Pose2& s = starts[k];
    particles_[i].pose = Pose2(s.x + random_.gaussian(sigma_xy), s.y + random_.gaussian(sigma_xy),
                               wrapAngle(s.theta + random_.gaussian(sigma_theta)));
    log_w[i] = weighed ? log_weights[k] : 0.0;
  }
  if (!weighed)
    return;  // equal weights, as initialize() set them
  normalizeLogWeights(&log_w, &weights_);
  for (std::size_t i = 0; i < particles_.size(); ++i)
    particles_[i].log_weight = log_w[i];
  best_ = static_cast<std::size_t>(std::max_element(log_w.begin(), log_w.end()) - log_w.begin());
}

namespace
{
Eigen::Vector2d sensorPosition(const Pose2& sensor)
{
  return Eigen::Vector2d(sensor.x, sensor.y);
}
}  // namespace

void FastSlam::updateParticle(Particle* p, const std::vector<LandmarkObservation>& obs, const Pose2& sensor_in_base,
                              FastSlamUpdateStats* stats)
{
  const bool gaussian = gaussianPose();
  // The landmarks the sensor may see from the particle's pose, then which observation each one took.
  const Eigen::Matrix3d gate_covariance = p->motion_covariance;
  association_.selectCandidates(p->map, p->pose, sensor_in_base, scope_, gaussian ? &gate_covariance : nullptr);
  if (config_.use_known_ids)
    association_.addNamedCandidates(p->map, p->pose, sensor_in_base, obs, gaussian ? &gate_covariance : nullptr);
  association_.associate(p->map, obs, scratch_.R);
  double log_w = 0.0;
  double dual_weight = std::numeric_limits<double>::quiet_NaN();
  if (gaussian)
    drawPoseAndRepredict(p, obs, sensor_in_base, &dual_weight);
  // The maps are updated from the drawn pose.
  updateMap(p, obs, p->pose * sensor_in_base, &log_w, stats);
  // A sweep that did not report all it saw misses no landmark.
  const std::size_t deleted =
      !sweep_complete_
          ? 0
          : evidence_.applyMisses(&p->map, association_, scope_, stats ? &deleted_positions_ : nullptr,
                                  sensorPosition(p->pose * sensor_in_base));
  if (stats && deleted_positions_.size() > kDeletedMemory)
    deleted_positions_.erase(deleted_positions_.begin(),
                             deleted_positions_.begin() + static_cast<std::ptrdiff_t>(deleted_positions_.size() - kDeletedMemory));
  if (stats)
    stats->deleted += static_cast<int>(deleted);
  p->log_weight += std::isnan(dual_weight) ? log_w : dual_weight;
}

void FastSlam::drawPoseAndRepredict(Particle* p, const std::vector<LandmarkObservation>& obs,
                                    const Pose2& sensor_in_base, double* dual_weight)
{
  const FastSlamConfig& c = config_;
  bool dual = false;
  double log_prior = 0.0;
  drawPose(p, obs, sensor_in_base, &dual, &log_prior);
  scratch_.dual_flags.push_back(dual ? 1 : 0);
  const bool mixture = c.mixture_fraction > 0.0;
  // p(z | x, m) at the drawn pose: the weights of a FastSLAM 1.0 sample from the Gaussian prior of the mixture;
  // FastSLAM 2.0 keeps the likelihood under the prior.
  const bool at_drawn_pose = mixture && c.proposal == PoseProposal::kFastSlam1;
  association_.repredict(p->map, p->pose * sensor_in_base, obs, scratch_.R, at_drawn_pose);
  // Thrun's dual weighting: a dual sample weighs p(x | u), its set being normalised apart (in update()).
  if (dual)
    *dual_weight = log_prior;
}

void FastSlam::updateMap(Particle* p, const std::vector<LandmarkObservation>& obs, const Pose2& s, double* log_w,
                         FastSlamUpdateStats* stats)
{
  for (std::size_t i = 0; i < obs.size(); ++i)
  {
    const int k = association_.match(i);
    if (k >= 0)
    {
      const std::size_t kc = static_cast<std::size_t>(k);
      const AssociationCandidate& cd = association_.candidates()[kc];
      const Eigen::Matrix2d& s_inv = association_.innovationInverse(i, kc);
      const Eigen::Vector2d& v = association_.innovation(i, kc);
      const Eigen::Matrix2d& R = scratch_.R[i];
      const LandmarkObservation& o = obs[i];
      const bool confirmed = !p->map[cd.index].provisional;
      if (stats)
      {
        // The innovation against all the uncertainty the filter claims: the landmark's, one independent look's
        // noise, and the cloud's spread before the update.
        const Matrix23d Hx = rangeBearingPoseJacobian(cd.H, p->pose, p->pose.inverse() * s);
        const Eigen::Matrix2d S = cd.H * p->map[cd.index].covariance * cd.H.transpose() + R * evidence_share_ +
                                  Hx * cloud_covariance_ * Hx.transpose();
        const Eigen::Vector2d vc(o.range - cd.z.x(), wrapAngle(o.bearing - cd.z.y()));
        if (S.determinant() > 0.0)
        {
          stats->claimed_nis += vc.dot(S.inverse() * vc);
          ++stats->claimed_matches;
        }
      }
      p->map.modify(cd.index, [&](Landmark& l) {
        updateLandmarkPosition(&l, cd.H, s_inv, v, R);
        fuseLandmarkRadius(&l, o);
        evidence_.recordHit(&l, sensorPosition(s));
        if (std::isfinite(clock_))
          l.last_seen = clock_;
      });
      *log_w += confirmed || config_.provisional_weighs ? association_.logLikelihood(i, kc) : scratch_.log_new[i];
      if (stats)
      {
        ++stats->matched;
        stats->innovation_nis += v.dot(s_inv * v);
        if (confirmed)
          ++stats->matched_confirmed;
        const Landmark& matched = p->map[cd.index];
        if (matched.observations > matched.visit_observations)  // seen before this run: a saved map's tree
          ++stats->matched_prior;
      }
      continue;
    }
    // Unmatched: new if no landmark could explain it, else it lost the matching (ignored).
    if (association_.gated(i))
    {
      *log_w += scratch_.log_new[i];
      if (stats)
        ++stats->ignored;
      continue;
    }
    if (!scope_.inRange(obs[i].range))
      continue;  // outside the scope: do not start landmarks there
    const bool known = config_.use_known_ids && obs[i].id >= 0;
    if (known && hasLandmarkId(p->map, obs[i].id))
    {
      // Known, but not among the candidates (predicted outside the scope's margins): not a second landmark.
      *log_w += scratch_.log_new[i];
      if (stats)
        ++stats->ignored;
      continue;
    }
    if (p->map.size() >= static_cast<std::size_t>(config_.max_landmarks))
    {
      // The map is full: the observation explains nothing here (as one that made no landmark).
      *log_w += scratch_.log_new[i];
      if (stats)
        ++stats->map_full;
      continue;
    }
    Landmark l = landmarkFromObservation(obs[i], s, scratch_.R[i]);
    if (!known && association_.overlapsCandidate(p->map, l.mean, obs[i].radius, config_.min_trunk_gap))
    {
      *log_w += scratch_.log_new[i];
      if (stats)
        ++stats->ignored;
      continue;
    }
    evidence_.initialize(&l, sensorPosition(s));
    l.first_seen = l.last_seen = clock_;
    if (known)
    {
      l.id = obs[i].id;
      l.known_id = true;
      next_id_ = std::max(next_id_, l.id + 1);
    }
    else
      l.id = next_id_++;
    if (stats)
    {
      ++stats->created;
      // A new landmark where the map lost one: the map is being rebuilt rather than re-observed.
      for (const Eigen::Vector2d& d : deleted_positions_)
        if ((d - l.mean).norm() < kRecreatedDistance)
        {
          ++stats->recreated;
          break;
        }
    }
    p->map.add(l);
    *log_w += scratch_.log_new[i];
  }
}

void FastSlam::drawPose(Particle* p, const std::vector<LandmarkObservation>& obs, const Pose2& sensor, bool* dual,
                          double* log_prior)
{
  const FastSlamConfig& c = config_;
  const Scratch& w = scratch_;
  const std::vector<AssociationCandidate>& candidates = association_.candidates();
  const Pose2 prior = p->pose;
  const Eigen::Matrix3d prior_cov = p->motion_covariance;
  // A robot at rest has no motion uncertainty to draw from.
  const bool degenerate = !(prior_cov.determinant() > kRestDeterminant);
  Pose2 mu = prior;
  Eigen::Matrix3d cov = prior_cov;
  std::size_t matched = 0;
  for (std::size_t i = 0; i < obs.size(); ++i)
  {
    const int k = association_.match(i);
    if (k < 0)
      continue;
    ++matched;
    if (c.proposal == PoseProposal::kFastSlam2 && !degenerate)
      conditionPoseOnLandmark(&mu, &cov, p->map[candidates[static_cast<std::size_t>(k)].index],
                              Eigen::Vector2d(obs[i].range, obs[i].bearing), w.R[i], sensor);
  }
  const bool mixture = c.mixture_fraction > 0.0 && !degenerate;
  const double u = c.mixture_fraction > 0.0 ? random_.uniform() : 1.0;

  // Dual proposal: the pose that best explains the matched observations alone (Gauss-Newton from mu).
  Pose2 mu_d = mu;
  Eigen::Matrix3d cov_d = Eigen::Matrix3d::Zero();
  bool have_dual = false;
  if (mixture && matched >= 2)
  {
    for (int iteration = 0; iteration < kDualIterations; ++iteration)
    {
      Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
      Eigen::Vector3d b = Eigen::Vector3d::Zero();
      const Pose2 s = mu_d * sensor;
      for (std::size_t i = 0; i < obs.size(); ++i)
      {
        const int k = association_.match(i);
        if (k < 0)
          continue;
        const Landmark& l = p->map[candidates[static_cast<std::size_t>(k)].index];
        Eigen::Matrix2d Hm;
        const Eigen::Vector2d zhat = predictRangeBearing(l.mean, s, &Hm);
        const Matrix23d Hx = rangeBearingPoseJacobian(Hm, mu_d, sensor);
        const Eigen::Matrix2d Qi = (w.R[i] + Hm * l.covariance * Hm.transpose()).inverse();
        const Eigen::Vector2d v(obs[i].range - zhat.x(), wrapAngle(obs[i].bearing - zhat.y()));
        A += Hx.transpose() * Qi * Hx;
        b += Hx.transpose() * Qi * v;
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(A);
      have_dual = eig.eigenvalues().minCoeff() > kDualMinConditioning * eig.eigenvalues().maxCoeff();
      if (!have_dual)
        break;
      cov_d = A.inverse();
      const Eigen::Vector3d d = cov_d * b;
      mu_d = Pose2(mu_d.x + d.x(), mu_d.y + d.y(), wrapAngle(mu_d.theta + d.z()));
    }
    // Observations that cannot pin the pose (a fit far from the prior) give no dual proposal.
    have_dual = have_dual && poseDifference(mu_d, prior).head<2>().norm() < kDualMaxShift;
  }
  *dual = have_dual && u < c.mixture_fraction;

  // Sample from the chosen Gaussian (a symmetric square root copes with a singular covariance).
  const Pose2& m = *dual ? mu_d : mu;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(*dual ? cov_d : cov);
  const Eigen::Vector3d xi(random_.gaussian(), random_.gaussian(), random_.gaussian());
  const Eigen::Vector3d d = eig.eigenvectors() * (eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().cwiseProduct(xi));
  const Pose2 x(m.x + d.x(), m.y + d.y(), wrapAngle(m.theta + d.z()));
  p->pose = x;
  p->motion_covariance.setZero();
  *log_prior = mixture ? logGaussian(x, prior, prior_cov) : 0.0;
}

FastSlamUpdateStats FastSlam::update(const std::vector<LandmarkObservation>& observations, const Pose2& sensor,
                                     const SensorScope& sensor_scope, double evidence_share)
{
  evidence_share_ = evidence_share > 0.0 && evidence_share <= 1.0 ? evidence_share : 1.0;
  scope_ = effectiveScope(config_.configuredScope(), sensor_scope, FastSlamConfig::fallbackScope());
  sweep_complete_ = sensor_scope.complete;
  FastSlamUpdateStats stats;
  stats.observations = static_cast<int>(observations.size());
  const std::size_t best_before = bestIndex();
  // Observation noise with the floor, and the likelihood at the gate (below it, a new landmark explains the
  // observation better): the same for every particle.
  scratch_.R.resize(observations.size());
  scratch_.log_new.resize(observations.size());
  for (std::size_t i = 0; i < observations.size(); ++i)
  {
    Eigen::Matrix2d& R = scratch_.R[i];
    R = observations[i].covariance;
    R(0, 0) += config_.range_sigma_floor * config_.range_sigma_floor;
    R(1, 1) += config_.bearing_sigma_floor * config_.bearing_sigma_floor;
    R /= evidence_share_;
    scratch_.log_new[i] = -0.5 * config_.association_gate - kLog2Pi - 0.5 * std::log(R.determinant());
  }
  scratch_.dual_flags.clear();
  // The cloud's spread before the update (the claimed uncertainty of the health's NIS).
  if (particles_.size() > 1)
  {
    const PoseMoments m = moments();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(m.covariance.topLeftCorner<2, 2>());
    stats.pose_spread = std::sqrt(std::max(0.0, eig.eigenvalues().maxCoeff()));
    cloud_covariance_ = m.covariance;
  }
  for (std::size_t i = 0; i < particles_.size(); ++i)
    updateParticle(&particles_[i], observations, sensor, i == best_before ? &stats : nullptr);
  stats.dual = static_cast<int>(std::count(scratch_.dual_flags.begin(), scratch_.dual_flags.end(), 1));

  std::vector<double> log_w(particles_.size());
  for (std::size_t i = 0; i < particles_.size(); ++i)
    log_w[i] = particles_[i].log_weight;
  if (config_.mixture_fraction > 0.0 && scratch_.dual_flags.size() == particles_.size())
  {
    // Thrun et al.'s dual weighting: the dual and the regular samples are normalised apart and hold the mass
    // f and 1 - f (all of it when the other set is empty).
    double lse[2] = { kNegInf, kNegInf };
    for (std::size_t i = 0; i < log_w.size(); ++i)
      lse[scratch_.dual_flags[i] ? 1 : 0] = logSumExp(lse[scratch_.dual_flags[i] ? 1 : 0], log_w[i]);
    if (lse[1] > kNegInf && lse[0] > kNegInf)
    {
      const double mass[2] = { std::log(1.0 - config_.mixture_fraction), std::log(config_.mixture_fraction) };
      for (std::size_t i = 0; i < log_w.size(); ++i)
      {
        const int set = scratch_.dual_flags[i] ? 1 : 0;
        log_w[i] += mass[set] - lse[set];
      }
    }
  }
  const WeightingStep step = weighAndResample(&log_w, &weights_, config_.resampling, random_,
                                              [this](const WeightingStep&) { weights_before_ = weights_; });
  stats.neff = step.neff;
  stats.resampled = step.resampled;
  best_ = step.best;
  if (step.resampled)
  {
    applyResampling(&particles_, step.keep);  // the copies of a particle share its map's chunks (copy-on-write)
    // The best particle is the first copy of the heaviest survivor (the best itself unless it was not drawn).
    best_ = 0;
    for (std::size_t n = 1; n < step.keep.size(); ++n)
      if (weights_before_[static_cast<std::size_t>(step.keep[n])] >
          weights_before_[static_cast<std::size_t>(step.keep[best_])])
        best_ = n;
  }
  for (std::size_t i = 0; i < particles_.size(); ++i)
  {
    Particle& p = particles_[i];
    p.log_weight = log_w[i];
    if (step.resampled && config_.roughening)
    {
      p.pose.x += random_.gaussian(config_.roughening_sigma_xy);
      p.pose.y += random_.gaussian(config_.roughening_sigma_xy);
      p.pose.theta = wrapAngle(p.pose.theta + random_.gaussian(config_.roughening_sigma_theta));
    }
  }
  if (config_.keep_history)
    for (Particle& p : particles_)
      p.history = std::make_shared<const HistoryNode<Pose2>>(p.pose, std::move(p.history));
  stats.landmarks = static_cast<int>(particles_[best_].map.size());
  const PoseMoments cloud = moments();
  stats.has_cloud = true;
  stats.cloud_mean = Eigen::Vector2d(cloud.mean.x, cloud.mean.y);
  stats.cloud_covariance = cloud.covariance.topLeftCorner<2, 2>();
  return stats;
}

bool insideRegion95(const Eigen::Vector2d& truth, const Eigen::Vector2d& mean, const Eigen::Matrix2d& covariance)
{
  constexpr double kChi2Dof2Quantile95 = 5.991;
  const Eigen::Vector2d d = truth - mean;
  const double det = covariance.determinant();
  if (!(det > 0.0) || !covariance.allFinite())
    return d.norm() == 0.0;
  return d.dot(covariance.inverse() * d) <= kChi2Dof2Quantile95;
}

double FastSlam::weighPosition(const Eigen::Vector2d& position, const Eigen::Matrix2d& covariance,
                               const Eigen::Vector2d& lever)
{
  if (particles_.empty() || !position.allFinite() || !covariance.allFinite() || !lever.allFinite() ||
      !(covariance.determinant() > 0.0))
    return -1.0;
  const Eigen::Matrix2d info = covariance.inverse();
  double lse = kNegInf;
  for (Particle& p : particles_)
  {
    Eigen::Vector2d at;
    p.pose.transformPoint(lever.x(), lever.y(), &at.x(), &at.y());
    const Eigen::Vector2d d = position - at;
    p.log_weight += -0.5 * d.dot(info * d);
    lse = logSumExp(lse, p.log_weight);
  }
  double sum2 = 0.0, best = kNegInf;
  for (std::size_t i = 0; i < particles_.size(); ++i)
  {
    Particle& p = particles_[i];
    p.log_weight -= lse;
    const double w = std::exp(p.log_weight);
    sum2 += w * w;
    if (p.log_weight > best)
    {
      best = p.log_weight;
      best_ = i;
    }
  }
  return 1.0 / (sum2 * static_cast<double>(particles_.size()));
}

std::vector<Pose2> FastSlam::bestHistory() const
{
  std::vector<Pose2> out;
  for (const HistoryNode<Pose2>* n = best().history.get(); n != nullptr; n = n->parent.get())
    out.push_back(n->value);
  std::reverse(out.begin(), out.end());
  return out;
}

Pose2 FastSlam::meanPose() const
{
  return moments().mean;
}

Eigen::Matrix3d FastSlam::poseCovariance() const
{
  return moments().covariance;
}

PoseMoments FastSlam::moments() const
{
  std::vector<Pose2> poses;
  std::vector<double> weights;
  poses.reserve(particles_.size());
  weights.reserve(particles_.size());
  for (const auto& p : particles_)
  {
    poses.push_back(p.pose);
    weights.push_back(std::exp(p.log_weight));
  }
  return poseMoments(poses, weights);
}

void FastSlam::predictAlong(const OdometryBuffer& odometry, double t_from, const Pose2& from_pose, double t_mid,
                            const Pose2& odom_mid)
{
  const FastSlamConfig& fc = config_;
  Pose2 from = from_pose;
  if (fc.motion_model == MotionModel::kVelocity)
  {
    std::vector<ArcStep> block;
    double block_start = t_from;
    odometry.forEachBetween(t_from, t_mid, [&](double t, const Pose2& pose) {
      block.push_back(arcStep(from, pose));
      from = pose;
      if (t - block_start >= fc.motion_noise_time)
      {
        predictArcs(block);
        block.clear();
        block_start = t;
      }
    });
    block.push_back(arcStep(from, odom_mid));
    predictArcs(block, partialStepNoiseScale((t_mid - block_start) / fc.motion_noise_time));
    return;
  }
  odometry.forEachBetween(t_from, t_mid, [&](double, const Pose2& pose) {
    const OdometryIncrement u = decomposeOdometry(from, pose);
    if (u.trans >= fc.motion_step || std::abs(u.rot1) + std::abs(u.rot2) >= fc.motion_step_angle)
    {
      predict(u);
      from = pose;
    }
  });
  const OdometryIncrement u = decomposeOdometry(from, odom_mid);
  predict(u, partialStepNoiseScale(std::max(u.trans / fc.motion_step,
                                                     (std::abs(u.rot1) + std::abs(u.rot2)) / fc.motion_step_angle)));
}

std::vector<Landmark> FastSlam::bestTrees() const
{
  const LandmarkMap& map = best().map;
  std::vector<Landmark> trees;
  trees.reserve(map.size());
  for (std::size_t i = 0; i < map.size(); ++i)
    trees.push_back(map[i]);
  return trees;
}

LandmarkMap priorMap(const std::vector<Landmark>& trees, const FastSlamConfig& config)
{
  if (trees.size() > static_cast<std::size_t>(config.max_landmarks))
    throw std::invalid_argument("the saved map holds " + std::to_string(trees.size()) + " trees, more than max_landmarks (" +
                                std::to_string(config.max_landmarks) + ")");
  LandmarkMap prior;
  for (Landmark l : trees)
  {
    l.evidence = l.provisional ? 0.0 : config.evidence_max;
    // The saved covariance made symmetric and positive semidefinite (negative eigenvalues clipped to 0).
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(0.5 * (l.covariance + l.covariance.transpose()));
    l.covariance = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
    l.visit_radius = NAN;  // this run has not seen it yet
    l.visit_radius_variance = 0.0;
    l.visit_observations = 0;
    prior.add(l);
  }
  return prior;
}

}  // namespace core
}  // namespace rbpf_slam
