#include "rbpf_slam/core/fastslam/data_association.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

namespace rbpf_slam
{
namespace core
{
namespace
{
constexpr double kNegInf = -std::numeric_limits<double>::infinity();
constexpr double kLog2Pi = 1.8378770664093453;  // log(2 pi): a 2D Gaussian's normaliser is -log(2 pi) - log|S| / 2
// The cheap bounds of the gate reject only pairs clearly outside it (rounding cannot change a decision).
constexpr double kGateSafety = 1.0 + 1e-9;
constexpr double kReachSlack = 1e-9;  // [m] widens the range window by rounding's worth, for the same reason

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

void DataAssociation::selectCandidates(const LandmarkMap& map, const Pose2& base, const Pose2& sensor_in_base,
                                       const VisibilityScope& scope, const Eigen::Matrix3d* pose_covariance)
{
  const Pose2 s = base * sensor_in_base;
  // The spatial index returns the landmarks within reach of the sensor (a superset of the scope test below,
  // in ascending index order, as a scan of the map would).
  map.near(Eigen::Vector2d(s.x, s.y), scope.candidateReach(), &near_);
  cand_.clear();
  for (std::size_t j : near_)
  {
    const Landmark& l = map[j];
    Eigen::Matrix2d H;
    const Eigen::Vector2d z = predictRangeBearing(l.mean, s, &H);
    if (!scope.admitsCandidate(z))
      continue;
    Eigen::Matrix2d pose_term = Eigen::Matrix2d::Zero();
    if (pose_covariance)
    {
      const Matrix23d Hx = rangeBearingPoseJacobian(H, base, sensor_in_base);
      pose_term = Hx * *pose_covariance * Hx.transpose();
    }
    Eigen::Matrix2d A = H * l.covariance * H.transpose();
    if (pose_covariance)
      A += pose_term;
    cand_.push_back({ j, z, H, pose_term, A });
  }
}

void DataAssociation::addNamedCandidates(const LandmarkMap& map, const Pose2& base, const Pose2& sensor_in_base,
                                         const std::vector<LandmarkObservation>& obs,
                                         const Eigen::Matrix3d* pose_covariance)
{
  bool any = false;
  for (const LandmarkObservation& o : obs)
    any = any || o.id >= 0;
  if (!any)
    return;
  const Pose2 s = base * sensor_in_base;
  bool added = false;
  for (std::size_t j = 0; j < map.size(); ++j)
  {
    const Landmark& l = map[j];
    if (!l.known_id)
      continue;
    bool named = false;
    for (const LandmarkObservation& o : obs)
      named = named || o.id == l.id;
    if (!named)
      continue;
    bool present = false;
    for (const AssociationCandidate& c : cand_)
      present = present || c.index == j;
    if (present)
      continue;
    Eigen::Matrix2d H;
    const Eigen::Vector2d z = predictRangeBearing(l.mean, s, &H);
    Eigen::Matrix2d pose_term = Eigen::Matrix2d::Zero();
    if (pose_covariance)
    {
      const Matrix23d Hx = rangeBearingPoseJacobian(H, base, sensor_in_base);
      pose_term = Hx * *pose_covariance * Hx.transpose();
    }
    const Eigen::Matrix2d A = H * l.covariance * H.transpose() + pose_term;
    cand_.push_back({ j, z, H, pose_term, A });
    added = true;
  }
  if (added)
    std::sort(cand_.begin(), cand_.end(),
              [](const AssociationCandidate& a, const AssociationCandidate& b) { return a.index < b.index; });
}

void DataAssociation::associate(const LandmarkMap& map, const std::vector<LandmarkObservation>& obs,
                                const std::vector<Eigen::Matrix2d>& R)
{
  const AssociationConfig& c = config_;
  const std::size_t n_obs = obs.size();
  const std::size_t n_cand = cand_.size();
  n_obs_ = n_obs;
  // Likelihood table (gated); S^-1 and the innovation of each gated pair are kept for the EKF update.
  ll_.assign(n_obs * n_cand, kNegInf);
  s_inv_.resize(n_obs * n_cand);
  v_.resize(n_obs * n_cand);
  radius_term_.resize(n_obs * n_cand);
  // Candidates by predicted range: an observation is tested only against those whose range could be inside
  // the gate (|v_r| <= sqrt(gate S_rr) with the largest S_rr), which the bound below would reject anyway.
  by_range_.clear();
  double max_arr = 0.0;
  for (std::size_t k = 0; k < n_cand; ++k)
  {
    by_range_.emplace_back(cand_[k].z.x(), k);
    max_arr = std::max(max_arr, cand_[k].A(0, 0));
  }
  std::sort(by_range_.begin(), by_range_.end());
  prefs_.clear();
  prefs_begin_.assign(n_obs + 1, 0);
  for (std::size_t i = 0; i < n_obs; ++i)
  {
    prefs_begin_[i] = prefs_.size();
    const Eigen::Matrix2d& Ri = R[i];
    if (c.use_known_ids && obs[i].id >= 0)
    {
      // Known association: the candidate of the observation's id, whatever its distance.
      for (std::size_t k = 0; k < n_cand; ++k)
      {
        if (map[cand_[k].index].id != obs[i].id)
          continue;
        const Eigen::Vector2d v(obs[i].range - cand_[k].z.x(), wrapAngle(obs[i].bearing - cand_[k].z.y()));
        const Eigen::Matrix2d S = cand_[k].A + Ri;
        const Eigen::Matrix2d Si = S.inverse();
        const std::size_t ik = i * n_cand + k;
        ll_[ik] = -0.5 * v.dot(Si * v) - kLog2Pi - 0.5 * std::log(S.determinant());
        prefs_.push_back(static_cast<int>(k));
        radius_term_[ik] = 0.0;
        s_inv_[ik] = Si;
        v_[ik] = v;
      }
      continue;
    }
    const double reach = std::sqrt(kGateSafety * c.gate * (max_arr + Ri(0, 0))) * kGateSafety + kReachSlack;
    auto first = std::lower_bound(by_range_.begin(), by_range_.end(), std::make_pair(obs[i].range - reach, std::size_t(0)));
    for (auto it = first; it != by_range_.end() && it->first <= obs[i].range + reach; ++it)
    {
      const std::size_t k = it->second;
      const AssociationCandidate& cd = cand_[k];
      const Landmark& l = map[cd.index];
      // A cheap bound first: v' S^-1 v >= v_i^2 / S_ii for each component (Cauchy-Schwarz), so a pair whose
      // range or bearing alone is outside the gate is outside it (most pairs of a dense stand).
      const double vr = obs[i].range - cd.z.x();
      const double srr = cd.A(0, 0) + Ri(0, 0);
      if (vr * vr > kGateSafety * c.gate * srr)
        continue;
      const Eigen::Vector2d v(vr, wrapAngle(obs[i].bearing - cd.z.y()));
      if (v.y() * v.y() > kGateSafety * c.gate * (cd.A(1, 1) + Ri(1, 1)))
        continue;
      const Eigen::Matrix2d S = cd.A + Ri;
      const Eigen::Matrix2d Si = S.inverse();
      const double d2 = v.dot(Si * v);
      if (!(d2 < c.gate))
        continue;
      double value = -0.5 * d2 - kLog2Pi - 0.5 * std::log(S.determinant());
      double radius_term = 0.0;
      if (c.use_radius && obs[i].radius_variance > 0.0 && l.radius_variance > 0.0)
      {
        const double var = obs[i].radius_variance + l.radius_variance + c.radius_sigma_floor * c.radius_sigma_floor;
        const double dr = obs[i].radius - l.radius;
        if (dr * dr / var > c.gate)
          continue;
        radius_term = -0.5 * dr * dr / var - 0.5 * std::log(2.0 * M_PI * var);
        value += radius_term;
      }
      const std::size_t ik = i * n_cand + k;
      ll_[ik] = value;
      prefs_.push_back(static_cast<int>(k));
      radius_term_[ik] = radius_term;
      s_inv_[ik] = Si;
      v_[ik] = v;
    }
  }
  prefs_begin_[n_obs] = prefs_.size();
  // The table's gated entries were listed while it was filled (prefs_, prefs_begin_).
  galeShapley(ll_.data(), n_obs, n_cand, &match_, &holder_, &free_, &prefs_, &prefs_begin_, &next_, true);
  taken_.assign(n_cand, 0);
  for (std::size_t i = 0; i < n_obs; ++i)
    if (match_[i] >= 0)
      taken_[static_cast<std::size_t>(match_[i])] = 1;
}

void DataAssociation::repredict(const LandmarkMap& map, const Pose2& sensor, const std::vector<LandmarkObservation>& obs,
                                const std::vector<Eigen::Matrix2d>& R, bool rescore)
{
  const std::size_t n_cand = cand_.size();
  for (auto& cd : cand_)
    cd.z = predictRangeBearing(map[cd.index].mean, sensor, &cd.H);
  for (std::size_t i = 0; i < n_obs_; ++i)
  {
    const int k = match_[i];
    if (k < 0)
      continue;
    const std::size_t ik = i * n_cand + static_cast<std::size_t>(k);
    const AssociationCandidate& cd = cand_[static_cast<std::size_t>(k)];
    const Eigen::Matrix2d S = cd.H * map[cd.index].covariance * cd.H.transpose() + R[i];
    s_inv_[ik] = S.inverse();
    v_[ik] = Eigen::Vector2d(obs[i].range - cd.z.x(), wrapAngle(obs[i].bearing - cd.z.y()));
    if (rescore)
      ll_[ik] = -0.5 * v_[ik].dot(s_inv_[ik] * v_[ik]) - kLog2Pi - 0.5 * std::log(S.determinant()) + radius_term_[ik];
  }
}

bool DataAssociation::overlapsCandidate(const LandmarkMap& map, const Eigen::Vector2d& centre, double radius,
                                        double min_gap) const
{
  for (const auto& cd : cand_)
  {
    const Landmark& other = map[cd.index];
    if ((other.mean - centre).norm() < other.radius + radius + min_gap)
      return true;
  }
  return false;
}

std::vector<int> DataAssociation::stableMatching(const std::vector<std::vector<double>>& ll)
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

}  // namespace core
}  // namespace rbpf_slam
