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

std::vector<int> FastSlam::stableMatching(const std::vector<std::vector<double>>& ll)
{
  // Observations propose to landmarks in order of decreasing likelihood; a landmark keeps the proposer it
  // likes best. The result is stable: no observation and landmark both prefer each other to their match.
  const std::size_t n_obs = ll.size();
  const std::size_t n_lm = n_obs ? ll[0].size() : 0;
  std::vector<std::vector<int>> prefs(n_obs);
  for (std::size_t i = 0; i < n_obs; ++i)
  {
    for (std::size_t j = 0; j < n_lm; ++j)
      if (ll[i][j] > kNegInf)
        prefs[i].push_back(static_cast<int>(j));
    std::sort(prefs[i].begin(), prefs[i].end(), [&](int a, int b) {
      return ll[i][static_cast<std::size_t>(a)] > ll[i][static_cast<std::size_t>(b)] ||
             (ll[i][static_cast<std::size_t>(a)] == ll[i][static_cast<std::size_t>(b)] && a < b);
    });
  }
  std::vector<int> match(n_obs, -1), holder(n_lm, -1);
  std::vector<std::size_t> next(n_obs, 0);
  std::vector<int> free;
  for (std::size_t i = n_obs; i-- > 0;)
    free.push_back(static_cast<int>(i));
  while (!free.empty())
  {
    const int i = free.back();
    free.pop_back();
    auto& pi = prefs[static_cast<std::size_t>(i)];
    while (next[static_cast<std::size_t>(i)] < pi.size())
    {
      const int j = pi[next[static_cast<std::size_t>(i)]++];
      const int h = holder[static_cast<std::size_t>(j)];
      if (h < 0)
      {
        holder[static_cast<std::size_t>(j)] = i;
        match[static_cast<std::size_t>(i)] = j;
        break;
      }
      if (ll[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] >
          ll[static_cast<std::size_t>(h)][static_cast<std::size_t>(j)])
      {
        holder[static_cast<std::size_t>(j)] = i;
        match[static_cast<std::size_t>(i)] = j;
        match[static_cast<std::size_t>(h)] = -1;
        free.push_back(h);
        break;
      }
    }
  }
  return match;
}

