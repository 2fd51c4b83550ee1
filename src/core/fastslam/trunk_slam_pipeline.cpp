#include "rbpf_slam/core/fastslam/trunk_slam_pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include <Eigen/Eigenvalues>

namespace rbpf_slam
{
namespace core
{
namespace
{
double since(std::chrono::steady_clock::time_point t0)
{
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

double evidenceShare(const FastSlamConfig& config, const std::vector<TrunkObservation>& trunks,
                     const Pose2& sensor_motion)
{
  if (!(config.evidence_view_change > 0.0))
    return 1.0;
  std::vector<double> ranges;
  ranges.reserve(trunks.size());
  for (const TrunkObservation& t : trunks)
    if (std::isfinite(t.center.x()) && std::isfinite(t.center.y()))
      ranges.push_back(t.center.norm());
  if (ranges.empty())
    return 1.0;
  const auto mid = ranges.begin() + static_cast<std::ptrdiff_t>(ranges.size() / 2);
  std::nth_element(ranges.begin(), mid, ranges.end());
  const double view = config.evidence_view_change;
  return std::min(1.0, std::hypot(sensor_motion.x, sensor_motion.y) / (view * std::max(*mid, 1e-3)));
}

int fuseSkippedLooks(std::vector<LandmarkObservation>* obs, const Pose2& sensor,
                     const std::vector<std::vector<LookPoint>>& skipped, double gate)
{
  int fused = 0;
  for (LandmarkObservation& o : *obs)
  {
    const double c = std::cos(o.bearing), s = std::sin(o.bearing);
    Eigen::Matrix2d J;  // d(x, y) / d(range, bearing) in the sensor frame
    J << c, -o.range * s, s, o.range * c;
    double sx = 0.0, sy = 0.0;
    sensor.transformPoint(o.range * c, o.range * s, &sx, &sy);
    const Eigen::Vector2d q(sx, sy);
    const Eigen::Matrix2d rot = Eigen::Rotation2Dd(sensor.theta).toRotationMatrix();
    // Two looks of one trunk differ by at most both their errors.
    const Eigen::Matrix2d both = 2.0 * rot * J * o.covariance * J.transpose() * rot.transpose();
    const Eigen::Matrix2d both_inv = both.inverse();
    if (!both_inv.allFinite())
      continue;
    Eigen::Vector2d sum = q;
    double radius_sum = o.radius;
    int n = 1;
    for (const std::vector<LookPoint>& sweep : skipped)
    {
      const LookPoint* best = nullptr;
      double best_d2 = gate;
      for (const LookPoint& l : sweep)
      {
        if (o.id >= 0 && l.id >= 0 && o.id != l.id)
          continue;
        const Eigen::Vector2d v = l.position - q;
        const double d2 = v.dot(both_inv * v);
        if (d2 < best_d2)
        {
          best_d2 = d2;
          best = &l;
        }
      }
      if (!best)
        continue;
      sum += best->position;
      radius_sum += best->radius;
      ++n;
    }
    if (n == 1)
      continue;
    fused += n - 1;
    double mx = 0.0, my = 0.0;
    const Eigen::Vector2d mean = sum / n;
    sensor.inverse().transformPoint(mean.x(), mean.y(), &mx, &my);
    o.range = std::hypot(mx, my);
    o.bearing = std::atan2(my, mx);
    o.radius = radius_sum / n;
  }
  return fused;
}

TrunkSlamPipeline::TrunkSlamPipeline(const TrunkDetectorConfig& detector, const FastSlamConfig& filter,
                                     const PipelineTiming& timing)
  : SensorPipeline(timing)
  , detector_config_(detector)
  , filter_config_(filter)
  , detector_(new TrunkDetector(detector))
  , filter_(new FastSlam(filter))
  , gnss_config_(filter.gnss)
  , anchor_estimator_(filter.gnss)
{
}

void TrunkSlamPipeline::resetFilter()
{
  // The map that ends here is kept for the caller to save (takeEndedMaps); only the latest few, so that a looped
  // bag's restarts do not grow the memory.
  if (initialized_ && filter_)
  {
    TimelineMap ended;
    ended.timeline = restarts() - 1;
    ended.anchor = anchor();
    ended.viewpoints = viewpoints_.viewpoints();
    const LandmarkMap& map = filter_->best().map;
    ended.trees.reserve(map.size());
    for (std::size_t i = 0; i < map.size(); ++i)
      ended.trees.push_back(map[i]);
    ended_.push_back(std::move(ended));
    while (ended_.size() > kKeptEndedMaps)
      ended_.erase(ended_.begin());
  }
  // Filter and detector start over with their seeds, so that each timeline is reproducible on its own.
  detector_.reset(new TrunkDetector(detector_config_));
  filter_.reset(new FastSlam(filter_config_));
  restartSearch();
  lost_search_ = false;
  lost_search_end_ = -1e300;
  travel_ = 0.0;
  last_unobserved_ = false;
  health_ = FilterHealth(healthConfig());
  anchor_estimator_.clear();  // a restart begins a new map frame (unless a saved map's)
  viewpoints_.reset(prior_viewpoints_);
  pending_fixes_.clear();
  between_.clear();
  gate_anchor_ = GeoAnchor();
  last_weigh_stamp_ = -1e300;
  next_anchor_check_ = -1e300;
  initialized_ = false;
  last_odometry_ = Pose2();
  last_estimate_ = Pose2();
}

void TrunkSlamPipeline::setPriorMap(const std::vector<Landmark>& trees, const Pose2& start,
                                    const RelocalizationConfig& relocalization)
{
  if (trees.size() > static_cast<std::size_t>(filter_config_.max_landmarks))
    throw std::invalid_argument("the saved map holds " + std::to_string(trees.size()) + " trees, more than max_landmarks (" +
                                std::to_string(filter_config_.max_landmarks) + ")");
  prior_ = LandmarkMap();
  for (Landmark l : trees)
  {
    l.evidence = l.provisional ? 0.0 : filter_config_.evidence_max;
    // The saved covariance, no surer than the floor in any direction.
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(0.5 * (l.covariance + l.covariance.transpose()));
    const double floor2 = filter_config_.prior_sigma_floor * filter_config_.prior_sigma_floor;
    l.covariance = eig.eigenvectors() * eig.eigenvalues().cwiseMax(floor2).asDiagonal() * eig.eigenvectors().transpose();
    l.visit_radius = NAN;  // this run has not seen it yet
    l.visit_radius_variance = 0.0;
    l.visit_observations = 0;
    prior_.add(l);
  }
  prior_start_ = start;
  has_prior_ = true;
  health_ = FilterHealth(healthConfig());
  relocalize_ = false;
  relocalization_config_ = relocalization;
  matcher_.reset(filter_config_.relocalize_when_lost ? new ConstellationMatcher(trees, relocalization.constellation) :
                                                     nullptr);
}

void TrunkSlamPipeline::setPriorMap(const std::vector<Landmark>& trees, const RelocalizationConfig& relocalization)
{
  setPriorMap(trees, Pose2(), relocalization);
  if (!matcher_)  // needed for the start
    matcher_.reset(new ConstellationMatcher(trees, relocalization.constellation));
  relocalize_ = true;
}

HealthConfig TrunkSlamPipeline::healthConfig() const
{
  HealthConfig h;
  if (has_prior_)
    h.matched_prior_warn = 0.3;
  return h;
}

void TrunkSlamPipeline::restartSearch()
{
  gathered_.clear();
  search_travel_ = 0.0;
  search_started_ = false;
}

void TrunkSlamPipeline::setMapAnchor(const GeoAnchor& anchor)
{
  map_anchor_ = anchor;
}

void TrunkSlamPipeline::setMapViewpoints(const std::vector<Viewpoint>& viewpoints)
{
  prior_viewpoints_ = viewpoints;
  viewpoints_.reset(prior_viewpoints_);
}

GeoAnchor TrunkSlamPipeline::anchor() const
{
  return combineAnchors(map_anchor_, anchor_estimator_.anchor());
}

std::string TrunkSlamPipeline::addFix(const GnssFix& fix, const Eigen::Vector2d& antenna)
{
  if (!gnss_config_.enabled)
    return "satellite fixes are not used (gps enabled: false)";
  std::string why = gnssFixProblem(fix, gnss_config_.max_sigma);
  if (why.empty() && !antenna.allFinite())
    why = "antenna position not finite";
  if (why.empty() && initialized_ && fix.stamp < last_stamp_ - 1.0)
    why = "older than the last filter update by more than 1 s";
  if (why.empty() && !pending_fixes_.empty() && fix.stamp <= pending_fixes_.back().fix.stamp)
    why = "stamp not after the previous fix's";
  if (!why.empty())
    return why;
  pending_fixes_.push_back({ fix, antenna });
  while (pending_fixes_.size() > 600)  // e.g. a long search without an update: keep the last ten minutes at 1 Hz
    pending_fixes_.pop_front();
  return "";
}

void TrunkSlamPipeline::useFixes(double t_mid, const Pose2& odom_mid)
{
  if (pending_fixes_.empty() || pending_fixes_.front().fix.stamp > t_mid)
    return;  // no fix is due: the estimate (a mean over the particles) is not needed
  const Pose2 estimate = filter_->estimate();
  const Eigen::Matrix2d pose_covariance = filter_->poseCovariance().topLeftCorner<2, 2>();
  const Pose2 odom_mid_inv = odom_mid.inverse();
  if (!gate_anchor_.valid && map_anchor_.valid)
    gate_anchor_ = map_anchor_;
  while (!pending_fixes_.empty() && pending_fixes_.front().fix.stamp <= t_mid)
  {
    const PendingFix f = pending_fixes_.front();
    pending_fixes_.pop_front();
    if (odometry_.empty() || f.fix.stamp < odometry_.earliest())
      continue;  // before the odometry kept (e.g. while the start was searched): not placed
    // base_link at the fix's instant, in base_link at this update's, by the odometry between them.
    const Pose2 back = odom_mid_inv * odometry_.at(f.fix.stamp);
    Eigen::Vector2d lever;
    back.transformPoint(f.antenna.x(), f.antenna.y(), &lever.x(), &lever.y());
    Eigen::Vector2d antenna_map;
    estimate.transformPoint(lever.x(), lever.y(), &antenna_map.x(), &antenna_map.y());
    // The innovation gate: once an anchor is known, a fix far from where it and the filter put the antenna (a
    // receiver's jump) goes neither into the anchor's fit nor onto the particles.
    if (gate_anchor_.valid &&
        gnssInnovation(f.fix, gate_anchor_, gnss_config_.sigma_floor, antenna_map, pose_covariance) > kGnssGate2)
    {
      ++gnss_rejected_;
      continue;
    }
    anchor_estimator_.add(f.fix, antenna_map);
    ++gnss_used_;
    // A fix weighs the particles at most once per correlation time; the anchor (a fit over every fix so far) is
    // refitted for it only when one is due, and at most ten times per correlation time while it is not yet known.
    if (gnss_config_.weigh_max_anchor_sigma <= 0.0 ||
        f.fix.stamp - last_weigh_stamp_ < gnss_config_.correlation_time || f.fix.stamp < next_anchor_check_)
      continue;
    next_anchor_check_ = f.fix.stamp + 0.1 * gnss_config_.correlation_time;
    const GeoAnchor a = anchor();
    if (a.valid)
      gate_anchor_ = a;
    if (!a.valid || (a.sigma > gnss_config_.weigh_max_anchor_sigma && !map_anchor_.valid))
      continue;
    Eigen::Vector2d z;
    Eigen::Matrix2d cov;
    gnssInFrame(f.fix, a, gnss_config_.sigma_floor, &z, &cov);
    if (filter_->weighPosition(z, cov, lever) >= 0.0)
    {
      last_weigh_stamp_ = f.fix.stamp;
      ++gnss_weighed_;
    }
  }
}

bool TrunkSlamPipeline::relocalize(const TrunkSweep& sw, const Pose2& odom_mid, RelocalizationStatus* st,
                                   std::vector<Pose2>* starts)
{
  const auto t0 = std::chrono::steady_clock::now();
  const RelocalizationConfig& rc = relocalization_config_;
  if (search_started_)
    search_travel_ += std::hypot(odom_mid.x - search_last_odometry_.x, odom_mid.y - search_last_odometry_.y);
  search_started_ = true;
  search_last_odometry_ = odom_mid;
  // The trunks of this sweep in the odometry frame, merged with those gathered before.
  const Pose2 sensor = odom_mid * Pose2(sw.mount.x, sw.mount.y, sw.mount.yaw);
  for (const TrunkObservation& t : sw.trunks)
  {
    if (!std::isfinite(t.center.x()) || !std::isfinite(t.center.y()) || !std::isfinite(t.radius))
      continue;
    Eigen::Vector2d p;
    sensor.transformPoint(t.center.x(), t.center.y(), &p.x(), &p.y());
    Gathered* near = nullptr;
    double best = rc.merge_distance;
    for (Gathered& g : gathered_)
    {
      const double d = (g.center - p).norm();
      if (d < best)
      {
        best = d;
        near = &g;
      }
    }
    if (!near)
    {
      gathered_.push_back(Gathered());
      near = &gathered_.back();
      near->center = p;
      near->radius = t.radius;
    }
    else
    {
      const double w = 1.0 / (near->sightings + 1.0);
      near->center += w * (p - near->center);
      near->radius += w * (t.radius - near->radius);
    }
    ++near->sightings;
    near->travel = search_travel_;
  }
  gathered_.erase(std::remove_if(gathered_.begin(), gathered_.end(),
                                 [&](const Gathered& g) { return search_travel_ - g.travel > rc.window; }),
                  gathered_.end());
  std::vector<TrunkPoint> seen;
  for (const Gathered& g : gathered_)
    if (g.sightings >= rc.min_sightings)
    {
      TrunkPoint tp;
      tp.center = g.center;
      tp.radius = g.radius;
      tp.radius_sigma = 0.02;
      seen.push_back(tp);
    }
  // The nearest trunks first: they make the pairs of the search (max_pair_trunks).
  std::sort(seen.begin(), seen.end(), [&](const TrunkPoint& a, const TrunkPoint& b) {
    return (a.center - Eigen::Vector2d(sensor.x, sensor.y)).squaredNorm() <
           (b.center - Eigen::Vector2d(sensor.x, sensor.y)).squaredNorm();
  });
  last_seen_ = seen;
  st->active = true;
  st->trunks = static_cast<int>(seen.size());
  st->travel = search_travel_;
  bool found = false;
  if (static_cast<int>(seen.size()) < rc.constellation.min_inliers)
    st->reason = "gathering trunks: " + std::to_string(seen.size()) + " seen twice, " +
                 std::to_string(rc.constellation.min_inliers) + " needed";
  else
  {
    const ConstellationResult r = matcher_->match(seen);
    if (!r.hypotheses.empty())
      st->best_inliers = r.hypotheses.front().inliers;
    if (r.hypotheses.size() > 1)
      st->second_inliers = r.hypotheses[1].inliers;
    st->reason = r.reason;
    if (r.accepted)
    {
      starts->clear();
      for (const PoseHypothesis& h : r.hypotheses)
        if (h.inliers >= rc.hypothesis_share * r.hypotheses.front().inliers)
          starts->push_back(h.transform * odom_mid);
      st->hypotheses = static_cast<int>(starts->size());
      gathered_.clear();
      found = true;
    }
  }
  st->seconds = since(t0);
  return found;
}

std::vector<TimelineMap> TrunkSlamPipeline::takeEndedMaps()
{
  std::vector<TimelineMap> ended;
  ended.swap(ended_);
  return ended;
}

bool TrunkSlamPipeline::enqueueSweep(TrunkSweep sweep, double arrival)
{
  if (sweep.trunks.size() > static_cast<std::size_t>(filter_config_.max_trunks_per_sweep))
    return false;  // beyond what the sensor can see: not a look at the trees
  const double start = sweep.stamp, end = sweep.stamp + sweep.period;
  enqueue(std::move(sweep), start, end, arrival);
  return true;
}

StampVerdict TrunkSlamPipeline::addTrunks(TrunkSweep sweep, double clock, double arrival)
{
  if (sweep.trunks.size() > static_cast<std::size_t>(filter_config_.max_trunks_per_sweep))
    return StampVerdict::kOverLimit;  // before its stamp is taken: it does not move the timeline either
  const StampVerdict v = admitSensor(sweep.stamp, clock);
  if (v != StampVerdict::kAccept && v != StampVerdict::kReset)
    return v;
  if (!std::isfinite(sweep.period) || sweep.period < 0.0)
    sweep.period = 0.0;
  if (!std::isfinite(sweep.tilt_roll))
    sweep.tilt_roll = 0.0;
  if (!std::isfinite(sweep.tilt_pitch))
    sweep.tilt_pitch = 0.0;
  enqueueSweep(std::move(sweep), arrival);
  return v;
}

StampVerdict TrunkSlamPipeline::addSweep(double stamp, double period, const std::vector<Eigen::Vector3f>& points,
                                         const SensorMount& mount, double clock, double arrival)
{
  const StampVerdict v = admitSensor(stamp, clock);
  if (v != StampVerdict::kAccept && v != StampVerdict::kReset)
    return v;
  const auto t0 = std::chrono::steady_clock::now();
  if (!(detector_->config().sensor_height > 0.0) && mount.z > 0.0)  // as the extraction nodelet does from TF
    detector_->setConfig(withMountHeight(detector_->config(), mount.z));
  TrunkDetectorStats stats;
  TrunkSweep sweep;
  sweep.stamp = stamp;
  sweep.period = period;
  sweep.mount = mount;
  sweep.trunks = detector_->detect(points, Eigen::Matrix3d::Identity(), &stats);
  sweep.scope = sweepScope(detector_->config(), stats.reach);
  sweep.tilt_roll = stats.tilt_roll;
  sweep.tilt_pitch = stats.tilt_pitch;
  const bool taken = enqueueSweep(std::move(sweep), arrival);
  seconds_extraction_ += since(t0);
  return taken ? v : StampVerdict::kOverLimit;
}

StampVerdict TrunkSlamPipeline::addScan(double stamp, double period, const PlanarScan& scan, const SensorMount& mount,
                                        double clock, double arrival)
{
  const StampVerdict v = admitSensor(stamp, clock);
  if (v != StampVerdict::kAccept && v != StampVerdict::kReset)
    return v;
  const auto t0 = std::chrono::steady_clock::now();
  TrunkSweep sweep;
  sweep.stamp = stamp;
  sweep.period = period;
  sweep.mount = mount;
  sweep.trunks = detector_->detectScan(scan);
  sweep.geometry = scanGeometry(scan);
  sweep.scope = scanScope(scan, detector_->config());
  const bool taken = enqueueSweep(std::move(sweep), arrival);
  seconds_extraction_ += since(t0);
  return taken ? v : StampVerdict::kOverLimit;
}

TrunkDetectorConfig withMountHeight(TrunkDetectorConfig config, double mount_z)
{
  if (!(config.sensor_height > 0.0) && std::isfinite(mount_z) && mount_z > 0.0)
    config.sensor_height = mount_z;
  return config;
}

double scanPeriod(double time_increment, std::size_t beams)
{
  if (!(std::isfinite(time_increment) && time_increment > 0.0) || beams < 2)
    return 0.0;
  return time_increment * static_cast<double>(beams - 1);
}

SweepGeometry scanGeometry(const PlanarScan& scan)
{
  SweepGeometry g;
  g.start_angle = scan.angle_min;
  g.span = std::max(1e-9, std::abs(scan.angle_increment) *
                              static_cast<double>(scan.ranges.size() > 1 ? scan.ranges.size() - 1 : 1));
  return g;
}

SensorScope scanScope(const PlanarScan& scan, const TrunkDetectorConfig& config)
{
  SensorScope s;
  const double last = scan.angle_min + scan.angle_increment * static_cast<double>(
                                           scan.ranges.empty() ? 0 : scan.ranges.size() - 1);
  s.fov_min = std::min(scan.angle_min, last);
  s.fov_max = std::max(scan.angle_min, last);
  s.min_range = std::max(std::isfinite(scan.range_min) ? scan.range_min : 0.0, config.min_range);
  s.max_range = std::isfinite(scan.range_max) && scan.range_max > 0.0 ? std::min(scan.range_max, config.max_range)
                                                                      : config.max_range;
  s.detection_probability = config.detection_probability;
  return s;
}

SensorScope sweepScope(const TrunkDetectorConfig& config, double reach)
{
  SensorScope s;
  s.fov_min = -M_PI;
  s.fov_max = M_PI;
  s.min_range = config.min_range;
  s.max_range = std::isfinite(reach) && reach > 0.0 ? std::min(reach, config.max_range) : config.max_range;
  s.detection_probability = config.detection_probability;
  return s;
}

std::vector<LandmarkObservation> sweepObservations(const std::vector<TrunkObservation>& trunks, double stamp,
                                                   double period, double tilt_roll, double tilt_pitch,
                                                   const SensorMount& mount, const OdometryBuffer& odometry,
                                                   double t_ref, const SweepGeometry& geometry)
{
  const Pose2 mount_pose(mount.x, mount.y, mount.yaw);
  const Eigen::Vector2d lever = mount.z * Eigen::Vector2d(std::tan(tilt_pitch), -std::tan(tilt_roll));
  const Pose2 sensor_ref = odometry.at(t_ref) * mount_pose;
  const Pose2 sensor_ref_inv = sensor_ref.inverse();
  std::vector<LandmarkObservation> obs;
  obs.reserve(trunks.size());
  for (const auto& t0 : trunks)
  {
    TrunkObservation t = t0;
    t.center += lever;
    t.range = t.center.norm();
    t.bearing = std::atan2(t.center.y(), t.center.x());
    double turned = t.bearing - geometry.start_angle;  // counter-clockwise from the sweep's first bearing
    turned -= 2.0 * M_PI * std::floor(turned / (2.0 * M_PI));
    const double t_obs = stamp + period * std::min(1.0, turned / geometry.span);
    const Pose2 sensor_obs = odometry.at(t_obs) * mount_pose;
    double wx = 0.0, wy = 0.0, mx = 0.0, my = 0.0;
    sensor_obs.transformPoint(t.center.x(), t.center.y(), &wx, &wy);
    sensor_ref_inv.transformPoint(wx, wy, &mx, &my);
    TrunkObservation moved = t;
    moved.center = Eigen::Vector2d(mx, my);
    const Eigen::Matrix2d R = Eigen::Rotation2Dd(sensor_obs.theta - sensor_ref.theta).toRotationMatrix();
    moved.covariance = R * t.covariance * R.transpose();
    obs.push_back(toLandmarkObservation(moved));
  }
  return obs;
}

void TrunkSlamPipeline::searchWhenLost(const TrunkSweep& sw, const Pose2& odom_mid, PipelineUpdate* u)
{
  const RelocalizationConfig& rc = relocalization_config_;
  const bool unobserved = u->health.saved_map_unobserved;
  const bool before = last_unobserved_;
  last_unobserved_ = unobserved;
  if (!has_prior_ || !matcher_ || !filter_config_.relocalize_when_lost)
    return;
  // A search begins when the saved map's trees stop being re-observed, or while they stay so, a window of travel
  // after the last search ended (the estimate it confirmed may have been lost since).
  if (!lost_search_ && unobserved && (!before || travel_ - lost_search_end_ > rc.window))
  {
    lost_search_ = true;
    restartSearch();
  }
  if (!lost_search_)
    return;
  RelocalizationStatus st;
  st.lost = true;
  std::vector<Pose2> starts;
  if (relocalize(sw, odom_mid, &st, &starts))
  {
    const Pose2 estimate = filter_->estimate();
    const Pose2 d = between(estimate, starts.front());
    // The estimate's own support among the trunks the search gathered (odometry frame -> map by the estimate).
    const int estimate_inliers = matcher_->inliers(last_seen_, estimate * odom_mid.inverse());
    const bool distinct = std::hypot(d.x, d.y) > rc.recover_distance || std::abs(d.theta) > rc.recover_angle;
    if (!distinct)
      st.confirmed = true;
    else if (st.best_inliers >= std::max(rc.recover_min_inliers, rc.constellation.min_inliers) &&
             st.best_inliers >= estimate_inliers + rc.recover_margin)
    {
      // Found elsewhere: the particles start again on the saved map, over the hypotheses and the estimate (should
      // the search be the one that is wrong, the next sweeps say so).
      starts.push_back(estimate);
      filter_->setClock(u->stamp);
      filter_->initialize(starts, prior_, rc.spread_xy, rc.spread_theta);
      health_ = FilterHealth(healthConfig());
      last_unobserved_ = false;
      st.recovered = true;
      st.found = true;
    }
    else
    {
      st.reason = "found elsewhere with " + std::to_string(st.best_inliers) + " trunks, the estimate explains " +
                  std::to_string(estimate_inliers) + ": not enough to move the particles";
      u->relocalization = st;
      return;  // go on gathering
    }
    lost_search_ = false;
    lost_search_end_ = travel_;
  }
  else if (search_travel_ > rc.window)
  {
    // Nothing found within a window of travel: this search ends; the next warning starts another.
    lost_search_ = false;
    lost_search_end_ = travel_;
    st.gave_up = true;
  }
  u->relocalization = st;
}

void TrunkSlamPipeline::predictMotion(const FastSlamConfig& fc, const Pose2& odom_mid, double t_mid)
{
  Pose2 from = last_odometry_;
  if (fc.motion_model == MotionModel::kVelocity)
  {
    std::vector<ArcStep> block;
    double block_start = last_stamp_;
    odometry_.forEachBetween(last_stamp_, t_mid, [&](double t, const Pose2& pose) {
      block.push_back(arcStep(from, pose));
      from = pose;
      if (t - block_start >= fc.motion_noise_time)
      {
        filter_->predictArcs(block);
        block.clear();
        block_start = t;
      }
    });
    block.push_back(arcStep(from, odom_mid));
    filter_->predictArcs(block, partialStepNoiseScale((t_mid - block_start) / fc.motion_noise_time));
    return;
  }
  odometry_.forEachBetween(last_stamp_, t_mid, [&](double, const Pose2& pose) {
    const OdometryIncrement u = decomposeOdometry(from, pose);
    if (u.trans >= fc.motion_step || std::abs(u.rot1) + std::abs(u.rot2) >= fc.motion_step_angle)
    {
      filter_->predict(u);
      from = pose;
    }
  });
  const OdometryIncrement u = decomposeOdometry(from, odom_mid);
  filter_->predict(u, partialStepNoiseScale(std::max(u.trans / fc.motion_step,
                                                     (std::abs(u.rot1) + std::abs(u.rot2)) / fc.motion_step_angle)));
}

PipelineUpdate TrunkSlamPipeline::update(TrunkSweep&& sweep, bool covered)
{
  const auto t0 = std::chrono::steady_clock::now();
  const TrunkSweep& sw = sweep;
  const double t_mid = sw.stamp + 0.5 * sw.period;
  const Pose2 odom_mid = odometry_.at(t_mid);
  const bool first = !initialized_;
  RelocalizationStatus search;
  if (!initialized_ && has_prior_ && relocalize_)
  {
    std::vector<Pose2> starts;
    if (relocalize(sw, odom_mid, &search, &starts))
    {
      filter_->initialize(starts, prior_, relocalization_config_.spread_xy, relocalization_config_.spread_theta);
      search.found = true;
    }
    else
    {
      // Still searching: no estimate, nothing given to the filter.
      PipelineUpdate u;
      u.mount = Pose2(sw.mount.x, sw.mount.y, sw.mount.yaw);
      u.stamp = t_mid;
      u.odometry = odom_mid;
      u.estimate = odom_mid;
      u.odometry_covered = covered;
      u.filtered = false;
      u.localized = false;
      u.relocalization = search;
      u.stats.observations = static_cast<int>(sw.trunks.size());
      u.health = health_.status();
      u.trunks = std::move(sweep.trunks);
      seconds_filter_ += since(t0);
      return u;
    }
    last_odometry_ = odom_mid;
    last_stamp_ = t_mid;
    initialized_ = true;
  }
  if (!initialized_)
  {
    // The map frame is the odometry frame at the first update (map -> odom starts as the identity), or the
    // frame of a saved map with the robot at the start pose given in it.
    if (has_prior_)
      filter_->initialize(prior_start_, prior_);
    else
      filter_->initialize(odom_mid);
    last_odometry_ = odom_mid;
    last_stamp_ = t_mid;
    initialized_ = true;
  }
  // The motion since the last update in steps of about motion_step along the odometry's samples.
  const FastSlamConfig& fc = filter_->config();
  const Pose2 mount_pose(sw.mount.x, sw.mount.y, sw.mount.yaw);
  const double share = first ? 1.0 : evidenceShare(fc, sw.trunks, between(last_odometry_ * mount_pose,
                                                                           odom_mid * mount_pose));
  bool skip = !first && share < kMinEvidenceShare;
  if (!first && (fc.update_min_travel > 0.0 || fc.update_min_turn > 0.0))
  {
    const Pose2 d = between(last_odometry_, odom_mid);
    const bool travelled = fc.update_min_travel > 0.0 && std::hypot(d.x, d.y) >= fc.update_min_travel;
    const bool turned = fc.update_min_turn > 0.0 && std::abs(d.theta) >= fc.update_min_turn;
    skip = skip || (!travelled && !turned);
  }
  {
    const Pose2 d = between(last_odometry_, odom_mid);
    if (skip)
    {
      // Too little motion for a new look at the trunks: the estimate follows the odometry from the last update, and
      // the sweep's trunks wait (odometry frame) to be fused into the next update's.
      const Pose2 sensor_mid = odom_mid * mount_pose;
      std::vector<LookPoint> looks;
      for (const LandmarkObservation& o : sweepObservations(sw.trunks, sw.stamp, sw.period, sw.tilt_roll,
                                                            sw.tilt_pitch, sw.mount, odometry_, t_mid, sw.geometry))
      {
        LookPoint l;
        sensor_mid.transformPoint(o.range * std::cos(o.bearing), o.range * std::sin(o.bearing), &l.position.x(),
                                  &l.position.y());
        l.radius = o.radius;
        l.id = o.id;
        looks.push_back(l);
      }
      if (between_.size() < kMaxSkippedLooks)
        between_.push_back(std::move(looks));
      PipelineUpdate u;
      u.mount = Pose2(sw.mount.x, sw.mount.y, sw.mount.yaw);
      u.stamp = t_mid;
      u.odometry = odom_mid;
      u.estimate = last_estimate_ * d;
      u.odometry_covered = covered;
      u.filtered = false;
      u.stats.landmarks = static_cast<int>(filter_->best().map.size());
      u.stats.observations = static_cast<int>(sw.trunks.size());
      u.health = health_.status();
      u.trunks = std::move(sweep.trunks);
      seconds_filter_ += since(t0);
      return u;
    }
  }
  const Pose2 from_odometry = last_odometry_;
  predictMotion(fc, odom_mid, t_mid);
  last_odometry_ = odom_mid;
  last_stamp_ = t_mid;
  std::vector<LandmarkObservation> obs = sweepObservations(sw.trunks, sw.stamp, sw.period, sw.tilt_roll,
                                                           sw.tilt_pitch, sw.mount, odometry_, t_mid, sw.geometry);
  fuseSkippedLooks(&obs, odom_mid * mount_pose, between_, fc.association_gate);
  between_.clear();
  PipelineUpdate u;
  u.mount = mount_pose;  // the filter's sensor pose on base_link
  filter_->setClock(t_mid);
  u.stats = filter_->update(obs, u.mount, sw.scope, share);
  useFixes(t_mid, odom_mid);
  u.relocalization = search;
  u.health = health_.add(u.stats, filter_->config().particles);
  if (!first)
  {
    const Pose2 moved = between(from_odometry, odom_mid);
    travel_ += std::hypot(moved.x, moved.y);
  }
  u.stamp = t_mid;
  searchWhenLost(sw, odom_mid, &u);
  u.odometry = odom_mid;
  u.estimate = filter_->estimate();
  last_estimate_ = u.estimate;
  viewpoints_.add(u.estimate * u.mount, filter_->scope());
  u.odometry_covered = covered;
  u.trunks = std::move(sweep.trunks);
  seconds_filter_ += since(t0);
  return u;
}

}  // namespace core
}  // namespace rbpf_slam
