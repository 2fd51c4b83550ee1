#include "rbpf_slam/core/trunk_slam_pipeline.h"

#include <chrono>
#include <algorithm>
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
  p.tilt_roll = stats.tilt_roll;
  p.tilt_pitch = stats.tilt_pitch;
  pending_.push_back(std::move(p));
  seconds_extraction_ += since(t0);
}

void TrunkSlamPipeline::addScan(double stamp, double period, const PlanarScan& scan)
{
  const auto t0 = std::chrono::steady_clock::now();
  Pending p;
  p.stamp = stamp;
  p.period = period;
  p.trunks = detector_.detectScan(scan);
  p.tilt_roll = 0.0;
  p.tilt_pitch = 0.0;
  p.geometry.start_angle = scan.angle_min;
  p.geometry.span = std::max(1e-9, std::abs(scan.angle_increment) * (scan.ranges.size() > 1 ? scan.ranges.size() - 1 : 1));
  pending_.push_back(std::move(p));
  seconds_extraction_ += since(t0);
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

std::vector<PipelineUpdate> TrunkSlamPipeline::process(bool flush)
{
  std::vector<PipelineUpdate> done;
  const Pose2 mount(mount_.x, mount_.y, mount_.yaw);  // the filter's sensor pose on base_link
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
    const std::vector<LandmarkObservation> obs =
        sweepObservations(ps.trunks, ps.stamp, ps.period, ps.tilt_roll, ps.tilt_pitch, mount_, odometry_, t_mid,
                          ps.geometry);
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
