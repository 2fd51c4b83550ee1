#include "rbpf_slam/core/trunk_slam/trunk_slam_pipeline.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <cmath>

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

TrunkSlamPipeline::TrunkSlamPipeline(const TrunkDetectorConfig& detector, const TrunkSlamConfig& filter,
                                     const PipelineTiming& timing)
  : SensorPipeline(timing)
  , detector_config_(detector)
  , filter_config_(filter)
  , detector_(new TrunkDetector(detector))
  , gnss_(filter.gnss)
{
  const std::string error = filter.validate();
  if (!error.empty())
    throw std::invalid_argument("TrunkSlamPipeline: " + error);
  // Loop closure smooths the best particle's own path: the filter keeps the histories.
  if (filter_config_.loop_closure.enabled)
  {
    filter_config_.keep_history = true;
    loops_.reset(new LoopClosing(filter_config_.loop_closure, filter_config_));
  }
  filter_.reset(new FastSlam(filter_config_));
  health_ = FilterHealth(healthConfig());
}

SmoothedRun TrunkSlamPipeline::smoothed() const
{
  return smoothingJob()();
}

Eigen::Matrix3d TrunkSlamPipeline::estimateCovariance(const Pose2& estimate) const
{
  Eigen::Matrix3d c = filter_->poseCovariance();
  if (!loops_ || has_prior_ || !loops_->publishedCovariance().allFinite())
    return c;
  // The smoothed pose the estimate starts from, its marginal carried to the robot: its heading's uncertainty swings
  // the robot about it by the distance between them.
  const Pose2 from = loops_->publishedFrom();
  Eigen::Matrix3d J = Eigen::Matrix3d::Identity();
  J(0, 2) = -(estimate.y - from.y);
  J(1, 2) = estimate.x - from.x;
  return c + J * loops_->publishedCovariance() * J.transpose();
}

std::function<SmoothedRun()> TrunkSlamPipeline::smoothingJob() const
{
  if (!loops_ || has_prior_)
  {
    SmoothedRun none;
    none.reason = has_prior_ ? "no loop closure on a saved map" : "loop closure is disabled";
    return [none]() { return none; };
  }
  return loops_->smoothingJob(*filter_);
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
    ended.trees = filter_->bestTrees();
    ended_.push_back(std::move(ended));
    while (ended_.size() > kKeptEndedMaps)
      ended_.erase(ended_.begin());
  }
  // Filter and detector start over with their seeds, so that each timeline is reproducible on its own.
  detector_.reset(new TrunkDetector(detector_config_));
  filter_.reset(new FastSlam(filter_config_));
  if (relocalizer_)
    relocalizer_->reset();
  if (loops_)
    loops_->reset();
  travel_ = 0.0;
  health_ = FilterHealth(healthConfig());
  gnss_.restart();
  viewpoints_.reset(prior_viewpoints_);
  between_.clear();
  initialized_ = false;
  last_odometry_ = Pose2();
  last_estimate_ = Pose2();
  last_covariance_.setZero();
}

void TrunkSlamPipeline::setPriorMap(const std::vector<Landmark>& trees, const Pose2& start,
                                    const RelocalizationConfig& relocalization)
{
  prior_ = priorMap(trees, filter_config_);
  prior_start_ = start;
  has_prior_ = true;
  health_ = FilterHealth(healthConfig());
  relocalize_ = false;
  relocalizer_.reset(filter_config_.relocalize_when_lost ?
                         new Relocalizer(trees, relocalization, filter_config_.relocalize_when_lost) :
                         nullptr);
}

void TrunkSlamPipeline::setPriorMap(const std::vector<Landmark>& trees, const RelocalizationConfig& relocalization)
{
  setPriorMap(trees, Pose2(), relocalization);
  if (!relocalizer_)  // needed for the start
    relocalizer_.reset(new Relocalizer(trees, relocalization, false));
  relocalize_ = true;
}

HealthConfig TrunkSlamPipeline::healthConfig() const
{
  HealthConfig h;
  if (has_prior_)
    h.matched_prior_warn = 0.3;
  else if (loops_)
    h.recreated_warn = 0;  // a map made again beside itself is the loop search's to find, and the smoother's to judge
  return h;
}

void TrunkSlamPipeline::setMapViewpoints(const std::vector<Viewpoint>& viewpoints)
{
  prior_viewpoints_ = viewpoints;
  viewpoints_.reset(prior_viewpoints_);
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
  zeroUnknownTiming(&sweep);
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
  TrunkSweep sweep = detectSweep(detector_.get(), stamp, period, points, mount);
  if (!sweep.reach_shortfall.empty())
  {
    ++short_reach_sweeps_;
    if (reach_shortfall_.empty())
      reach_shortfall_ = sweep.reach_shortfall;
  }
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
  const bool taken = enqueueSweep(detectScanSweep(detector_.get(), stamp, period, scan, mount), arrival);
  seconds_extraction_ += since(t0);
  return taken ? v : StampVerdict::kOverLimit;
}

