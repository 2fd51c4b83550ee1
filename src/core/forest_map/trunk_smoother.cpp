#include "rbpf_slam/core/forest_map/trunk_smoother.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <unordered_map>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <ceres/ceres.h>

#include "rbpf_slam/core/filter/cell_key.h"

namespace rbpf_slam
{
namespace core
{
namespace
{
/** @brief Upper-triangular U with U^T U = the inverse of @p covariance: the whitening of a residual. */
template <int N>
Eigen::Matrix<double, N, N> sqrtInformation(const Eigen::Matrix<double, N, N>& covariance)
{
  const Eigen::Matrix<double, N, N> info = covariance.inverse();
  return Eigen::LLT<Eigen::Matrix<double, N, N>>(0.5 * (info + info.transpose())).matrixU();
}

template <typename T>
T wrap(const T& a)
{
  using std::atan2;
  using std::cos;
  using std::sin;
  return atan2(sin(a), cos(a));
}

/** @brief Odometry factor: the increment from keyframe a to keyframe b in a's frame against the odometry's. */
struct OdometryFactor
{
  Eigen::Vector3d delta;
  Eigen::Matrix3d whiten;
  template <typename T>
  bool operator()(const T* a, const T* b, T* residual) const
  {
    using std::cos;
    using std::sin;
    const T dx = b[0] - a[0], dy = b[1] - a[1];
    const T c = cos(a[2]), s = sin(a[2]);
    Eigen::Matrix<T, 3, 1> e;
    e(0) = c * dx + s * dy - T(delta(0));
    e(1) = -s * dx + c * dy - T(delta(1));
    e(2) = wrap(T(b[2] - a[2] - T(delta(2))));
    const Eigen::Matrix<T, 3, 1> w = whiten.cast<T>() * e;
    for (int i = 0; i < 3; ++i)
      residual[i] = w(i);
    return true;
  }
};

/** @brief A tree seen from a keyframe: its position in the keyframe's base_link frame against the observed one
 * (the keyframe's observations of the tree fused). */
struct PointFactor
{
  Eigen::Vector2d z;
  Eigen::Matrix2d whiten;
  template <typename T>
  bool operator()(const T* pose, const T* tree, T* residual) const
  {
    using std::cos;
    using std::sin;
    const T c = cos(pose[2]), s = sin(pose[2]);
    const T dx = tree[0] - pose[0], dy = tree[1] - pose[1];
    Eigen::Matrix<T, 2, 1> e;
    e(0) = c * dx + s * dy - T(z(0));
    e(1) = -s * dx + c * dy - T(z(1));
    const Eigen::Matrix<T, 2, 1> w = whiten.cast<T>() * e;
    residual[0] = w(0);
    residual[1] = w(1);
    return true;
  }
};

/** @brief Identity factor: two trees that a loop shows to be one. */
struct IdentityFactor
{
  Eigen::Matrix2d whiten;
  template <typename T>
  bool operator()(const T* a, const T* b, T* residual) const
  {
    const Eigen::Matrix<T, 2, 1> e(a[0] - b[0], a[1] - b[1]);
    const Eigen::Matrix<T, 2, 1> w = whiten.cast<T>() * e;
    residual[0] = w(0);
    residual[1] = w(1);
    return true;
  }
};

/** @brief The regularized lower incomplete gamma function P(a, x): its series below a + 1, else one minus the
 * continued fraction of Q (Lentz's method). */
double gammaP(double a, double x)
{
  if (!(x > 0.0))
    return 0.0;
  const double log_front = a * std::log(x) - x - std::lgamma(a);
  if (x < a + 1.0)
  {
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < 1000 && std::abs(term) > 1e-15 * std::abs(sum); ++n)
    {
      term *= x / (a + n);
      sum += term;
    }
    return sum * std::exp(log_front);
  }
  const double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 1000; ++i)
  {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    d = std::abs(d) < tiny ? tiny : d;
    c = b + an / c;
    c = std::abs(c) < tiny ? tiny : c;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < 1e-15)
      break;
  }
  return 1.0 - std::exp(log_front) * h;
}

