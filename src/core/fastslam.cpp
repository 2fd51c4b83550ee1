#include "rbpf_slam/core/fastslam.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>

#include "rbpf_slam/core/trunk_detector.h"

namespace rbpf_slam
{
namespace core
{
namespace
{
constexpr double kNegInf = -std::numeric_limits<double>::infinity();
constexpr double kLog2Pi = 1.8378770664093453;
// The cheap bound of the gate rejects only pairs clearly outside it (rounding cannot change a decision).
constexpr double kGateSafety = 1.0 + 1e-9;

/** Predicted range-bearing of @p l from the sensor pose @p s, with the Jacobian wrt the landmark. */
Eigen::Vector2d predictObservation(const Eigen::Vector2d& l, const Pose2& s, Eigen::Matrix2d* H)
{
  const double dx = l.x() - s.x, dy = l.y() - s.y;
  const double q = dx * dx + dy * dy;
  const double r = std::sqrt(q);
  *H << dx / r, dy / r, -dy / q, dx / q;
  return Eigen::Vector2d(r, wrapAngle(std::atan2(dy, dx) - s.theta));
}

using Matrix23d = Eigen::Matrix<double, 2, 3>;

/**
 * Jacobian of the range-bearing of a landmark wrt the base pose (x, y, theta), from its Jacobian @p Hm wrt
 * the landmark, with the sensor at @p sensor on base_link: wrt the sensor position it is -Hm, wrt the sensor
 * heading (0, -1), and the sensor moves with the base's heading by its lever arm.
 */
Matrix23d poseJacobian(const Eigen::Matrix2d& Hm, const Pose2& base, const Pose2& sensor)
{
  const double c = std::cos(base.theta), s = std::sin(base.theta);
  const double dsx = -s * sensor.x - c * sensor.y, dsy = c * sensor.x - s * sensor.y;
  Matrix23d Hx;
  Hx.col(0) = -Hm.col(0);
  Hx.col(1) = -Hm.col(1);
  Hx.col(2) = -Hm.col(0) * dsx - Hm.col(1) * dsy + Eigen::Vector2d(0.0, -1.0);
  return Hx;
}

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

void conditionPoseOnLandmark(Pose2* mean, Eigen::Matrix3d* covariance, const Landmark& l, const Eigen::Vector2d& z,
                             const Eigen::Matrix2d& R, const Pose2& sensor)
{
  const Pose2 s = *mean * sensor;
  Eigen::Matrix2d Hm;
  const Eigen::Vector2d zhat = predictObservation(l.mean, s, &Hm);
  const Matrix23d Hx = poseJacobian(Hm, *mean, sensor);
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
  return o;
}

std::string FastSlamConfig::validate() const
{
  if (particles < 1 || particles > kMaxParticles)
    return "particles must be in 1.." + std::to_string(kMaxParticles) + ", not " + std::to_string(particles);
  const std::string m = motion.validate();
  if (!m.empty())
    return "motion: " + m;
  if (!(range_sigma_floor > 0.0) || !(bearing_sigma_floor > 0.0))
    return "range_sigma_floor and bearing_sigma_floor must be > 0";
  if (!(min_range >= 0.0) || !(max_range > min_range))
    return "max_range must be > min_range >= 0";
  if (!(field_of_view > 0.0))
    return "field_of_view must be > 0";
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
  const std::string r = resampling.validate();
  if (!r.empty())
    return r;
  if (!(roughening_sigma_xy >= 0.0) || !(roughening_sigma_theta >= 0.0))
    return "roughening sigmas must be >= 0";
  if (!(mixture_fraction >= 0.0 && mixture_fraction < 1.0))
    return "mixture_fraction must be in [0, 1)";
  return "";
}

FastSlam::FastSlam(const FastSlamConfig& config) : config_(config), random_(config.seed)
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
  }
  next_id_ = 0;
}

void FastSlam::predict(const OdometryIncrement& u)
{
  if (gaussianPose())
  {
    for (auto& p : particles_)
      propagatePoseGaussian(&p.pose, &p.motion_covariance, u, config_.motion);
    return;
  }
  for (auto& p : particles_)
    p.pose = sampleOdometryMotion(p.pose, u, config_.motion, random_);
}

namespace
{
/**
 * Gale-Shapley on a row-major table: observations propose to landmarks in order of decreasing likelihood
 * (ties: lower index first); a landmark keeps the proposer it likes best. The result is stable: no
 * observation and landmark both prefer each other to their match.
 */
void galeShapley(const double* ll, std::size_t n_obs, std::size_t n_lm, std::vector<int>* match_out,
                 std::vector<int>* holder, std::vector<int>* free, std::vector<int>* prefs,
                 std::vector<std::size_t>* prefs_begin, std::vector<std::size_t>* next, bool prefs_filled)
{
  std::vector<int>& match = *match_out;
  match.assign(n_obs, -1);
  holder->assign(n_lm, -1);
  next->assign(n_obs, 0);
  // Each observation's acceptable landmarks (those inside the gate), given or found here, best first.
  if (!prefs_filled)
  {
    prefs->clear();
    prefs_begin->assign(n_obs + 1, 0);
    for (std::size_t i = 0; i < n_obs; ++i)
    {
      (*prefs_begin)[i] = prefs->size();
      for (std::size_t j = 0; j < n_lm; ++j)
        if (ll[i * n_lm + j] > kNegInf)
          prefs->push_back(static_cast<int>(j));
    }
    (*prefs_begin)[n_obs] = prefs->size();
  }
  for (std::size_t i = 0; i < n_obs; ++i)
  {
    const double* row = ll + i * n_lm;
    std::sort(prefs->begin() + static_cast<std::ptrdiff_t>((*prefs_begin)[i]),
              prefs->begin() + static_cast<std::ptrdiff_t>((*prefs_begin)[i + 1]),
              [row](int a, int c) { return row[a] > row[c] || (row[a] == row[c] && a < c); });
  }
  free->clear();
  for (std::size_t i = n_obs; i-- > 0;)
    free->push_back(static_cast<int>(i));
  while (!free->empty())
  {
    const std::size_t i = static_cast<std::size_t>(free->back());
    free->pop_back();
    const std::size_t end = (*prefs_begin)[i + 1];
    std::size_t& n = (*next)[i];
    while ((*prefs_begin)[i] + n < end)
    {
      const int j = (*prefs)[(*prefs_begin)[i] + n++];
      const int h = (*holder)[static_cast<std::size_t>(j)];
      if (h < 0)
      {
        (*holder)[static_cast<std::size_t>(j)] = static_cast<int>(i);
        match[i] = j;
        break;
      }
      if (ll[i * n_lm + static_cast<std::size_t>(j)] > ll[static_cast<std::size_t>(h) * n_lm + static_cast<std::size_t>(j)])
      {
        (*holder)[static_cast<std::size_t>(j)] = static_cast<int>(i);
        match[i] = j;
        match[static_cast<std::size_t>(h)] = -1;
        free->push_back(h);
        break;
      }
    }
  }
}
}  // namespace

void FastSlam::initialize(const Pose2& start, const LandmarkMap& map)
{
  initialize(start);
  for (auto& p : particles_)
    p.map = map;
  for (std::size_t j = 0; j < map.size(); ++j)
    next_id_ = std::max(next_id_, map[j].id + 1);
}

std::vector<int> FastSlam::stableMatching(const std::vector<std::vector<double>>& ll)
{
  const std::size_t n_obs = ll.size();
  const std::size_t n_lm = n_obs ? ll[0].size() : 0;
  std::vector<double> flat;
  flat.reserve(n_obs * n_lm);
  for (const auto& row : ll)
    flat.insert(flat.end(), row.begin(), row.end());
  std::vector<int> match, holder, free, prefs;
  std::vector<std::size_t> prefs_begin, next;
  galeShapley(flat.data(), n_obs, n_lm, &match, &holder, &free, &prefs, &prefs_begin, &next, false);
  return match;
}

void FastSlam::stableMatchingFlat(const double* ll, std::size_t n_obs, std::size_t n_lm)
{
  Scratch& w = scratch_;
  // The table's gated entries were listed while it was filled (scratch_.prefs, prefs_begin).
  galeShapley(ll, n_obs, n_lm, &w.match, &w.holder, &w.free, &w.prefs, &w.prefs_begin, &w.next, true);
}

void FastSlam::updateParticle(Particle* p, const std::vector<LandmarkObservation>& obs, const Pose2& sensor_in_base,
                              FastSlamUpdateStats* stats)
{
  const FastSlamConfig& c = config_;
  Scratch& w = scratch_;
  Pose2 s = p->pose * sensor_in_base;
  const std::size_t n_obs = obs.size();
  const double margin = 0.5;  // landmarks just outside the scope may still take an observation
  const bool gaussian = gaussianPose();

  // Landmarks near the scope, with their predictions: the spatial index returns those within reach of the
  // sensor (a superset of the scope test below, in ascending index order, as a scan of the map would).
  p->map.near(Eigen::Vector2d(s.x, s.y), c.max_range + margin + 1e-6, &w.near);
  w.cand.clear();
  for (std::size_t j : w.near)
  {
    const Landmark& l = p->map[j];
    Eigen::Matrix2d H;
    const Eigen::Vector2d z = predictObservation(l.mean, s, &H);
    if (z.x() < c.min_range - margin || z.x() > c.max_range + margin || std::abs(z.y()) > 0.5 * c.field_of_view + 0.1)
      continue;
    Eigen::Matrix2d pose_term = Eigen::Matrix2d::Zero();
    if (gaussian)
    {
      const Matrix23d Hx = poseJacobian(H, p->pose, sensor_in_base);
      pose_term = Hx * p->motion_covariance * Hx.transpose();
    }
    Eigen::Matrix2d A = H * l.covariance * H.transpose();
    if (gaussian)
      A += pose_term;
    w.cand.push_back({ j, z, H, pose_term, A });
  }
  const std::size_t n_cand = w.cand.size();

  // Likelihood table (gated); S^-1 and the innovation of each gated pair are kept for the EKF update.
  w.ll.assign(n_obs * n_cand, kNegInf);
  w.Si.resize(n_obs * n_cand);
  w.v.resize(n_obs * n_cand);
  if (gaussian)
    w.radius_term.resize(n_obs * n_cand);
  // Candidates by predicted range: an observation is tested only against those whose range could be inside
  // the gate (|v_r| <= sqrt(gate S_rr) with the largest S_rr), which the bound below would reject anyway.
  w.by_range.clear();
  double max_arr = 0.0;
  for (std::size_t k = 0; k < n_cand; ++k)
  {
    w.by_range.emplace_back(w.cand[k].z.x(), k);
    max_arr = std::max(max_arr, w.cand[k].A(0, 0));
  }
  std::sort(w.by_range.begin(), w.by_range.end());
  w.prefs.clear();
  w.prefs_begin.assign(n_obs + 1, 0);
  for (std::size_t i = 0; i < n_obs; ++i)
  {
    w.prefs_begin[i] = w.prefs.size();
    const Eigen::Matrix2d& R = w.R[i];
    const double reach = std::sqrt(kGateSafety * c.association_gate * (max_arr + R(0, 0))) * kGateSafety + 1e-9;
    auto first = std::lower_bound(w.by_range.begin(), w.by_range.end(), std::make_pair(obs[i].range - reach, std::size_t(0)));
    for (auto it = first; it != w.by_range.end() && it->first <= obs[i].range + reach; ++it)
    {
      const std::size_t k = it->second;
      const Scratch::Candidate& cd = w.cand[k];
      const Landmark& l = p->map[cd.index];
      // A cheap bound first: v' S^-1 v >= v_i^2 / S_ii for each component (Cauchy-Schwarz), so a pair whose
      // range or bearing alone is outside the gate is outside it (most pairs of a dense stand).
      const double vr = obs[i].range - cd.z.x();
      const double srr = cd.A(0, 0) + R(0, 0);
      if (vr * vr > kGateSafety * c.association_gate * srr)
        continue;
      const Eigen::Vector2d v(vr, wrapAngle(obs[i].bearing - cd.z.y()));
      if (v.y() * v.y() > kGateSafety * c.association_gate * (cd.A(1, 1) + R(1, 1)))
        continue;
      const Eigen::Matrix2d S = cd.A + R;
      const Eigen::Matrix2d Si = S.inverse();
      const double d2 = v.dot(Si * v);
      if (!(d2 < c.association_gate))
        continue;
      double value = -0.5 * d2 - kLog2Pi - 0.5 * std::log(S.determinant());
      double radius_term = 0.0;
      if (c.use_radius && obs[i].radius_variance > 0.0 && l.radius_variance > 0.0)
      {
        const double var = obs[i].radius_variance + l.radius_variance + c.radius_sigma_floor * c.radius_sigma_floor;
        const double dr = obs[i].radius - l.radius;
        if (dr * dr / var > c.association_gate)
          continue;
        radius_term = -0.5 * dr * dr / var - 0.5 * std::log(2.0 * M_PI * var);
        value += radius_term;
      }
      const std::size_t ik = i * n_cand + k;
      w.ll[ik] = value;
      w.prefs.push_back(static_cast<int>(k));
      if (gaussian)
        w.radius_term[ik] = radius_term;
      w.Si[ik] = Si;
      w.v[ik] = v;
    }
  }
  w.prefs_begin[n_obs] = w.prefs.size();
  stableMatchingFlat(w.ll.data(), n_obs, n_cand);

  double log_w = 0.0;
  double dual_weight = std::numeric_limits<double>::quiet_NaN();
  if (gaussian)
  {
    // Draw the pose, then predict every candidate from it: the maps are updated from the drawn pose.
    bool dual = false;
    double log_prior = 0.0;
    const double correction = drawPose(p, obs, sensor_in_base, &dual, &log_prior);
    scratch_.dual_flags.push_back(dual ? 1 : 0);
    s = p->pose * sensor_in_base;
    for (auto& cd : w.cand)
      cd.z = predictObservation(p->map[cd.index].mean, s, &cd.H);
    const bool mixture = c.mixture_fraction > 0.0;
    if (mixture && c.mixture_balance)
      log_w += correction;
    // Thrun's dual weighting: a dual sample weighs p(x | u), its set being normalised apart (in update()).
    if (dual && !c.mixture_balance)
      dual_weight = log_prior;
    // p(z | x, m) at the drawn pose: the mixture's weights, and those of a FastSLAM 1.0 sample from the
    // Gaussian prior; FastSLAM 2.0 keeps the likelihood under the prior.
    const bool at_drawn_pose = mixture && (c.mixture_balance || c.proposal == PoseProposal::kFastSlam1);
    for (std::size_t i = 0; i < n_obs; ++i)
    {
      const int k = w.match[i];
      if (k < 0)
        continue;
      const std::size_t ik = i * n_cand + static_cast<std::size_t>(k);
      const Scratch::Candidate& cd = w.cand[static_cast<std::size_t>(k)];
      const Eigen::Matrix2d S = cd.H * p->map[cd.index].covariance * cd.H.transpose() + w.R[i];
      w.Si[ik] = S.inverse();
      w.v[ik] = Eigen::Vector2d(obs[i].range - cd.z.x(), wrapAngle(obs[i].bearing - cd.z.y()));
      if (at_drawn_pose)
        w.ll[ik] = -0.5 * w.v[ik].dot(w.Si[ik] * w.v[ik]) - kLog2Pi - 0.5 * std::log(S.determinant()) + w.radius_term[ik];
    }
  }

  w.seen.assign(n_cand, 0);
  for (std::size_t i = 0; i < n_obs; ++i)
  {
    const double* row = w.ll.data() + i * n_cand;
    const int k = w.match[i];
    if (k >= 0)
    {
      const std::size_t ik = i * n_cand + static_cast<std::size_t>(k);
      w.seen[static_cast<std::size_t>(k)] = 1;
      const Eigen::Matrix2d& H = w.cand[static_cast<std::size_t>(k)].H;
      const Eigen::Matrix2d& R = w.R[i];
      const LandmarkObservation& o = obs[i];
      p->map.modify(w.cand[static_cast<std::size_t>(k)].index, [&](Landmark& l) {
        const Eigen::Matrix2d K = l.covariance * H.transpose() * w.Si[ik];
        l.mean += K * w.v[ik];
        // Joseph form keeps the covariance symmetric and positive.
        const Eigen::Matrix2d IKH = Eigen::Matrix2d::Identity() - K * H;
        l.covariance = IKH * l.covariance * IKH.transpose() + K * R * K.transpose();
        if (o.radius_variance > 0.0)
        {
          if (l.radius_variance <= 0.0 || l.observations == 0)
          {
            l.radius = o.radius;
            l.radius_variance = o.radius_variance;
          }
          else
          {
            const double g = l.radius_variance / (l.radius_variance + o.radius_variance);
            l.radius += g * (o.radius - l.radius);
            l.radius_variance *= (1.0 - g);
          }
        }
        ++l.observations;
        l.evidence = std::min(c.evidence_max, l.evidence + c.evidence_hit);
        if (l.observations >= c.confirm_observations)
          l.provisional = false;
      });
      log_w += row[k];
      if (stats)
        ++stats->matched;
      continue;
    }
    // Unmatched: new if no landmark could explain it, else it lost the matching (ignored).
    const bool gated = w.prefs_begin[i + 1] > w.prefs_begin[i];  // some landmark was inside its gate
    if (gated)
    {
      log_w += w.log_new[i];
      if (stats)
        ++stats->ignored;
      continue;
    }
    if (obs[i].range < c.min_range || obs[i].range > c.max_range)
      continue;  // outside the scope: do not start landmarks there
    Landmark l;
    const double a = s.theta + obs[i].bearing;
    l.mean = Eigen::Vector2d(s.x + obs[i].range * std::cos(a), s.y + obs[i].range * std::sin(a));
    // Trunks do not overlap: an observation whose centre lies inside an existing trunk (plus a margin) is
    // that trunk seen badly (e.g. with a heading error at long range), not a new one.
    bool overlaps = false;
    for (const auto& cd : w.cand)
    {
      const Landmark& other = p->map[cd.index];
      overlaps = overlaps || (other.mean - l.mean).norm() < other.radius + obs[i].radius + c.min_trunk_gap;
    }
    if (overlaps)
    {
      log_w += w.log_new[i];
      if (stats)
        ++stats->ignored;
      continue;
    }
    Eigen::Matrix2d G;  // d(landmark) / d(range, bearing)
    G << std::cos(a), -obs[i].range * std::sin(a), std::sin(a), obs[i].range * std::cos(a);
    l.covariance = G * w.R[i] * G.transpose();
    l.radius = obs[i].radius;
    l.radius_variance = std::max(0.0, obs[i].radius_variance);  // 0: the radius is not known yet
    l.observations = 1;
    l.evidence = c.evidence_hit;
    l.provisional = c.confirm_observations > 1;
    l.id = next_id_++;
    p->map.add(l);
    log_w += w.log_new[i];
    if (stats)
      ++stats->created;
  }

  // Misses: landmarks inside the scope, not hidden behind a nearer landmark, that took no observation.
  w.to_delete.clear();
  for (std::size_t k = 0; k < n_cand; ++k)
  {
    if (w.seen[k])
      continue;
    const double r = w.cand[k].z.x(), b = w.cand[k].z.y();
    if (r < c.min_range || r > c.max_range || std::abs(b) > 0.5 * c.field_of_view)
    {
      // Just beyond the scope's far edge (the candidates reach half a metre further): a provisional landmark
      // here is leaving the scope unconfirmed (the sensor moves a few centimetres per update, so none jumps
      // the ring). Landmarks outside the field of view or too near may come back into view as the robot
      // turns or passes: they are kept.
      if (c.drop_unconfirmed_leaving_scope && r > c.max_range && std::abs(b) <= 0.5 * c.field_of_view &&
          p->map[w.cand[k].index].provisional)
        w.to_delete.push_back(w.cand[k].index);
      continue;
    }
    // Hidden: a nearer landmark, clearly in front (not a near-duplicate of this one at almost the same
    // place, which must be missed to be removed), covers its bearing.
    bool hidden = false;
    const double own_radius = p->map[w.cand[k].index].radius;
    for (std::size_t m = 0; m < n_cand && !hidden; ++m)
    {
      const double other_radius = p->map[w.cand[m].index].radius;
      if (m == k || w.cand[m].z.x() >= r - (own_radius + other_radius + 0.1))
        continue;
      const double half = (other_radius + 0.15) / w.cand[m].z.x();
      hidden = std::abs(wrapAngle(w.cand[m].z.y() - b)) < half;
    }
    if (hidden)
      continue;
    bool remove = false;
    p->map.modify(w.cand[k].index, [&](Landmark& l) {
      l.evidence -= c.evidence_miss;
      remove = l.evidence < c.delete_evidence;
    });
    if (remove)
      w.to_delete.push_back(w.cand[k].index);
  }
  std::sort(w.to_delete.rbegin(), w.to_delete.rend());
  for (std::size_t j : w.to_delete)
    p->map.remove(j);
  if (stats)
    stats->deleted += static_cast<int>(w.to_delete.size());
  p->log_weight += std::isnan(dual_weight) ? log_w : dual_weight;
}

double FastSlam::drawPose(Particle* p, const std::vector<LandmarkObservation>& obs, const Pose2& sensor, bool* dual,
                          double* log_prior)
{
  const FastSlamConfig& c = config_;
  Scratch& w = scratch_;
  const Pose2 prior = p->pose;
  const Eigen::Matrix3d prior_cov = p->motion_covariance;
  // A robot at rest has no motion uncertainty to draw from.
  const bool degenerate = !(prior_cov.determinant() > 1e-24);
  Pose2 mu = prior;
  Eigen::Matrix3d cov = prior_cov;
  std::size_t matched = 0;
  for (std::size_t i = 0; i < obs.size(); ++i)
  {
    const int k = w.match[i];
    if (k < 0)
      continue;
    ++matched;
    if (c.proposal == PoseProposal::kFastSlam2 && !degenerate)
      conditionPoseOnLandmark(&mu, &cov, p->map[w.cand[static_cast<std::size_t>(k)].index],
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
    for (int iteration = 0; iteration < 4; ++iteration)
    {
      Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
      Eigen::Vector3d b = Eigen::Vector3d::Zero();
      const Pose2 s = mu_d * sensor;
      for (std::size_t i = 0; i < obs.size(); ++i)
      {
        const int k = w.match[i];
        if (k < 0)
          continue;
        const Landmark& l = p->map[w.cand[static_cast<std::size_t>(k)].index];
        Eigen::Matrix2d Hm;
        const Eigen::Vector2d zhat = predictObservation(l.mean, s, &Hm);
        const Matrix23d Hx = poseJacobian(Hm, mu_d, sensor);
        const Eigen::Matrix2d Qi = (w.R[i] + Hm * l.covariance * Hm.transpose()).inverse();
        const Eigen::Vector2d v(obs[i].range - zhat.x(), wrapAngle(obs[i].bearing - zhat.y()));
        A += Hx.transpose() * Qi * Hx;
        b += Hx.transpose() * Qi * v;
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(A);
      have_dual = eig.eigenvalues().minCoeff() > 1e-9 * eig.eigenvalues().maxCoeff();
      if (!have_dual)
        break;
      cov_d = A.inverse();
      const Eigen::Vector3d d = cov_d * b;
      mu_d = Pose2(mu_d.x + d.x(), mu_d.y + d.y(), wrapAngle(mu_d.theta + d.z()));
    }
    // Observations that cannot pin the pose (a fit far from the prior) give no dual proposal.
    have_dual = have_dual && poseDifference(mu_d, prior).head<2>().norm() < 3.0;
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
  if (!mixture)
    return 0.0;
  // Weight of the mixture: p(x | u) / ((1 - f) q(x) + f q_dual(x)), p(z | x, m) being added by the caller.
  const double log_q = logGaussian(x, mu, cov);
  const double log_mix = have_dual ? logSumExp(std::log(1.0 - c.mixture_fraction) + log_q,
                                                std::log(c.mixture_fraction) + logGaussian(x, mu_d, cov_d))
                                   : log_q;
  if (!std::isfinite(log_mix))
    return 0.0;
  return *log_prior - log_mix;
}

FastSlamUpdateStats FastSlam::update(const std::vector<LandmarkObservation>& observations, const Pose2& sensor)
{
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
    scratch_.log_new[i] = -0.5 * config_.association_gate - kLog2Pi - 0.5 * std::log(R.determinant());
  }
  scratch_.dual_flags.clear();
  for (std::size_t i = 0; i < particles_.size(); ++i)
    updateParticle(&particles_[i], observations, sensor, i == best_before ? &stats : nullptr);
  stats.dual = static_cast<int>(std::count(scratch_.dual_flags.begin(), scratch_.dual_flags.end(), 1));

  std::vector<double> log_w(particles_.size());
  for (std::size_t i = 0; i < particles_.size(); ++i)
    log_w[i] = particles_[i].log_weight;
  if (config_.mixture_fraction > 0.0 && !config_.mixture_balance && scratch_.dual_flags.size() == particles_.size())
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
  const WeightingStep step = weighAndResample(&log_w, &weights_, config_.resampling, random_);
  stats.neff = step.neff;
  stats.resampled = step.resampled;
  if (step.resampled)
    applyResampling(&particles_, step.keep);  // the copies of a particle share its map's chunks (copy-on-write)
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
  return stats;
}

std::size_t FastSlam::bestIndex() const
{
  std::size_t best = 0;
  for (std::size_t i = 1; i < particles_.size(); ++i)
    if (particles_[i].log_weight > particles_[best].log_weight)
      best = i;
  return best;
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

}  // namespace core
}  // namespace rbpf_slam
