#include "rbpf_slam/core/filter/particle_filter.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace rbpf_slam
{
namespace core
{
std::string OdometryMotionNoise::validate() const
{
  const auto ok = [](double v) { return std::isfinite(v) && v >= 0.0; };
  if (!ok(alpha1))
    return "alpha1 must be >= 0";
  if (!ok(alpha2))
    return "alpha2 must be >= 0";
  if (!ok(alpha3))
    return "alpha3 must be >= 0";
  if (!ok(alpha4))
    return "alpha4 must be >= 0";
  return "";
}

OdometryIncrement decomposeOdometry(const Pose2& a, const Pose2& b)
{
  OdometryIncrement u;
  const double dx = b.x - a.x, dy = b.y - a.y;
  u.trans = std::hypot(dx, dy);
  // Below 1 cm the direction of travel is noise: treat the motion as a turn on the spot.
  u.rot1 = u.trans < 0.01 ? 0.0 : wrapAngle(std::atan2(dy, dx) - a.theta);
  u.rot2 = wrapAngle(b.theta - a.theta - u.rot1);
  return u;
}

OdometryNoiseSigmas odometryNoiseSigmas(const OdometryIncrement& u, const OdometryMotionNoise& n)
{
  OdometryNoiseSigmas s;
  s.rot1 = n.alpha1 * std::abs(u.rot1) + n.alpha2 * u.trans;
  s.trans = n.alpha3 * u.trans + n.alpha4 * (std::abs(u.rot1) + std::abs(u.rot2));
  s.rot2 = n.alpha1 * std::abs(u.rot2) + n.alpha2 * u.trans;
  return s;
}

Pose2 applyOdometry(const Pose2& pose, const OdometryIncrement& u)
{
  const double heading = pose.theta + u.rot1;
  return Pose2(pose.x + u.trans * std::cos(heading), pose.y + u.trans * std::sin(heading), wrapAngle(heading + u.rot2));
}

Pose2 sampleOdometryMotion(const Pose2& pose, const OdometryIncrement& u, const OdometryMotionNoise& n, Random& random)
{
  const OdometryNoiseSigmas s = odometryNoiseSigmas(u, n);
  OdometryIncrement noisy;
  noisy.rot1 = u.rot1 - random.gaussian(s.rot1);
  noisy.trans = u.trans - random.gaussian(s.trans);
  noisy.rot2 = u.rot2 - random.gaussian(s.rot2);
  return applyOdometry(pose, noisy);
}

double partialStepNoiseScale(double fraction)
{
  return fraction > 0.0 && fraction < 1.0 ? 1.0 / std::sqrt(fraction) : 1.0;
}

Pose2 arcIncrement(double distance, double turn)
{
  // x = d sin(t) / t, y = d (1 - cos t) / t, with their series near t = 0.
  const double t2 = turn * turn;
  const double sinc = std::abs(turn) < 1e-4 ? 1.0 - t2 / 6.0 : std::sin(turn) / turn;
  const double cosc = std::abs(turn) < 1e-4 ? turn / 2.0 - turn * t2 / 24.0 : (1.0 - std::cos(turn)) / turn;
  return Pose2(distance * sinc, distance * cosc, turn);
}

ArcStep arcStep(const Pose2& a, const Pose2& b)
{
  ArcStep s;
  s.delta = a.inverse() * b;
  s.turn = s.delta.theta;
  const double chord = std::hypot(s.delta.x, s.delta.y);
  if (chord < 1e-9)
    return s;
  // A unicycle's arc: its chord is turn / 2 off the start's heading, the arc longer than the chord by
  // (turn / 2) / sin(turn / 2).
  const double half = 0.5 * s.turn;
  const double ratio = std::abs(half) < 1e-4 ? 1.0 + half * half / 6.0 : half / std::sin(half);
  s.distance = (s.delta.x >= 0.0 ? 1.0 : -1.0) * chord * ratio;
  return s;
}

Pose2 applyVelocityBlock(const Pose2& pose, const std::vector<ArcStep>& block, const OdometryMotionNoise& n,
                         double scale, double z_v, double z_w)
{
  Pose2 out = pose;
  for (std::size_t i = 0; i < block.size(); ++i)
  {
    const ArcStep& a = block[i];
    const double d = std::abs(a.distance), t = std::abs(a.turn);
    const double distance = a.distance + z_v * scale * (n.alpha3 * d + n.alpha4 * t);
    const double turn = a.turn + z_w * scale * (n.alpha1 * t + n.alpha2 * d);
    // The odometry's own increment, then the change from its nominal arc to the noisy one (in the arc's end
    // frame): the mean stays the odometry's even where it is not exactly an arc.
    out = out * a.delta * (arcIncrement(a.distance, a.turn).inverse() * arcIncrement(distance, turn));
  }
  out.theta = wrapAngle(out.theta);
  return out;
}

Pose2 sampleVelocityBlock(const Pose2& pose, const std::vector<ArcStep>& block, const OdometryMotionNoise& n,
                          double scale, Random& random)
{
  const double z_v = random.gaussian(1.0);
  const double z_w = random.gaussian(1.0);
  return applyVelocityBlock(pose, block, n, scale, z_v, z_w);
}

double normalizeLogWeights(std::vector<double>* log_weights, std::vector<double>* weights)
{
  weights->resize(log_weights->size());
  if (log_weights->empty())
    return 0.0;
  const double max = *std::max_element(log_weights->begin(), log_weights->end());
  if (!std::isfinite(max))
  {
    // All weights zero (or broken): fall back to uniform rather than NaN.
    std::fill(weights->begin(), weights->end(), 1.0 / static_cast<double>(weights->size()));
    std::fill(log_weights->begin(), log_weights->end(), 0.0);
    return -std::numeric_limits<double>::infinity();
  }
  double sum = 0.0;
  for (std::size_t i = 0; i < log_weights->size(); ++i)
  {
    (*weights)[i] = std::exp((*log_weights)[i] - max);
    sum += (*weights)[i];
  }
  for (std::size_t i = 0; i < weights->size(); ++i)
  {
    (*weights)[i] /= sum;
    (*log_weights)[i] = std::log((*weights)[i]);
  }
  return max + std::log(sum);
}

double effectiveSampleSize(const std::vector<double>& weights)
{
  double s2 = 0.0;
  for (double w : weights)
    s2 += w * w;
  return s2 > 0.0 ? 1.0 / s2 : 0.0;
}

std::vector<int> lowVarianceResample(const std::vector<double>& weights, Random& random)
{
  const std::size_t n = weights.size();
  std::vector<int> out;
  out.reserve(n);
  if (n == 0)
    return out;
  const double step = 1.0 / static_cast<double>(n);
  const double r = random.uniform() * step;
  double c = weights[0];
  std::size_t i = 0;
  for (std::size_t m = 0; m < n; ++m)
  {
    const double u = r + static_cast<double>(m) * step;
    while (u > c && i + 1 < n)
    {
      ++i;
      c += weights[i];
    }
    out.push_back(static_cast<int>(i));
  }
  return out;
}

std::vector<int> multinomialResample(const std::vector<double>& weights, Random& random)
{
  const std::size_t n = weights.size();
  std::vector<double> cdf(n);
  double c = 0.0;
  for (std::size_t i = 0; i < n; ++i)
    cdf[i] = (c += weights[i]);
  std::vector<int> out;
  out.reserve(n);
  for (std::size_t m = 0; m < n; ++m)
  {
    const double u = random.uniform() * c;
    const auto it = std::upper_bound(cdf.begin(), cdf.end(), u);
    out.push_back(static_cast<int>(std::min<std::ptrdiff_t>(it - cdf.begin(), static_cast<std::ptrdiff_t>(n) - 1)));
  }
  return out;
}

bool parseResamplingMethod(const std::string& name, ResamplingMethod* method)
{
  if (name == "low_variance")
    *method = ResamplingMethod::kLowVariance;
  else if (name == "multinomial")
    *method = ResamplingMethod::kMultinomial;
  else
    return false;
  return true;
}

const char* resamplingMethodName(ResamplingMethod method)
{
  return method == ResamplingMethod::kMultinomial ? "multinomial" : "low_variance";
}

std::vector<int> resample(const std::vector<double>& weights, ResamplingMethod method, Random& random)
{
  return method == ResamplingMethod::kMultinomial ? multinomialResample(weights, random)
                                                  : lowVarianceResample(weights, random);
}

std::string ResamplingPolicy::validate() const
{
  if (!(std::isfinite(neff_ratio) && neff_ratio >= 0.0 && neff_ratio <= 1.0))
    return "resample_neff_ratio must be in [0, 1]";
  return "";
}

WeightingStep weighAndResample(std::vector<double>* log_weights, std::vector<double>* weights,
                               const ResamplingPolicy& policy, Random& random,
                               const std::function<void(const WeightingStep&)>& before_resampling)
{
  WeightingStep step;
  normalizeLogWeights(log_weights, weights);
  step.neff = effectiveSampleSize(*weights);
  const std::size_t n = weights->size();
  if (n > 0)
    step.best = static_cast<std::size_t>(std::max_element(weights->begin(), weights->end()) - weights->begin());
  if (before_resampling)
    before_resampling(step);
  if (n == 0 || !(step.neff < policy.neff_ratio * static_cast<double>(n)))
    return step;
  step.keep = resample(*weights, policy.method, random);
  step.resampled = true;
  const double uniform = 1.0 / static_cast<double>(n);
  std::fill(weights->begin(), weights->end(), uniform);
  std::fill(log_weights->begin(), log_weights->end(), -std::log(static_cast<double>(n)));
  return step;
}

PoseMoments poseMoments(const std::vector<Pose2>& poses, const std::vector<double>& weights)
{
  PoseMoments m;
  if (poses.empty())
    return m;
  double sw = 0.0;
  for (std::size_t i = 0; i < poses.size() && i < weights.size(); ++i)
    sw += weights[i] > 0.0 ? weights[i] : 0.0;
  const bool uniform = !(sw > 0.0) || weights.size() != poses.size();
  const auto w = [&](std::size_t i) { return uniform ? 1.0 / poses.size() : std::max(0.0, weights[i]) / sw; };
  double x = 0.0, y = 0.0, c = 0.0, s = 0.0;
  for (std::size_t i = 0; i < poses.size(); ++i)
  {
    x += w(i) * poses[i].x;
    y += w(i) * poses[i].y;
    c += w(i) * std::cos(poses[i].theta);
    s += w(i) * std::sin(poses[i].theta);
  }
  m.mean = Pose2(x, y, std::atan2(s, c));
  for (std::size_t i = 0; i < poses.size(); ++i)
  {
    const Eigen::Vector3d d(poses[i].x - m.mean.x, poses[i].y - m.mean.y, wrapAngle(poses[i].theta - m.mean.theta));
    m.covariance += w(i) * d * d.transpose();
  }
  return m;
}

}  // namespace core
}  // namespace rbpf_slam