/** @brief The two trees of an identity as one: information-weighted position, counts and times combined. */
Landmark mergeTrees(const Landmark& recent, const Landmark& old)
{
  Landmark m = old;
  const Eigen::Matrix2d ia = recent.covariance.inverse(), ib = old.covariance.inverse();
  m.covariance = (ia + ib).inverse();
  m.mean = m.covariance * (ia * recent.mean + ib * old.mean);
  if (recent.radius_variance > 0.0 && old.radius_variance > 0.0)
  {
    const double wa = 1.0 / recent.radius_variance, wb = 1.0 / old.radius_variance;
    m.radius = (wa * recent.radius + wb * old.radius) / (wa + wb);
    m.radius_variance = 1.0 / (wa + wb);
  }
  m.evidence = std::max(recent.evidence, old.evidence);
  m.observations = recent.observations + old.observations;
  m.visit_observations = recent.visit_observations + old.visit_observations;
  m.provisional = recent.provisional && old.provisional;
  m.known_id = recent.known_id || old.known_id;
  m.first_seen = std::fmin(recent.first_seen, old.first_seen);
  m.last_seen = std::fmax(recent.last_seen, old.last_seen);
  m.views = recent.views + old.views;
  if (!(old.last_seen >= recent.last_seen))
  {
    m.view_direction = recent.view_direction;
    m.view_log_range = recent.view_log_range;
  }
  m.seen_range = std::fmax(recent.seen_range, old.seen_range);
  return m;
}

constexpr double kTreeCell = 2.0;  // [m] cells of the trees' grid for the association

/** @brief The trees' indices by the cell (kTreeCell) their mean lies in. */
using TreeGrid = std::unordered_map<long long, std::vector<std::size_t>>;

long long treeCellKey(double x, double y)
{
  return packCell(static_cast<std::int64_t>(std::floor(x / kTreeCell)),
                  static_cast<std::int64_t>(std::floor(y / kTreeCell)));
}

/** @brief The tree of @p grid nearest to the point @p p of covariance @p C (Mahalanobis, below @p gate), or -1. */
long nearestTree(const TreeGrid& grid, const std::vector<Landmark>& trees, const Eigen::Vector2d& p,
                 const Eigen::Matrix2d& C, double gate)
{
  double best = gate;
  long best_j = -1;
  const long cx = static_cast<long>(std::floor(p.x() / kTreeCell));
  const long cy = static_cast<long>(std::floor(p.y() / kTreeCell));
  for (long ix = cx - 1; ix <= cx + 1; ++ix)
    for (long iy = cy - 1; iy <= cy + 1; ++iy)
    {
      const auto it = grid.find(treeCellKey((ix + 0.5) * kTreeCell, (iy + 0.5) * kTreeCell));
      if (it == grid.end())
        continue;
      for (std::size_t j : it->second)
      {
        const Eigen::Vector2d e = p - trees[j].mean;
        const double d2 = e.dot((C + trees[j].covariance).ldlt().solve(e));
        if (d2 < best)
        {
          best = d2;
          best_j = static_cast<long>(j);
        }
      }
    }
  return best_j;
}

ceres::Solver::Options solverOptions(int max_iterations)
{
  ceres::Solver::Options options;
  // Sparse Cholesky of the whole normal equations: faster here than eliminating the trees first (the path is a
  // chain, and most trees are seen from a few keyframes), with the same solution.
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.num_threads = 1;
  // The solve's work is bounded by its iterations (and the graph's size by max_factors), never by a clock: the
  // same run gives the same answer on any computer, however busy.
  options.max_num_iterations = max_iterations;
  options.max_solver_time_in_seconds = 1e9;
  // Converged when an iteration changes the cost by less than 1e-4 of it: by then the path moves by millimetres.
  options.function_tolerance = 1e-4;
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;
  return options;
}

/** @brief Whether the solve ended without converging (then why, in @p out's reason). */
bool solverFailed(const ceres::Solver::Summary& summary, int max_iterations, SmoothedRun* out)
{
  if (summary.termination_type == ceres::CONVERGENCE)
    return false;
  out->reason = summary.termination_type == ceres::NO_CONVERGENCE ?
                    "the smoother did not converge in " + std::to_string(max_iterations) + " iterations" :
                    "the smoother failed: " + summary.message;
  return true;
}

/**
 * @brief The marginal covariance of the pose @p last, one of @p blocks (the problem's free parameter blocks, in the
 * order given: it fixes the columns), into @p out: its three columns of the inverse of the information matrix JᵀJ at
 * the solution (the loss applied, as in the solve), from one sparse Cholesky factorisation. That costs about one
 * iteration of the solve, where Ceres's own covariance (a sparse QR) took up to three times the whole minimisation
 * on the graphs of a plantation; the two agree to 1e-12.
 */
