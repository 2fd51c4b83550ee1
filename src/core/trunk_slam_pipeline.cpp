#include "rbpf_slam/core/trunk_slam_pipeline.h"

#include <chrono>
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

TrunkSlamPipeline::TrunkSlamPipeline(const TrunkDetectorConfig& detector, const FastSlamConfig& filter,
                                     const SensorMount& mount)
  : detector_(detector), filter_(filter), mount_(mount)
{
}

bool TrunkSlamPipeline::addOdometry(double stamp, const Pose2& pose)
{
  return odometry_.add(stamp, pose) != OdometryBuffer::AddResult::kBackwards;
}

void TrunkSlamPipeline::addSweep(double stamp, double period, const std::vector<Eigen::Vector3f>& points)
{
  const auto t0 = std::chrono::steady_clock::now();
  TrunkDetectorStats stats;
  Pending p;
  p.stamp = stamp;
  p.period = period;
  p.trunks = detector_.detect(points, Eigen::Matrix3d::Identity(), &stats);
  const Eigen::Vector2d lever = mount_.z * Eigen::Vector2d(std::tan(stats.tilt_pitch), -std::tan(stats.tilt_roll));
  for (auto& t : p.trunks)
  {
    t.center += lever;
    t.range = t.center.norm();
    t.bearing = std::atan2(t.center.y(), t.center.x());
  }
  pending_.push_back(std::move(p));
  seconds_extraction_ += since(t0);
}

std::vector<PipelineUpdate> TrunkSlamPipeline::process(bool flush)
{
  std::vector<PipelineUpdate> done;
  const Pose2 mount(mount_.x, mount_.y, mount_.yaw);
  while (!pending_.empty() && !odometry_.empty() && (flush || odometry_.covers(pending_.front().stamp + pending_.front().period)))
  {
    Pending ps = std::move(pending_.front());
    pending_.pop_front();
    const auto t0 = std::chrono::steady_clock::now();
    const double t_mid = ps.stamp + 0.5 * ps.period;
    const Pose2 odom_mid = odometry_.at(t_mid);
    if (!initialized_)
    {
      filter_.initialize(Pose2());  // the map frame starts at the first odometry pose
      last_odometry_ = odometry_.at(odometry_.earliest());
      initialized_ = true;
    }
    filter_.predict(decomposeOdometry(last_odometry_, odom_mid));
    last_odometry_ = odom_mid;
    std::vector<LandmarkObservation> obs;
    obs.reserve(ps.trunks.size());
    const Pose2 sensor_mid = odom_mid * mount;
    const Pose2 sensor_mid_inv = sensor_mid.inverse();
    for (const auto& t : ps.trunks)
    {
      const double t_obs = ps.stamp + ps.period * (wrapAngle(t.bearing) + M_PI) / (2.0 * M_PI);
      const Pose2 sensor_obs = odometry_.at(t_obs) * mount;
      double wx = 0.0, wy = 0.0, mx = 0.0, my = 0.0;
      sensor_obs.transformPoint(t.center.x(), t.center.y(), &wx, &wy);
      sensor_mid_inv.transformPoint(wx, wy, &mx, &my);
      TrunkObservation moved = t;
      moved.center = Eigen::Vector2d(mx, my);
      const Eigen::Matrix2d R = Eigen::Rotation2Dd(sensor_obs.theta - sensor_mid.theta).toRotationMatrix();
      moved.covariance = R * t.covariance * R.transpose();
      obs.push_back(toLandmarkObservation(moved));
    }
    PipelineUpdate u;
    u.stats = filter_.update(obs, mount);
    u.stamp = t_mid;
    u.odometry = odom_mid;
    u.trunks = std::move(ps.trunks);
    done.push_back(std::move(u));
    seconds_filter_ += since(t0);
    // Odometry older than what the next sweep needs is no longer kept.
    const double keep_from = pending_.empty() ? t_mid : std::min(t_mid, pending_.front().stamp);
    odometry_.dropBefore(keep_from - 0.1);
  }
  return done;
}

}  // namespace core
}  // namespace rbpf_slam