void FastSlam::updateParticle(Particle* p, const std::vector<LandmarkObservation>& obs, const Pose2& sensor_in_base,
                              FastSlamUpdateStats* stats)
{
  const FastSlamConfig& c = config_;
  const Pose2 s = p->pose * sensor_in_base;
  const std::size_t n_obs = obs.size();
  const double margin = 0.5;  // landmarks just outside the scope may still take an observation

  // Landmarks near the scope, with their predictions.
  struct Candidate
  {
    std::size_t index;
    Eigen::Vector2d z;
    Eigen::Matrix2d H;
  };
  std::vector<Candidate> cand;
  for (std::size_t j = 0; j < p->map.size(); ++j)
  {
    const Landmark& l = p->map[j];
    Eigen::Matrix2d H;
    const Eigen::Vector2d z = predictObservation(l.mean, s, &H);
    if (z.x() < c.min_range - margin || z.x() > c.max_range + margin || std::abs(z.y()) > 0.5 * c.field_of_view + 0.1)
      continue;
    cand.push_back({ j, z, H });
  }

  // Observation noise with the floor; likelihood table (gated).
  std::vector<Eigen::Matrix2d> R(n_obs);
  std::vector<std::vector<double>> ll(n_obs, std::vector<double>(cand.size(), kNegInf));
  std::vector<double> log_new(n_obs);
  for (std::size_t i = 0; i < n_obs; ++i)
  {
    R[i] = obs[i].covariance;
    R[i](0, 0) += c.range_sigma_floor * c.range_sigma_floor;
    R[i](1, 1) += c.bearing_sigma_floor * c.bearing_sigma_floor;
    // The likelihood of an observation at the gate: below it, a new landmark explains the observation better.
    log_new[i] = -0.5 * c.association_gate - kLog2Pi - 0.5 * std::log(R[i].determinant());
    for (std::size_t k = 0; k < cand.size(); ++k)
    {
      const Landmark& l = p->map[cand[k].index];
      const Eigen::Matrix2d S = cand[k].H * l.covariance * cand[k].H.transpose() + R[i];
      Eigen::Vector2d v(obs[i].range - cand[k].z.x(), wrapAngle(obs[i].bearing - cand[k].z.y()));
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
      ll[i][k] = value;
    }
  }
  const std::vector<int> match = stableMatching(ll);

  std::vector<bool> seen(cand.size(), false);
  double log_w = 0.0;
  for (std::size_t i = 0; i < n_obs; ++i)
  {
    const int k = match[i];
    if (k >= 0)
    {
      seen[static_cast<std::size_t>(k)] = true;
      Landmark& l = p->map.mutableAt(cand[static_cast<std::size_t>(k)].index);
      const Eigen::Matrix2d& H = cand[static_cast<std::size_t>(k)].H;
      const Eigen::Matrix2d S = H * l.covariance * H.transpose() + R[i];
      const Eigen::Vector2d v(obs[i].range - cand[static_cast<std::size_t>(k)].z.x(),
                              wrapAngle(obs[i].bearing - cand[static_cast<std::size_t>(k)].z.y()));
      const Eigen::Matrix2d K = l.covariance * H.transpose() * S.inverse();
      l.mean += K * v;
      // Joseph form keeps the covariance symmetric and positive.
      const Eigen::Matrix2d IKH = Eigen::Matrix2d::Identity() - K * H;
      l.covariance = IKH * l.covariance * IKH.transpose() + K * R[i] * K.transpose();
      if (obs[i].radius_variance > 0.0)
      {
        if (l.radius_variance <= 0.0 || l.observations == 0)
        {
          l.radius = obs[i].radius;
          l.radius_variance = obs[i].radius_variance;
        }
        else
        {
          const double w = l.radius_variance / (l.radius_variance + obs[i].radius_variance);
          l.radius += w * (obs[i].radius - l.radius);
          l.radius_variance *= (1.0 - w);
        }
      }
      ++l.observations;
      l.evidence = std::min(c.evidence_max, l.evidence + c.evidence_hit);
      if (l.observations >= c.confirm_observations)
        l.provisional = false;
      log_w += ll[i][static_cast<std::size_t>(k)];
      if (stats)
        ++stats->matched;
      continue;
    }
    // Unmatched: new if no landmark could explain it, else it lost the matching (ignored).
    bool gated = false;
    for (double v : ll[i])
      gated = gated || v > kNegInf;
    if (gated)
    {
      log_w += log_new[i];
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
    for (const auto& cd : cand)
    {
      const Landmark& other = p->map[cd.index];
      overlaps = overlaps || (other.mean - l.mean).norm() < other.radius + obs[i].radius + c.min_trunk_gap;
    }
    if (overlaps)
    {
      log_w += log_new[i];
      if (stats)
        ++stats->ignored;
      continue;
    }
    Eigen::Matrix2d G;  // d(landmark) / d(range, bearing)
    G << std::cos(a), -obs[i].range * std::sin(a), std::sin(a), obs[i].range * std::cos(a);
    l.covariance = G * R[i] * G.transpose();
    l.radius = obs[i].radius;
    l.radius_variance = std::max(0.0, obs[i].radius_variance);  // 0: the radius is not known yet
    l.observations = 1;
    l.evidence = c.evidence_hit;
    l.provisional = c.confirm_observations > 1;
    l.id = next_id_++;
    p->map.add(l);
    log_w += log_new[i];
    if (stats)
      ++stats->created;
  }

  // Misses: landmarks inside the scope, not hidden behind a nearer landmark, that took no observation.
  std::vector<std::size_t> to_delete;
  for (std::size_t k = 0; k < cand.size(); ++k)
  {
    if (seen[k])
      continue;
    const double r = cand[k].z.x(), b = cand[k].z.y();
    if (r < c.min_range || r > c.max_range || std::abs(b) > 0.5 * c.field_of_view)
      continue;
    // Hidden: a nearer landmark, clearly in front (not a near-duplicate of this one at almost the same
    // place, which must be missed to be removed), covers its bearing.
    bool hidden = false;
    const double own_radius = p->map[cand[k].index].radius;
    for (std::size_t m = 0; m < cand.size() && !hidden; ++m)
    {
      const double other_radius = p->map[cand[m].index].radius;
      if (m == k || cand[m].z.x() >= r - (own_radius + other_radius + 0.1))
        continue;
      const double half = (other_radius + 0.15) / cand[m].z.x();
      hidden = std::abs(wrapAngle(cand[m].z.y() - b)) < half;
    }
    if (hidden)
      continue;
    Landmark& l = p->map.mutableAt(cand[k].index);
    l.evidence -= c.evidence_miss;
    if (l.evidence < c.delete_evidence)
      to_delete.push_back(cand[k].index);
  }
  std::sort(to_delete.rbegin(), to_delete.rend());
  for (std::size_t j : to_delete)
    p->map.remove(j);
  if (stats)
    stats->deleted += static_cast<int>(to_delete.size());
  p->log_weight += log_w;
}

FastSlamUpdateStats FastSlam::update(const std::vector<LandmarkObservation>& observations, const Pose2& sensor)
{
  FastSlamUpdateStats stats;
  stats.observations = static_cast<int>(observations.size());
  const std::size_t best_before = bestIndex();
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
    std::vector<Particle> next;
    next.reserve(particles_.size());
    for (int k : keep)
      next.push_back(particles_[static_cast<std::size_t>(k)]);  // maps are shared, not copied
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