void lastPoseCovariance(ceres::Problem* problem, const std::vector<double*>& blocks, const double* last,
                        SmoothedRun* out)
{
  std::size_t col = 0, last_col = 0;
  bool found = false;
  for (const double* b : blocks)
  {
    if (b == last)
    {
      last_col = col;
      found = true;
    }
    col += static_cast<std::size_t>(problem->ParameterBlockSize(b));
  }
  if (!found)
    return;
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = blocks;
  ceres::CRSMatrix crs;
  if (!problem->Evaluate(eo, nullptr, nullptr, nullptr, &crs))
    return;
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(crs.values.size());
  for (int r = 0; r < crs.num_rows; ++r)
    for (int i = crs.rows[r]; i < crs.rows[r + 1]; ++i)
      entries.emplace_back(r, crs.cols[i], crs.values[i]);
  Eigen::SparseMatrix<double> J(crs.num_rows, crs.num_cols);
  J.setFromTriplets(entries.begin(), entries.end());
  const Eigen::SparseMatrix<double> H = Eigen::SparseMatrix<double>(J.transpose()) * J;
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> llt(H);
  if (llt.info() != Eigen::Success)
    return;  // not every parameter is determined: no marginal
  Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(crs.num_cols, 3);
  for (int c = 0; c < 3; ++c)
    unit(static_cast<Eigen::Index>(last_col) + c, c) = 1.0;
  const Eigen::MatrixXd columns = llt.solve(unit);
  if (llt.info() != Eigen::Success)
    return;
  const Eigen::Matrix3d c = columns.middleRows<3>(static_cast<Eigen::Index>(last_col));
  out->last_covariance = 0.5 * (c + c.transpose());
  out->has_covariance = out->last_covariance.allFinite();
}
}  // namespace

