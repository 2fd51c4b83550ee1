#include "rbpf_slam/core/fastslam.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>

#include "rbpf_slam/core/trunk_detector.h"

namespace rbpf_slam
{
namespace core
{
namespace
{
constexpr double kNegInf = -std::numeric_limits<double>::infinity();
constexpr double kLog2Pi = 1.8378770664093453;

/** Predicted range-bearing of @p l from the sensor pose @p s, with the Jacobian wrt the landmark. */
Eigen::Vector2d predictObservation(const Eigen::Vector2d& l, const Pose2& s, Eigen::Matrix2d* H)
{
  const double dx = l.x() - s.x, dy = l.y() - s.y;
  const double q = dx * dx + dy * dy;
  const double r = std::sqrt(q);
  *H << dx / r, dy / r, -dy / q, dx / q;
  return Eigen::Vector2d(r, wrapAngle(std::atan2(dy, dx) - s.theta));
}
}  // namespace

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
  if (particles < 1)
    return "particles must be >= 1";
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
  if (!(resample_threshold >= 0.0 && resample_threshold <= 1.0))
    return "resample_threshold must be in [0, 1]";
  if (!(roughening_sigma_xy >= 0.0) || !(roughening_sigma_theta >= 0.0))
    return "roughening sigmas must be >= 0";
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
  }
  next_id_ = 0;
}

void FastSlam::predict(const OdometryIncrement& u)
{
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
                 std::vector<std::size_t>* prefs_begin, std::vector<std::size_t>* next)
{
  std::vector<int>& match = *match_out;
  match.assign(n_obs, -1);
  holder->assign(n_lm, -1);
  next->assign(n_obs, 0);
  prefs->clear();
  prefs_begin->assign(n_obs + 1, 0);
  for (std::size_t i = 0; i < n_obs; ++i)
  {
    const double* row = ll + i * n_lm;
    const std::size_t b = prefs->size();
    (*prefs_begin)[i] = b;
    for (std::size_t j = 0; j < n_lm; ++j)
      if (row[j] > kNegInf)
        prefs->push_back(static_cast<int>(j));
    std::sort(prefs->begin() + static_cast<std::ptrdiff_t>(b), prefs->end(), [row](int a, int c) {
      return row[a] > row[c] || (row[a] == row[c] && a < c);
    });
  }
  (*prefs_begin)[n_obs] = prefs->size();
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
  galeShapley(flat.data(), n_obs, n_lm, &match, &holder, &free, &prefs, &prefs_begin, &next);
  return match;
}

void FastSlam::stableMatchingFlat(const double* ll, std::size_t n_obs, std::size_t n_lm)
{
  Scratch& w = scratch_;
  galeShapley(ll, n_obs, n_lm, &w.match, &w.holder, &w.free, &w.prefs, &w.prefs_begin, &w.next);
}

