#include "rbpf_slam/core/forest_map/gnss.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

namespace rbpf_slam
{
namespace core
{
std::string gnssFixProblem(const GnssFix& fix, double max_sigma)
{
  if (!fix.valid)
    return "no fix";
  if (!std::isfinite(fix.stamp))
    return "stamp not finite";
  if (!std::isfinite(fix.latitude) || !std::isfinite(fix.longitude) || std::abs(fix.latitude) > 90.0 ||
      std::abs(fix.longitude) > 180.0)
    return "latitude / longitude not finite or out of range";
  if (!fix.covariance.allFinite())
    return "covariance not finite";
  if (std::abs(fix.covariance(0, 1) - fix.covariance(1, 0)) > 1e-6 * (1.0 + fix.covariance.cwiseAbs().maxCoeff()))
    return "covariance not symmetric";
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(fix.covariance);
  if (!(eig.eigenvalues().minCoeff() > 0.0))
    return "covariance not positive definite";
  if (std::sqrt(eig.eigenvalues().maxCoeff()) > max_sigma)
    return "sigma " + std::to_string(std::sqrt(eig.eigenvalues().maxCoeff())) + " m beyond " +
           std::to_string(max_sigma) + " m";
  return "";
}

std::string GnssFusionConfig::validate() const
{
  if (!enabled)
    return "";
  if (!(max_sigma > 0.0) || !std::isfinite(max_sigma))
    return "gps/max_sigma must be a finite number > 0 [m]";
  if (!(sigma_floor > 0.0) || !std::isfinite(sigma_floor))
    return "gps/sigma_floor must be a finite number > 0 [m]";
  if (!(correlation_time > 0.0) || !std::isfinite(correlation_time))
    return "gps/correlation_time must be a finite number > 0 [s]";
  if (!(anchor_min_spread >= 0.0) || !std::isfinite(anchor_min_spread))
    return "gps/anchor_min_spread must be a finite number >= 0 [m]";
  if (anchor_min_fixes < 3)
    return "gps/anchor_min_fixes must be >= 3";
  if (!(weigh_max_anchor_sigma >= 0.0) || !std::isfinite(weigh_max_anchor_sigma))
    return "gps/weigh_max_anchor_sigma must be a finite number >= 0 [m] (0: fixes never weigh the particles)";
  return "";
}

bool GnssConfig::validate(std::string* error) const
{
  auto fail = [&](const std::string& what) {
    if (error)
      *error = "gps: " + what;
    return false;
  };
  if (!enabled)
    return true;
  if (!(rate > 0.0))
    return fail("rate must be > 0");
  if (!(std::abs(origin.latitude) < 90.0) || !(std::abs(origin.longitude) <= 180.0))
    return fail("origin latitude / longitude out of range");
  if (!(open_sigma >= 0.0 && canopy_sigma >= 0.0 && open_bias_sigma >= 0.0 && canopy_bias_sigma >= 0.0))
    return fail("sigmas must be >= 0");
  if (!(open_sigma > 0.0 || open_bias_sigma > 0.0) || !(canopy_sigma > 0.0 || canopy_bias_sigma > 0.0))
    return fail("a receiver has some noise: a sigma must be > 0");
  if (!(bias_time > 0.0) || !(canopy_radius > 0.0) || !(crown_ratio >= 0.0) || !(vertical_factor > 0.0))
    return fail("bias_time, canopy_radius and vertical_factor must be > 0, crown_ratio >= 0");
  if (!(outage_interval >= 0.0) || !(outage_duration >= 0.0))
    return fail("outage_interval and outage_duration must be >= 0");
  if (!antenna.allFinite())
    return fail("antenna position not finite");
  return true;
}

GnssReceiver::GnssReceiver(const GnssConfig& config, std::uint64_t seed)
  : config_(config), random_(seed), plane_(config.origin)
{
  for (int i = 0; i < 3; ++i)
    bias_unit_[i] = random_.gaussian();  // stationary from the start
}

GnssSample GnssReceiver::sample(double stamp, const Eigen::Vector3d& antenna_world, double canopy)
{
  const GnssConfig& c = config_;
  canopy = std::min(1.0, std::max(0.0, canopy));
  // The bias walks on (unit variance, correlation time bias_time) and is scaled by the canopy of the moment.
  if (last_stamp_ >= 0.0)
  {
    const double a = std::exp(-std::max(0.0, stamp - last_stamp_) / c.bias_time);
    for (int i = 0; i < 3; ++i)
      bias_unit_[i] = a * bias_unit_[i] + std::sqrt(std::max(0.0, 1.0 - a * a)) * random_.gaussian();
  }
  const double dt = last_stamp_ >= 0.0 ? std::max(0.0, stamp - last_stamp_) : 0.0;
  last_stamp_ = stamp;
  const double sigma = c.open_sigma + (c.canopy_sigma - c.open_sigma) * canopy;
  const double bias_sigma = c.open_bias_sigma + (c.canopy_bias_sigma - c.open_bias_sigma) * canopy;
  const double w_e = random_.gaussian(sigma), w_n = random_.gaussian(sigma),
               w_u = random_.gaussian(sigma * c.vertical_factor);
  // Outages begin at a rate growing with the canopy and last an exponential time.
  const double u_start = random_.uniform(), u_len = random_.uniform();
  if (stamp >= outage_until_ && c.outage_interval > 0.0 && canopy > 0.0 &&
      u_start < 1.0 - std::exp(-dt * canopy / c.outage_interval))
    outage_until_ = stamp - c.outage_duration * std::log(std::max(1e-12, 1.0 - u_len));
  // World -> east-north, then WGS84.
  const double cy = std::cos(c.world_yaw), sy = std::sin(c.world_yaw);
  const Eigen::Vector2d en(cy * antenna_world.x() - sy * antenna_world.y(),
                           sy * antenna_world.x() + cy * antenna_world.y());
  GnssSample s;
  s.canopy = canopy;
  s.truth.stamp = stamp;
  s.truth.valid = true;
  const GeoPoint t = plane_.toGeo(en, c.origin.altitude + antenna_world.z());
  s.truth.latitude = t.latitude;
  s.truth.longitude = t.longitude;
  s.truth.altitude = t.altitude;
  s.truth.covariance = Eigen::Matrix2d::Zero();
  s.fix.stamp = stamp;
  s.fix.valid = stamp >= outage_until_;
  const Eigen::Vector2d noisy = en + Eigen::Vector2d(w_e + bias_sigma * bias_unit_[0], w_n + bias_sigma * bias_unit_[1]);
  const GeoPoint f = plane_.toGeo(noisy, t.altitude + w_u + c.vertical_factor * bias_sigma * bias_unit_[2]);
  s.fix.latitude = f.latitude;
  s.fix.longitude = f.longitude;
  s.fix.altitude = f.altitude;
  s.fix.covariance = (sigma * sigma + bias_sigma * bias_sigma) * Eigen::Matrix2d::Identity();
  return s;
}

GeoAnchorEstimator::GeoAnchorEstimator(const GnssFusionConfig& config) : config_(config)
{
}

void GeoAnchorEstimator::clear()
{
  map_.clear();
  east_north_.clear();
  weight_.clear();
  stamp_.clear();
  altitude_.clear();
  latitude_.clear();
  longitude_.clear();
}

void GeoAnchorEstimator::add(const GnssFix& fix, const Eigen::Vector2d& antenna_map)
{
  if (!gnssFixProblem(fix, config_.max_sigma).empty() || !antenna_map.allFinite())
    return;
  if (map_.empty())
    plane_ = LocalTangentPlane(GeoPoint{ fix.latitude, fix.longitude, fix.altitude });
  const double var = std::max(0.5 * fix.covariance.trace(), config_.sigma_floor * config_.sigma_floor);
  map_.push_back(antenna_map);
  east_north_.push_back(plane_.toEastNorth(fix.latitude, fix.longitude));
  weight_.push_back(1.0 / var);
  stamp_.push_back(fix.stamp);
  altitude_.push_back(fix.altitude);
  latitude_.push_back(fix.latitude);
  longitude_.push_back(fix.longitude);
}

namespace
{
constexpr double kPlaneFollowDistance = 1000.0;  ///< [m] the fit's tangent plane moves to the median fix beyond this

/** @brief The median of @p v (reordered); NaN when empty. */
double median(std::vector<double>* v)
{
  if (v->empty())
    return NAN;
  const auto mid = v->begin() + static_cast<std::ptrdiff_t>(v->size() / 2);
  std::nth_element(v->begin(), mid, v->end());
  return *mid;
}
}  // namespace

void GeoAnchorEstimator::followFixes() const
{
  std::vector<double> lat = latitude_, lon = longitude_, alt = altitude_;
  const GeoPoint middle{ median(&lat), median(&lon), median(&alt) };
  if (!(plane_.toEastNorth(middle.latitude, middle.longitude).norm() > kPlaneFollowDistance))
    return;
  plane_ = LocalTangentPlane(middle);
  for (std::size_t i = 0; i < east_north_.size(); ++i)
    east_north_[i] = plane_.toEastNorth(latitude_[i], longitude_[i]);
}

bool GeoAnchorEstimator::robustStart(double* yaw, Eigen::Vector2d* origin) const
{
  // The heading from pairs of fixes far apart in the map (each pair its own estimate), the one most others agree
  // with; then the origin as the per-axis median: neither moves while fewer than half the fixes are wild.
  const std::size_t n = map_.size();
  const std::size_t step = std::max<std::size_t>(1, n / 100);  // at most ~100 pairs: bounded work
  std::vector<double> headings;
  for (std::size_t i = 0; i < n; i += step)
  {
    const std::size_t j = (i + n / 2) % n;
    const Eigen::Vector2d dm = map_[j] - map_[i], de = east_north_[j] - east_north_[i];
    if (dm.norm() < config_.anchor_min_spread || !(de.norm() > 0.0))
      continue;
    headings.push_back(std::atan2(de.y(), de.x()) - std::atan2(dm.y(), dm.x()));
  }
  if (headings.empty())
    return false;
  std::size_t best = 0, best_count = 0;
  for (std::size_t a = 0; a < headings.size(); ++a)
  {
    std::size_t count = 0;
    for (const double h : headings)
      count += std::abs(std::remainder(h - headings[a], 2.0 * M_PI)) < 0.1 ? 1 : 0;
    if (count > best_count)
    {
      best = a;
      best_count = count;
    }
  }
  *yaw = headings[best];
  const Eigen::Matrix2d R = Eigen::Rotation2Dd(*yaw).toRotationMatrix();
  std::vector<double> ox, oy;
  for (std::size_t i = 0; i < n; ++i)
  {
    const Eigen::Vector2d o = east_north_[i] - R * map_[i];
    ox.push_back(o.x());
    oy.push_back(o.y());
  }
  *origin = Eigen::Vector2d(median(&ox), median(&oy));
  return true;
}

GeoAnchor GeoAnchorEstimator::anchor(int* outliers) const
{
  GeoAnchor a;
  if (outliers)
    *outliers = 0;
  const std::size_t n = map_.size();
  if (static_cast<int>(n) < std::max(3, config_.anchor_min_fixes))
    return a;
  followFixes();
  // Fixes that disagree with a robust first fit (beyond the gate of their own sigma, and beyond three robust
  // standard deviations of all the residuals) are left out of the least-squares fit.
  double yaw0 = 0.0;
  Eigen::Vector2d origin0;
  std::vector<double> w = weight_;
  if (robustStart(&yaw0, &origin0))
  {
    const Eigen::Matrix2d R0 = Eigen::Rotation2Dd(yaw0).toRotationMatrix();
    std::vector<double> residuals(n);
    for (std::size_t i = 0; i < n; ++i)
      residuals[i] = (R0 * map_[i] + origin0 - east_north_[i]).norm();
    std::vector<double> sorted = residuals;
    const double robust_sigma = 1.4826 * median(&sorted);
    for (std::size_t i = 0; i < n; ++i)
      if (residuals[i] > std::max(kGnssGate * std::sqrt(1.0 / weight_[i]), 3.0 * robust_sigma))
      {
        w[i] = 0.0;
        if (outliers)
          ++*outliers;
      }
  }
  double wsum = 0.0, alt = 0.0;
  Eigen::Vector2d cm = Eigen::Vector2d::Zero(), ce = Eigen::Vector2d::Zero();
  std::size_t used = 0;
  double first = NAN, last = NAN;
  for (std::size_t i = 0; i < n; ++i)
  {
    if (!(w[i] > 0.0))
      continue;
    ++used;
    if (std::isnan(first))
      first = stamp_[i];
    last = stamp_[i];
    wsum += w[i];
    cm += w[i] * map_[i];
    ce += w[i] * east_north_[i];
    alt += w[i] * altitude_[i];
  }
  if (static_cast<int>(used) < std::max(3, config_.anchor_min_fixes))
    return a;
  cm /= wsum;
  ce /= wsum;
  alt /= wsum;
  Eigen::Matrix2d spread = Eigen::Matrix2d::Zero(), H = Eigen::Matrix2d::Zero();
  for (std::size_t i = 0; i < n; ++i)
  {
    const Eigen::Vector2d dm = map_[i] - cm, de = east_north_[i] - ce;
    spread += w[i] * dm * dm.transpose();
    H += w[i] * dm * de.transpose();
  }
  spread /= wsum;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(spread);
  const double strongest = std::sqrt(std::max(0.0, eig.eigenvalues().maxCoeff()));
  // A straight drive fixes the heading as well as a loop does; a cluster of fixes at one spot fixes none.
  if (strongest < config_.anchor_min_spread)
    return a;
  const double yaw = std::atan2(H(0, 1) - H(1, 0), H(0, 0) + H(1, 1));
  const Eigen::Matrix2d R = Eigen::Rotation2Dd(yaw).toRotationMatrix();
  const Eigen::Vector2d origin = ce - R * cm;  // the map origin in east-north
  double sse = 0.0;
  for (std::size_t i = 0; i < n; ++i)
    sse += w[i] * (R * map_[i] + origin - east_north_[i]).squaredNorm();
  // Per-axis residual sigma (two axes, three parameters fitted), and the number of independent stretches.
  const double m = static_cast<double>(used);
  const double residual = std::sqrt(sse / wsum / 2.0 * m / std::max(1.0, m - 1.5));
  const double span = last - first;
  const double independent = std::max(1.0, std::min(m, span / config_.correlation_time));
  const double sigma_centre = residual / std::sqrt(independent);
  const double sigma_yaw = residual / (strongest * std::sqrt(independent));
  a.valid = true;
  const GeoPoint g = plane_.toGeo(origin, alt);
  a.latitude = g.latitude;
  a.longitude = g.longitude;
  a.altitude = alt;
  a.yaw = std::atan2(std::sin(yaw), std::cos(yaw));
  a.sigma = std::hypot(sigma_centre, cm.norm() * sigma_yaw);
  return a;
}

double gnssInnovation(const GnssFix& fix, const GeoAnchor& anchor, double sigma_floor,
                      const Eigen::Vector2d& predicted, const Eigen::Matrix2d& predicted_covariance)
{
  Eigen::Vector2d z;
  Eigen::Matrix2d cov;
  gnssInFrame(fix, anchor, sigma_floor, &z, &cov);
  const Eigen::Matrix2d S = cov + predicted_covariance;
  const Eigen::Vector2d e = z - predicted;
  if (!e.allFinite() || !S.allFinite() || !(S.determinant() > 0.0))
    return std::numeric_limits<double>::infinity();
  return e.dot(S.ldlt().solve(e));
}

GeoAnchor combineAnchors(const GeoAnchor& a, const GeoAnchor& b)
{
  if (!a.valid)
    return b;
  if (!b.valid)
    return a;
  if (!(a.sigma > 0.0))
    return a;
  if (!(b.sigma > 0.0))
    return b;
  const double wa = 1.0 / (a.sigma * a.sigma), wb = 1.0 / (b.sigma * b.sigma);
  const LocalTangentPlane plane(GeoPoint{ a.latitude, a.longitude, a.altitude });
  const Eigen::Vector2d en = wb / (wa + wb) * plane.toEastNorth(b.latitude, b.longitude);
  GeoAnchor c;
  c.valid = true;
  c.altitude = (wa * a.altitude + wb * b.altitude) / (wa + wb);
  const GeoPoint g = plane.toGeo(en, c.altitude);
  c.latitude = g.latitude;
  c.longitude = g.longitude;
  c.yaw = std::atan2(wa * std::sin(a.yaw) + wb * std::sin(b.yaw), wa * std::cos(a.yaw) + wb * std::cos(b.yaw));
  c.sigma = 1.0 / std::sqrt(wa + wb);
  return c;
}

void gnssInFrame(const GnssFix& fix, const GeoAnchor& anchor, double sigma_floor, Eigen::Vector2d* position,
                 Eigen::Matrix2d* covariance)
{
  *position = geoToAnchored(anchor, fix.latitude, fix.longitude);
  // East-north covariance turned into the frame.
  const Eigen::Matrix2d R = Eigen::Rotation2Dd(-anchor.yaw).toRotationMatrix();
  Eigen::Matrix2d c = R * fix.covariance * R.transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(0.5 * (c + c.transpose()));
  c = eig.eigenvectors() * eig.eigenvalues().cwiseMax(sigma_floor * sigma_floor).asDiagonal() *
      eig.eigenvectors().transpose();
  *covariance = c + anchor.sigma * anchor.sigma * Eigen::Matrix2d::Identity();
}

}  // namespace core
}  // namespace rbpf_slam