double chiSquareQuantile(double quantile, int dof)
{
  if (dof <= 0 || !(quantile > 0.0 && quantile < 1.0))
    return 0.0;
  // Bisection on the distribution function P(dof / 2, x / 2).
  double lo = 0.0, hi = dof + 20.0 * std::sqrt(2.0 * dof) + 50.0;
  for (int i = 0; i < 200; ++i)
  {
    const double mid = 0.5 * (lo + hi);
    (gammaP(0.5 * dof, 0.5 * mid) < quantile ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

std::string SmootherConfig::validate() const
{
  if (!(keyframe_distance > 0.0) || !(keyframe_angle > 0.0))
    return "keyframe_distance and keyframe_angle must be > 0";
  if (!(association_gate > 0.0))
    return "association_gate must be > 0";
  if (!(robust_scale > 0.0))
    return "robust_scale must be > 0";
  if (!(loop_sigma > 0.0) || !(loop_radius_share >= 0.0))
    return "loop_sigma must be > 0 and loop_radius_share >= 0";
  if (!(loop_quantile > 0.0 && loop_quantile < 1.0))
    return "loop_quantile must lie in (0, 1)";
  if (max_iterations < 1 || loop_rounds < 1)
    return "max_iterations and loop_rounds must be >= 1";
  if (max_factors < 1)
    return "max_factors must be >= 1";
  if (!(spread_floor_xy >= 0.0) || !(spread_floor_theta >= 0.0))
    return "spread_floor_xy and spread_floor_theta must be >= 0";
  return "";
}

TrunkSmoother::TrunkSmoother(const SmootherConfig& config, const FastSlamConfig& filter)
  : config_(config)
  , motion_(filter.motion)
  , motion_step_(filter.motion_step)
  , motion_step_angle_(filter.motion_step_angle)
  , range_floor_(filter.range_sigma_floor)
  , bearing_floor_(filter.bearing_sigma_floor)
{
}

void TrunkSmoother::add(double stamp, const Pose2& odometry, const Pose2& mount,
                        const std::vector<LandmarkObservation>& observations, double evidence_share)
{
  Record r;
  r.stamp = stamp;
  r.odometry = odometry;
  r.mount = mount;
  r.observations.reserve(observations.size());
  const double share = evidence_share > 0.0 && evidence_share <= 1.0 ? evidence_share : 1.0;
  for (LandmarkObservation o : observations)
  {
    if (!std::isfinite(o.range) || !std::isfinite(o.bearing) || !(o.range > 0.0) || !o.covariance.allFinite())
      continue;
    o.covariance(0, 0) += range_floor_ * range_floor_;
    o.covariance(1, 1) += bearing_floor_ * bearing_floor_;
    o.covariance /= share;
    r.observations.push_back(o);
  }
  records_.push_back(std::move(r));
}

std::size_t TrunkSmoother::thin(const std::vector<Pose2>& path, double before, double pass_gap)
{
  if (path.size() != records_.size())
    return 0;
  // The first visits' updates, by the cell of their pose; oldest first, so that a place keeps its first visit (the
  // one a loop refers to).
  const double cell = config_.keyframe_distance;
  std::unordered_map<std::int64_t, std::vector<std::size_t>> first_visits;
  std::size_t count = 0;
  const Record* last = nullptr;  // the last update that keeps its observations
  for (std::size_t i = 0; i < records_.size() && records_[i].stamp < before; ++i)
  {
    Record& r = records_[i];
    if (r.observations.empty())
      continue;
    const Pose2& p = path[i];
    const long cx = static_cast<long>(std::floor(p.x / cell)), cy = static_cast<long>(std::floor(p.y / cell));
    bool revisit = false;
    for (long ix = cx - 1; ix <= cx + 1 && !revisit; ++ix)
      for (long iy = cy - 1; iy <= cy + 1 && !revisit; ++iy)
      {
        const auto it = first_visits.find(packCell(ix, iy));
        if (it == first_visits.end())
          continue;
        for (std::size_t j : it->second)
          if (r.stamp - records_[j].stamp >= pass_gap && std::hypot(p.x - path[j].x, p.y - path[j].y) < cell &&
              std::abs(wrapAngle(p.theta - path[j].theta)) < config_.keyframe_angle)
          {
            revisit = true;
            break;
          }
      }
    if (!revisit)
    {
      first_visits[packCell(cx, cy)].push_back(i);
      last = &r;
      continue;
    }
    // A revisit keeps one look per keyframe of travel, so that each of its keyframes stays tied to the trees (one
    // with no observation would follow the odometry alone).
    const Pose2 since = last != nullptr ? between(last->odometry, r.odometry) : Pose2();
    if (last == nullptr || std::hypot(since.x, since.y) >= config_.keyframe_distance ||
        std::abs(since.theta) >= config_.keyframe_angle)
    {
      last = &r;
      continue;
    }
    std::vector<LandmarkObservation>().swap(r.observations);  // its memory given back
    ++count;
  }
  thinned_ += count;
  return count;
}

Eigen::Matrix3d TrunkSmoother::odometryCovariance(std::size_t a, std::size_t b) const
{
  Pose2 mean;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t i = a; i < b; ++i)
  {
    const OdometryIncrement u = decomposeOdometry(records_[i].odometry, records_[i + 1].odometry);
    const double steps = std::max(u.trans / motion_step_, (std::abs(u.rot1) + std::abs(u.rot2)) / motion_step_angle_);
    const int k = std::max(1, static_cast<int>(std::ceil(steps - 1e-9)));
    const double scale = partialStepNoiseScale(steps / k);
    OdometryMotionNoise n = motion_;
    n.alpha1 *= scale;
    n.alpha2 *= scale;
    n.alpha3 *= scale;
    n.alpha4 *= scale;
    OdometryIncrement piece;
    piece.rot1 = u.rot1 / k;
    piece.trans = u.trans / k;
    piece.rot2 = u.rot2 / k;
    for (int j = 0; j < k; ++j)
    {
      // A piece of the increment: rot1, then trans, then rot2, each a k-th (a close approximation of the path).
      propagatePoseGaussian(&mean, &cov, piece, n);
    }
  }
  // A floor: a keyframe the odometry did not move from is still not known to the micrometre.
  cov += Eigen::Vector3d(1e-6, 1e-6, 1e-8).asDiagonal();
  return cov;
}

Eigen::Matrix3d TrunkSmoother::driftSince(double stamp, Pose2* odometry_then) const
{
  if (records_.size() < 2)
  {
    *odometry_then = lastOdometry();
    return Eigen::Matrix3d::Zero();
  }
  const auto after = std::upper_bound(records_.begin(), records_.end(), stamp,
                                      [](double t, const Record& r) { return t < r.stamp; });
  const std::size_t a = after == records_.begin() ? 0 : static_cast<std::size_t>(after - records_.begin()) - 1;
  *odometry_then = records_[a].odometry;
  return odometryCovariance(a, records_.size() - 1);
}

// One solve's graph, its members in the order the solve fills them: the keyframes, the parameter blocks (sized
// before the problem, which points into them, and never resized after), the problem and the loop's identities.
struct TrunkSmoother::Graph
{
  explicit Graph(double robust_scale) : cauchy(robust_scale) {}

  std::vector<std::size_t> keyframes;              // the records that are keyframes
  std::vector<std::size_t> keyframe_of;            // each record's keyframe
  // Every parameter block in one buffer, in a fixed order: the keyframes' poses (x, y, theta), then the trees'
  // positions. The marginal covariance takes its columns in that order, and a later round of the same graph starts
  // from the buffer an earlier one ended with.
  std::vector<double> blocks;
  std::size_t tree_offset = 0;
  double* pose(std::size_t k) { return blocks.data() + 3 * k; }
  const double* pose(std::size_t k) const { return blocks.data() + 3 * k; }
  double* tree(std::size_t j) { return blocks.data() + tree_offset + 2 * j; }
  const double* tree(std::size_t j) const { return blocks.data() + tree_offset + 2 * j; }
  std::unordered_map<int, std::size_t> index_of;   // each tree's index by its id
  TreeGrid grid;                                   // the trees by cell, for the association
  std::vector<char> used;                          // the trees an observation ties to the path
  std::optional<ceres::Problem> problem;           // once the parameter blocks are sized
  ceres::CauchyLoss cauchy;                        // the range-bearing factors' loss
  // The loop's identities, and the indices of their two trees.
  std::vector<IdentityFactor> identity_factors;
  std::vector<std::pair<std::size_t, std::size_t>> identity_trees;
  std::vector<std::size_t> identity_of;  // each identity factor's index in the identities given
};

void TrunkSmoother::chooseKeyframes(const std::vector<Pose2>& path, Graph* g) const
{
  const std::size_t n = records_.size();
  // Keyframes: about every keyframe_distance of travel or keyframe_angle of turn.
  g->keyframes = { 0 };
  g->keyframe_of.assign(n, 0);
  for (std::size_t i = 1; i < n; ++i)
  {
    const Pose2 d = between(records_[g->keyframes.back()].odometry, records_[i].odometry);
    if (std::hypot(d.x, d.y) >= config_.keyframe_distance || std::abs(d.theta) >= config_.keyframe_angle)
      g->keyframes.push_back(i);
    g->keyframe_of[i] = g->keyframes.size() - 1;
  }
  g->blocks.clear();
  for (std::size_t k : g->keyframes)
    g->blocks.insert(g->blocks.end(), { path[k].x, path[k].y, path[k].theta });
  g->tree_offset = g->blocks.size();
}

void TrunkSmoother::indexTrees(const std::vector<Landmark>& trees, Graph* g)
{
  // The trees, and a grid of 2 m cells over them for the association.
  for (std::size_t j = 0; j < trees.size(); ++j)
  {
    g->index_of[trees[j].id] = j;
    g->grid[treeCellKey(trees[j].mean.x(), trees[j].mean.y())].push_back(j);
  }
  g->blocks.resize(g->tree_offset);
  for (const Landmark& t : trees)
    g->blocks.insert(g->blocks.end(), { t.mean.x(), t.mean.y() });
  g->used.assign(trees.size(), 0);
}

void TrunkSmoother::addOdometryFactors(Graph* g) const
{
  for (std::size_t k = 0; k + 1 < g->keyframes.size(); ++k)
  {
    const Pose2 d = between(records_[g->keyframes[k]].odometry, records_[g->keyframes[k + 1]].odometry);
    OdometryFactor f{ Eigen::Vector3d(d.x, d.y, d.theta),
                      sqrtInformation<3>(odometryCovariance(g->keyframes[k], g->keyframes[k + 1])) };
    g->problem->AddResidualBlock(new ceres::AutoDiffCostFunction<OdometryFactor, 3, 3, 3>(new OdometryFactor(f)),
                                 nullptr, g->pose(k), g->pose(k + 1));
  }
}

void TrunkSmoother::addObservationFactors(const std::vector<Pose2>& path, const std::vector<Landmark>& trees, Graph* g,
                                          SmoothedRun* out) const
{
  // Observations, each given to the tree it falls on from the particle's own pose, and carried into its keyframe's
  // frame (a point with its covariance); a keyframe's observations of one tree are fused into one factor (their
  // information summed), so that the graph grows with keyframes and trees, not with sweeps.
  struct Fused
  {
    Eigen::Matrix2d information = Eigen::Matrix2d::Zero();
    Eigen::Vector2d weighted = Eigen::Vector2d::Zero();
  };
  std::map<long, Fused> fused;  // by tree index: ordered, so that the graph is built the same way every time
  auto flush = [&](std::size_t k) {
    for (const auto& f : fused)
    {
      const Eigen::Matrix2d cov = f.second.information.inverse();
      PointFactor factor{ cov * f.second.weighted, sqrtInformation<2>(cov) };
      g->problem->AddResidualBlock(new ceres::AutoDiffCostFunction<PointFactor, 2, 3, 2>(new PointFactor(factor)),
                                   &g->cauchy, g->pose(k), g->tree(f.first));
      ++out->factors;
    }
    fused.clear();
  };
  for (std::size_t i = 0; i < records_.size(); ++i)
  {
    const Record& r = records_[i];
    const std::size_t k = g->keyframe_of[i];
    if (i > 0 && k != g->keyframe_of[i - 1])
      flush(g->keyframe_of[i - 1]);
    const Pose2 sensor_in_keyframe = between(records_[g->keyframes[k]].odometry, r.odometry) * r.mount;
    const Pose2 s = path[i] * r.mount;
    for (const LandmarkObservation& o : r.observations)
    {
      const double phi = s.theta + o.bearing, c = std::cos(phi), sn = std::sin(phi);
      const Eigen::Vector2d p(s.x + o.range * c, s.y + o.range * sn);
      Eigen::Matrix2d J;
      J << c, -o.range * sn, sn, o.range * c;
      const Eigen::Matrix2d C = J * o.covariance * J.transpose();
      const long best_j = nearestTree(g->grid, trees, p, C, config_.association_gate);
      if (best_j < 0)
        continue;
      // The point in the keyframe's frame, and its covariance there.
      const double pk = sensor_in_keyframe.theta + o.bearing, ck = std::cos(pk), sk = std::sin(pk);
      const Eigen::Vector2d q(sensor_in_keyframe.x + o.range * ck, sensor_in_keyframe.y + o.range * sk);
      Eigen::Matrix2d Jk;
      Jk << ck, -o.range * sk, sk, o.range * ck;
      const Eigen::Matrix2d info = (Jk * o.covariance * Jk.transpose()).inverse();
      Fused& f = fused[best_j];
      f.information += info;
      f.weighted += info * q;
      g->used[best_j] = 1;
      ++out->observations;
    }
  }
  if (!records_.empty())
    flush(g->keyframe_of.back());
}

void TrunkSmoother::addIdentityFactors(const std::vector<Landmark>& trees,
                                       const std::vector<std::pair<int, int>>& identities, Graph* g) const
{
  // The loop: its trees' identities.
  for (std::size_t i = 0; i < identities.size(); ++i)
  {
    const auto& id = identities[i];
    const auto a = g->index_of.find(id.first), b = g->index_of.find(id.second);
    if (a == g->index_of.end() || b == g->index_of.end() || a->second == b->second || !g->used[a->second] ||
        !g->used[b->second])
      continue;
    // The two trees' covariances, and the fit of a trunk's centre from other sides of its bark: loop_sigma, and a
    // share of the radius (a trunk is no perfect circle).
    const double r = 0.5 * (trees[a->second].radius + trees[b->second].radius) * config_.loop_radius_share;
    const Eigen::Matrix2d cov = trees[a->second].covariance + trees[b->second].covariance +
                                (config_.loop_sigma * config_.loop_sigma + r * r) * Eigen::Matrix2d::Identity();
    IdentityFactor f{ sqrtInformation<2>(cov) };
    g->identity_factors.push_back(f);
    g->identity_trees.emplace_back(a->second, b->second);
    g->identity_of.push_back(i);
    g->problem->AddResidualBlock(new ceres::AutoDiffCostFunction<IdentityFactor, 2, 2, 2>(new IdentityFactor(f)),
                                 nullptr, g->tree(a->second), g->tree(b->second));
  }
}

void TrunkSmoother::storePath(const Graph& g, const std::vector<Pose2>& corrected, SmoothedRun* out) const
{
  const std::size_t n = records_.size();
  out->stamps.resize(n);
  out->poses.resize(n);
  for (std::size_t i = 0; i < n; ++i)
  {
    const std::size_t k = g.keyframe_of[i];
    out->stamps[i] = records_[i].stamp;
    out->poses[i] = corrected[k] * between(records_[g.keyframes[k]].odometry, records_[i].odometry);
  }
}

void TrunkSmoother::storeTrees(const Graph& g, const std::vector<Pose2>& corrected, const std::vector<Pose2>& path,
                               const std::vector<Landmark>& trees, SmoothedRun* out) const
{
  const std::size_t n = records_.size();
  std::vector<Landmark> moved = trees;
  for (std::size_t j = 0; j < trees.size(); ++j)
  {
    if (g.used[j])
    {
      moved[j].mean = Eigen::Vector2d(g.tree(j)[0], g.tree(j)[1]);
      continue;
    }
    // Not tied by an observation kept here: moved with the keyframe of its last sighting.
    std::size_t i = n - 1;
    if (std::isfinite(trees[j].last_seen))
    {
      const auto it = std::lower_bound(records_.begin(), records_.end(), trees[j].last_seen,
                                       [](const Record& r, double t) { return r.stamp < t; });
      i = std::min<std::size_t>(n - 1, static_cast<std::size_t>(it - records_.begin()));
    }
    const std::size_t k = g.keyframe_of[i];
    const Pose2 c = corrected[k] * path[g.keyframes[k]].inverse();
    double x = 0.0, y = 0.0;
    c.transformPoint(trees[j].mean.x(), trees[j].mean.y(), &x, &y);
    moved[j].mean = Eigen::Vector2d(x, y);
    const Eigen::Matrix2d R = Eigen::Rotation2Dd(c.theta).toRotationMatrix();
    moved[j].covariance = R * trees[j].covariance * R.transpose();
  }
  std::vector<char> drop(trees.size(), 0);
  for (const auto& ab : g.identity_trees)
  {
    moved[ab.second] = mergeTrees(moved[ab.first], moved[ab.second]);
    drop[ab.first] = 1;
  }
  for (std::size_t j = 0; j < trees.size(); ++j)
    if (!drop[j])
      out->trees.push_back(moved[j]);
}

SmoothedRun TrunkSmoother::solve(const std::vector<Pose2>& path, const std::vector<Landmark>& trees,
                                 const std::vector<std::pair<int, int>>& identities) const
{
  // A loop's pair that does not fit the others once solved is a look-alike: the worst is dropped and the rest solved
  // again, while more than half of the pairs (and loop_min_trees) remain; at most loop_rounds solves.
  std::vector<std::pair<int, int>> kept = identities;
  SmoothedRun out;
  double seconds = 0.0, seconds_covariance = 0.0;
  int tied = -1;  // the pairs tied to the path in the first solve
  std::vector<double> start;  // each round starts where the one before ended (the same graph, one pair fewer)
  for (int round = 0;; ++round)
  {
    std::vector<double> chi2;
    out = solveOnce(path, trees, kept, &chi2, &start);
    if (tied < 0)
      tied = out.identities;
    seconds += out.seconds;
    seconds_covariance += out.seconds_covariance;
    out.seconds = seconds;
    out.seconds_covariance = seconds_covariance;
    out.identities_dropped = tied - out.identities;
    if (out.ok || out.identities == 0 || !(out.identity_chi2 > out.identity_bound) || round + 1 >= config_.loop_rounds)
      return out;
    // The worst pair, when it lies beyond the quantile on its own (one wrong pair spreads its pull over the others:
    // they are judged again without it).
    std::size_t worst = chi2.size();
    for (std::size_t f = 0; f < chi2.size(); ++f)
      if (std::isfinite(chi2[f]) && (worst == chi2.size() || chi2[f] > chi2[worst]))
        worst = f;
    const std::size_t needed = std::max(static_cast<std::size_t>(std::max(config_.loop_min_trees, 1)),
                                        static_cast<std::size_t>(tied / 2 + 1));
    if (worst == chi2.size() || !(chi2[worst] > chiSquareQuantile(config_.loop_quantile, 2)) ||
        static_cast<std::size_t>(out.identities) - 1 < needed)
      return out;
    std::vector<std::pair<int, int>> fit;
    for (std::size_t f = 0; f < chi2.size(); ++f)
      if (f != worst && std::isfinite(chi2[f]))  // a pair not tied to the path is left out
        fit.push_back(kept[f]);
    kept = std::move(fit);
  }
}

SmoothedRun TrunkSmoother::solveOnce(const std::vector<Pose2>& path, const std::vector<Landmark>& trees,
                                     const std::vector<std::pair<int, int>>& identities,
                                     std::vector<double>* identity_chi2, std::vector<double>* start) const
{
  const auto t0 = std::chrono::steady_clock::now();
  SmoothedRun out;
  const std::size_t n = records_.size();
  if (n < 2 || path.size() != n)
  {
    out.reason = "the path (" + std::to_string(path.size()) + " poses) does not match the " + std::to_string(n) +
                 " updates recorded";
    return out;
  }
  Graph g(config_.robust_scale);
  chooseKeyframes(path, &g);
  out.keyframes = static_cast<int>(g.keyframes.size());
  indexTrees(trees, &g);
  if (start->size() == g.blocks.size())
    g.blocks = *start;  // the buffer is sized; the problem, made below, points into it

  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem& problem = g.problem.emplace(problem_options);
  addOdometryFactors(&g);
  addObservationFactors(path, trees, &g, &out);
  addIdentityFactors(trees, identities, &g);
  out.identities = static_cast<int>(g.identity_factors.size());
  if (!identities.empty() && g.identity_factors.empty())
  {
    out.reason = "none of the loop's trees is tied to the path by an observation";
    return out;
  }
  problem.SetParameterBlockConstant(g.pose(0));
  for (char u : g.used)
    out.trees_solved += u;

  if (out.factors + static_cast<int>(g.keyframes.size()) > config_.max_factors)
  {
    out.reason = "the graph has " + std::to_string(out.factors + static_cast<int>(g.keyframes.size())) +
                 " factors, beyond max_factors " + std::to_string(config_.max_factors);
    return out;
  }
  const ceres::Solver::Options options = solverOptions(config_.max_iterations);
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  *start = g.blocks;
  out.iterations = static_cast<int>(summary.iterations.size());
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (solverFailed(summary, config_.max_iterations, &out))
  {
    out.inconsistent = !g.identity_factors.empty() && summary.termination_type == ceres::NO_CONVERGENCE;
    return out;
  }

  // Consistency: the identities' residuals after the solve (NaN: a pair not tied to the path).
  identity_chi2->assign(identities.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t f = 0; f < g.identity_factors.size(); ++f)
  {
    double r[2];
    g.identity_factors[f](g.tree(g.identity_trees[f].first), g.tree(g.identity_trees[f].second), r);
    out.identity_chi2 += r[0] * r[0] + r[1] * r[1];
    (*identity_chi2)[g.identity_of[f]] = r[0] * r[0] + r[1] * r[1];
  }
  out.identity_bound = chiSquareQuantile(config_.loop_quantile, 2 * out.identities);
  if (out.identities > 0 && out.identity_chi2 > out.identity_bound)
  {
    out.inconsistent = true;
    out.reason = "the loop is inconsistent: its trees' residuals " + std::to_string(out.identity_chi2) +
                 " exceed the chi-square bound " + std::to_string(out.identity_bound);
    return out;
  }

  // The last keyframe's marginal covariance, for the spread of the particles drawn again (only for a result that is
  // applied).
  const auto t_cov = std::chrono::steady_clock::now();
  if (g.keyframes.size() > 1)
  {
    // The free blocks in a fixed order (the keyframes after the first, then the trees in the problem).
    std::vector<double*> free_blocks;
    for (std::size_t k = 1; k < g.keyframes.size(); ++k)
      free_blocks.push_back(g.pose(k));
    for (std::size_t j = 0; j < trees.size(); ++j)
      if (problem.HasParameterBlock(g.tree(j)))
        free_blocks.push_back(g.tree(j));
    lastPoseCovariance(&problem, free_blocks, g.pose(g.keyframes.size() - 1), &out);
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.seconds_covariance = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_cov).count();

  // The path at every update, and the trees.
  std::vector<Pose2> corrected(g.keyframes.size());
  for (std::size_t k = 0; k < g.keyframes.size(); ++k)
    corrected[k] = Pose2(g.pose(k)[0], g.pose(k)[1], wrapAngle(g.pose(k)[2]));
  storePath(g, corrected, &out);
  storeTrees(g, corrected, path, trees, &out);
  out.ok = true;
  return out;
}

}  // namespace core
}  // namespace rbpf_slam