void FastSlam::updateParticle(Particle* p, const std::vector<LandmarkObservation>& obs, const Pose2& sensor_in_base,
                              FastSlamUpdateStats* stats)
{
  const FastSlamConfig& c = config_;
  Scratch& w = scratch_;
  const Pose2 s = p->pose * sensor_in_base;
  const std::size_t n_obs = obs.size();
  const double margin = 0.5;  // landmarks just outside the scope may still take an observation

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
    w.cand.push_back({ j, z, H });
  }
  const std::size_t n_cand = w.cand.size();

  // Likelihood table (gated); S^-1 and the innovation of each gated pair are kept for the EKF update.
  w.ll.assign(n_obs * n_cand, kNegInf);
  w.Si.resize(n_obs * n_cand);
  w.v.resize(n_obs * n_cand);
  for (std::size_t i = 0; i < n_obs; ++i)
  {
    const Eigen::Matrix2d& R = w.R[i];
    for (std::size_t k = 0; k < n_cand; ++k)
    {
      const Scratch::Candidate& cd = w.cand[k];
      const Landmark& l = p->map[cd.index];
      const Eigen::Matrix2d S = cd.H * l.covariance * cd.H.transpose() + R;
      const Eigen::Vector2d v(obs[i].range - cd.z.x(), wrapAngle(obs[i].bearing - cd.z.y()));
      const Eigen::Matrix2d Si = S.inverse();
      const double d2 = v.dot(Si * v);
      if (!(d2 < c.association_gate))
        continue;
      double value = -0.5 * d2 - kLog2Pi - 0.5 * std::log(S.determinant());
      if (c.use_radius && obs[i].radius_variance > 0.0 && l.radius_variance > 0.0)
      {
        const double var = obs[i].radius_variance + l.radius_variance + c.radius_sigma_floor * c.radius_sigma_floor;
        const double dr = obs[i].radius - l.radius;
        if (dr * dr / var > c.association_gate)
          continue;
        value += -0.5 * dr * dr / var - 0.5 * std::log(2.0 * M_PI * var);
      }
      const std::size_t ik = i * n_cand + k;
      w.ll[ik] = value;
      w.Si[ik] = Si;
      w.v[ik] = v;
    }
  }
  stableMatchingFlat(w.ll.data(), n_obs, n_cand);

  w.seen.assign(n_cand, 0);
  double log_w = 0.0;
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
    bool gated = false;
    for (std::size_t k2 = 0; k2 < n_cand && !gated; ++k2)
      gated = row[k2] > kNegInf;
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
      continue;
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
  p->log_weight += log_w;
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
  for (std::size_t i = 0; i < particles_.size(); ++i)
    updateParticle(&particles_[i], observations, sensor, i == best_before ? &stats : nullptr);

  std::vector<double> log_w(particles_.size());
  for (std::size_t i = 0; i < particles_.size(); ++i)
    log_w[i] = particles_[i].log_weight;
  normalizeLogWeights(&log_w, &weights_);
  for (std::size_t i = 0; i < particles_.size(); ++i)
    particles_[i].log_weight = log_w[i];
  stats.neff = effectiveSampleSize(weights_);
  if (stats.neff < config_.resample_threshold * static_cast<double>(particles_.size()))
  {
    const std::vector<int> keep = lowVarianceResample(weights_, random_);
    // The last copy of a particle takes its map by move; the others share its chunks (copy-on-write).
    std::vector<int> last_use(particles_.size(), -1);
    for (std::size_t n = 0; n < keep.size(); ++n)
      last_use[static_cast<std::size_t>(keep[n])] = static_cast<int>(n);
    std::vector<Particle> next;
    next.reserve(particles_.size());
    for (std::size_t n = 0; n < keep.size(); ++n)
    {
      Particle& src = particles_[static_cast<std::size_t>(keep[n])];
      if (last_use[static_cast<std::size_t>(keep[n])] == static_cast<int>(n))
        next.push_back(std::move(src));
      else
        next.push_back(src);
    }
    particles_.swap(next);
    const double uniform = -std::log(static_cast<double>(particles_.size()));
    for (auto& p : particles_)
    {
      p.log_weight = uniform;
      if (config_.roughening)
      {
        p.pose.x += random_.gaussian(config_.roughening_sigma_xy);
        p.pose.y += random_.gaussian(config_.roughening_sigma_xy);
        p.pose.theta = wrapAngle(p.pose.theta + random_.gaussian(config_.roughening_sigma_theta));
      }
    }
    stats.resampled = true;
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
  double sw = 0.0, x = 0.0, y = 0.0, cs = 0.0, sn = 0.0;
  for (const auto& p : particles_)
  {
    const double w = std::exp(p.log_weight);
    sw += w;
    x += w * p.pose.x;
    y += w * p.pose.y;
    cs += w * std::cos(p.pose.theta);
    sn += w * std::sin(p.pose.theta);
  }
  if (!(sw > 0.0))
    return best().pose;
  return Pose2(x / sw, y / sw, std::atan2(sn, cs));
}

Eigen::Matrix3d FastSlam::poseCovariance() const
{
  const Pose2 m = meanPose();
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  double sw = 0.0;
  for (const auto& p : particles_)
  {
    const double w = std::exp(p.log_weight);
    const Eigen::Vector3d d(p.pose.x - m.x, p.pose.y - m.y, wrapAngle(p.pose.theta - m.theta));
    cov += w * d * d.transpose();
    sw += w;
  }
  return sw > 0.0 ? (cov / sw).eval() : cov;
}

}  // namespace core
}  // namespace rbpf_slam