void TrunkSlamPipeline::searchWhenLost(const TrunkSweep& sw, const Pose2& odom_mid, PipelineUpdate* u)
{
  if (!has_prior_ || !relocalizer_)
    return;
  RelocalizationStatus status;
  std::vector<Pose2> starts;
  const Pose2 mount(sw.mount.x, sw.mount.y, sw.mount.yaw);
  const Relocalizer::Tracking t =
      relocalizer_->whileTracking(sw.trunks, mount, odom_mid, [this] { return filter_->estimate(); },
                                  u->health.saved_map_unobserved, travel_, &status, &starts);
  if (t == Relocalizer::Tracking::kNoSearch)
    return;
  if (t == Relocalizer::Tracking::kRecovered)
  {
    // Found elsewhere: the particles start again on the saved map, over the hypotheses and the estimate (should
    // the search be the one that is wrong, the next sweeps say so).
    filter_->setClock(u->stamp);
    filter_->initialize(starts, prior_, relocalizer_->config().spread_xy, relocalizer_->config().spread_theta,
                        relocalizer_->startLogWeights());
    health_ = FilterHealth(healthConfig());
  }
  u->relocalization = status;
}

PipelineUpdate TrunkSlamPipeline::unfiltered(TrunkSweep&& sweep, double t_mid, const Pose2& odom_mid,
                                             const Pose2& estimate, bool covered) const
{
  PipelineUpdate u;
  u.mount = Pose2(sweep.mount.x, sweep.mount.y, sweep.mount.yaw);
  u.stamp = t_mid;
  u.odometry = odom_mid;
  u.estimate = estimate;
  u.covariance = last_covariance_;
  u.odometry_covered = covered;
  u.filtered = false;
  u.stats.observations = static_cast<int>(sweep.trunks.size());
  u.health = health_.status();
  u.trunks = std::move(sweep.trunks);
  return u;
}

PipelineUpdate TrunkSlamPipeline::update(TrunkSweep&& sweep, bool covered)
{
  const auto t0 = std::chrono::steady_clock::now();
  const TrunkSweep& sw = sweep;
  const double t_mid = sw.stamp + 0.5 * sw.period;
  const Pose2 odom_mid = odometry_.at(t_mid);
  const Pose2 mount_pose(sw.mount.x, sw.mount.y, sw.mount.yaw);
  const bool first = !initialized_;
  RelocalizationStatus search;
  if (first)
  {
    // The map frame is the odometry frame at the first update (map -> odom starts as the identity), the frame of a
    // saved map with the robot at the start pose given in it, or where the search in it found the robot.
    std::vector<Pose2> starts;
    if (!has_prior_)
      filter_->initialize(odom_mid);
    else if (!relocalize_)
      filter_->initialize(prior_start_, prior_);
    else if (relocalizer_->search(sw.trunks, mount_pose, odom_mid, &search, &starts))
    {
      filter_->initialize(starts, prior_, relocalizer_->config().spread_xy, relocalizer_->config().spread_theta,
                          relocalizer_->startLogWeights());
      search.found = true;
    }
    else
    {
      // Still searching: no estimate, nothing given to the filter.
      PipelineUpdate u = unfiltered(std::move(sweep), t_mid, odom_mid, odom_mid, covered);
      u.localized = false;
      u.relocalization = search;
      seconds_filter_ += since(t0);
      return u;
    }
    last_odometry_ = odom_mid;
    last_stamp_ = t_mid;
    initialized_ = true;
  }
  const FastSlamConfig& fc = filter_->config();
  const double share = first ? 1.0 : evidenceShare(fc, sw.trunks, between(last_odometry_ * mount_pose,
                                                                           odom_mid * mount_pose));
  if (!first && share < kMinEvidenceShare)
  {
    // Too little motion for a new look at the trunks: the estimate follows the odometry from the last update, and
    // the sweep's trunks wait (odometry frame) to be fused into the next update's.
    if (between_.size() < kMaxSkippedLooks)
      between_.push_back(sweepLooks(sw, odometry_, t_mid));
    PipelineUpdate u =
        unfiltered(std::move(sweep), t_mid, odom_mid, last_estimate_ * between(last_odometry_, odom_mid), covered);
    u.stats.landmarks = static_cast<int>(filter_->best().map.size());
    seconds_filter_ += since(t0);
    return u;
  }
  const Pose2 from_odometry = last_odometry_;
  filter_->predictAlong(odometry_, last_stamp_, last_odometry_, t_mid, odom_mid);
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
  gnss_.use(t_mid, odom_mid, odometry_, filter_.get());
  u.relocalization = search;
  if (loops_ && !has_prior_)
  {
    u.loop = loops_->afterUpdate(filter_.get(), t_mid, odom_mid, u.mount, obs, share);
    // The smoother's verdict on a revisit: a loop it could not bring together warns until one closes.
    if (u.loop.kind == LoopEvent::Kind::kClosed)
      health_.revisit(true, std::string());
    else if (u.loop.kind == LoopEvent::Kind::kRejected && u.loop.inconsistent)
      health_.revisit(false, u.loop.reason);
  }
  u.health = health_.add(u.stats, filter_->config().particles);
  if (!first)
  {
    const Pose2 moved = between(from_odometry, odom_mid);
    travel_ += std::hypot(moved.x, moved.y);
  }
  u.stamp = t_mid;
  searchWhenLost(sw, odom_mid, &u);
  u.odometry = odom_mid;
  u.estimate = loops_ && !has_prior_ ? loops_->published(filter_->estimate()) : filter_->estimate();
  u.covariance = estimateCovariance(u.estimate);
  last_estimate_ = u.estimate;
  last_covariance_ = u.covariance;
  viewpoints_.add(u.estimate * u.mount, filter_->scope());
  u.odometry_covered = covered;
  u.trunks = std::move(sweep.trunks);
  seconds_filter_ += since(t0);
  return u;
}

}  // namespace core
}  // namespace rbpf_slam
