#include "rbpf_slam/sim/forest_simulator.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "rbpf_slam/core/grid/occupancy_image.h"

namespace rbpf_slam
{
namespace sim
{
using core::GnssConfig;
using core::GnssReceiver;
using core::interpolate;
using core::OccupancyImage;
using core::Pose2;

namespace
{
std::int64_t ticksOf(double seconds, double physics_rate)
{
  return static_cast<std::int64_t>(std::llround(seconds * physics_rate));
}

float intensityOf(HitKind kind)
{
  switch (kind)
  {
    case HitKind::kTrunk:
      return 60.0f;
    case HitKind::kFoliage:
      return 25.0f;
    case HitKind::kRock:
      return 45.0f;
    case HitKind::kBranch:
    case HitKind::kStub:
      return 40.0f;
    case HitKind::kSapling:
      return 55.0f;
    case HitKind::kBox:
      return 80.0f;
    case HitKind::kGround:
      return 15.0f;
    default:
      return 0.0f;
  }
}
}  // namespace

Eigen::Isometry3d Mount::transform() const
{
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(x, y, z);
  t.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  return t;
}

bool SimulatorConfig::validate(std::string* error) const
{
  auto fail = [&](const std::string& what) {
    if (error)
      *error = what;
    return false;
  };
  if (!(physics_rate > 0.0))
    return fail("physics_rate must be > 0");
  if (!odometry.validate(error))
    return false;
  if (!robot.validate(error))
    return false;
  if (lidar3d.enabled && (lidar3d.rings < 1 || !(lidar3d.azimuth_resolution > 0.0) || !(lidar3d.rate > 0.0) ||
                          !(lidar3d.min_range < lidar3d.max_range) || lidar3d.min_elevation > lidar3d.max_elevation))
    return fail("lidar3d: need rings >= 1, azimuth_resolution > 0, rate > 0, min_range < max_range, "
                "min_elevation <= max_elevation");
  if (lidar2d.enabled && (lidar2d.beams < 2 || !(lidar2d.rate > 0.0) || !(lidar2d.min_range < lidar2d.max_range) ||
                          !(lidar2d.angle_min < lidar2d.angle_max)))
    return fail("lidar2d: need beams >= 2, rate > 0, min_range < max_range, angle_min < angle_max");
  if (imu.enabled && !(imu.rate > 0.0))
    return fail("imu rate must be > 0");
  if (!gnss.validate(error))
    return false;
  if (!(truth_rate > 0.0))
    return fail("truth_rate must be > 0");
  return true;
}

void SimulatorOutput::clear()
{
  odometry.clear();
  sweeps.clear();
  scans.clear();
  imu.clear();
  truth.clear();
  gnss.clear();
}

bool SimulatorOutput::empty() const
{
  return odometry.empty() && sweeps.empty() && scans.empty() && imu.empty() && truth.empty() && gnss.empty();
}

ForestSimulator::ForestSimulator(const ForestWorld& world, const SimulatorConfig& config)
  : ForestSimulator(world, config, nullptr)
{
}

ForestSimulator::ForestSimulator(const ForestWorld& world, const SimulatorConfig& config,
                                 std::shared_ptr<const OccupancyImage> image)
  : config_(config)
  , random_(config.seed)
  , sensor_random_(config.seed ^ 0x9E3779B97F4A7C15ull)
  , caster_(world)
  , image_(std::move(image))
  , robot_(makeRobot(config.robot, config.odometry, config.start, &random_))
{
  init();
}

ForestSimulator::~ForestSimulator() = default;

void ForestSimulator::init()
{
  const double hz = config_.physics_rate;
  odom_period_ = std::max<std::int64_t>(1, ticksOf(1.0 / config_.odometry.rate, hz));
  latency_ticks_ = std::max<std::int64_t>(0, ticksOf(config_.odometry.latency, hz));
  sweep_period_ = std::max<std::int64_t>(1, ticksOf(1.0 / config_.lidar3d.rate, hz));
  scan_period_ = std::max<std::int64_t>(1, ticksOf(1.0 / config_.lidar2d.rate, hz));
  imu_period_ = std::max<std::int64_t>(1, ticksOf(1.0 / config_.imu.rate, hz));
  truth_period_ = std::max<std::int64_t>(1, ticksOf(1.0 / config_.truth_rate, hz));
  if (config_.gnss.enabled)
  {
    gnss_period_ = std::max<std::int64_t>(1, ticksOf(1.0 / config_.gnss.rate, hz));
    gnss_.reset(new GnssReceiver(config_.gnss, config_.seed ^ 0x6A09E667F3BCC909ull));
  }
  if (config_.imu.enabled)
  {
    for (int i = 0; i < 3; ++i)
    {
      gyro_bias_[i] = random_.gaussian(config_.imu.gyro_bias_sigma);
      accel_bias_[i] = random_.gaussian(config_.imu.accel_bias_sigma);
    }
  }
  const Lidar3DConfig& l = config_.lidar3d;
  for (int r = 0; r < l.rings; ++r)
  {
    const double el = l.rings == 1 ? l.min_elevation :
                                     l.min_elevation + (l.max_elevation - l.min_elevation) * r / (l.rings - 1);
    ring_sin_.push_back(std::sin(el));
    ring_cos_.push_back(std::cos(el));
  }
  history_.emplace_back(0, robot_->pose());
}

Eigen::Isometry3d ForestSimulator::bodyPose(const Pose2& pose) const
{
  const Ground& ground = caster_.ground();
  const Eigen::Vector2d g = ground.gradient(pose.x, pose.y);
  const Eigen::Vector3d n = Eigen::Vector3d(-g.x(), -g.y(), 1.0).normalized();
  const Eigen::Vector3d heading(std::cos(pose.theta), std::sin(pose.theta), 0.0);
  // The body's x axis stays in the vertical plane of the heading (so yaw is the planar heading) and
  // tilts up or down with the slope until it is tangent to the ground.
  const Eigen::Vector3d x_axis = (heading - heading.dot(n) / n.z() * Eigen::Vector3d::UnitZ()).normalized();
  Eigen::Isometry3d body = Eigen::Isometry3d::Identity();
  body.linear().col(0) = x_axis;
  body.linear().col(1) = n.cross(x_axis);
  body.linear().col(2) = n;
  body.translation() = Eigen::Vector3d(pose.x, pose.y, ground.height(pose.x, pose.y));
  return body;
}

Pose2 ForestSimulator::poseAt(double t) const
{
  const double ft = t * config_.physics_rate;
  const auto lower = static_cast<std::int64_t>(std::floor(ft));
  const std::int64_t first = history_.front().first, last = history_.back().first;
  if (lower < first)
    return history_.front().second;
  if (lower >= last)
    return history_.back().second;
  const std::size_t i = static_cast<std::size_t>(lower - first);
  return interpolate(history_[i].second, history_[i + 1].second, ft - static_cast<double>(lower));
}

void ForestSimulator::castSweep(double stamp, LidarSweep* sweep)
{
  const Lidar3DConfig& l = config_.lidar3d;
  const Eigen::Isometry3d mount = l.mount.transform();
  const int columns = std::max(1, static_cast<int>(std::lround(2.0 * M_PI / l.azimuth_resolution)));
  const double period = 1.0 / l.rate;
  sweep->stamp = stamp;
  sweep->points.clear();
  sweep->points.reserve(static_cast<std::size_t>(columns) * l.rings);
  for (int c = 0; c < columns; ++c)
  {
    // Columns sweep counter-clockwise from behind the sensor; each is cast from the pose the
    // robot has at its own instant (motion distortion, as a real spinning lidar has).
    const double dt = period * c / columns;
    const Eigen::Isometry3d sensor = bodyPose(poseAt(stamp + dt)) * mount;
    const double az = -M_PI + 2.0 * M_PI * c / columns;
    const double ca = std::cos(az), sa = std::sin(az);
    for (int r = 0; r < l.rings; ++r)
    {
      const Eigen::Vector3d local(ring_cos_[r] * ca, ring_cos_[r] * sa, ring_sin_[r]);
      const Eigen::Vector3d dir = sensor.linear() * local;
      const RayHit hit = caster_.cast(sensor.translation(), dir, l.max_range, sensor_random_);
      if (hit.kind == HitKind::kNone)
        continue;
      const double range = hit.range + sensor_random_.gaussian(l.range_sigma);
      if (range < l.min_range || range > l.max_range)
        continue;
      const Eigen::Vector3d p = local * range;
      sweep->points.push_back({ static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()),
                                intensityOf(hit.kind), static_cast<std::uint16_t>(r), static_cast<float>(dt) });
    }
  }
}

void ForestSimulator::castScan(double stamp, LaserScan2D* scan)
{
  const Lidar2DConfig& l = config_.lidar2d;
  const Eigen::Isometry3d mount = l.mount.transform();
  scan->stamp = stamp;
  scan->angle_min = l.angle_min;
  scan->angle_increment = (l.angle_max - l.angle_min) / (l.beams - 1);
  scan->scan_time = 1.0 / l.rate;
  // A spinning 2D scanner covers its field of view in the matching share of a revolution.
  scan->time_increment = scan->scan_time * (scan->angle_increment / (2.0 * M_PI));
  scan->range_min = l.min_range;
  scan->range_max = l.max_range;
  scan->ranges.assign(static_cast<std::size_t>(l.beams), std::numeric_limits<float>::infinity());
  for (int b = 0; b < l.beams; ++b)
  {
    const double t = stamp + b * scan->time_increment;
    const double angle = l.angle_min + b * scan->angle_increment;
    double range = std::numeric_limits<double>::infinity();
    if (image_)
    {
      const Pose2 pose = poseAt(t);
      const Pose2 sensor = pose * Pose2(l.mount.x, l.mount.y, l.mount.yaw);
      range = image_->castRay(sensor.x, sensor.y, sensor.theta + angle, l.max_range);
    }
    else
    {
      const Eigen::Isometry3d sensor = bodyPose(poseAt(t)) * mount;
      const Eigen::Vector3d dir = sensor.linear() * Eigen::Vector3d(std::cos(angle), std::sin(angle), 0.0);
      range = caster_.cast(sensor.translation(), dir, l.max_range, sensor_random_).range;
    }
    if (!std::isfinite(range))
      continue;  // REP-117: +inf, no return
    range += sensor_random_.gaussian(l.range_sigma);
    if (range > l.max_range)
      continue;
    scan->ranges[static_cast<std::size_t>(b)] =
        range < l.min_range ? -std::numeric_limits<float>::infinity() : static_cast<float>(range);
  }
}

std::string Collision::what(const ForestWorld& world) const
{
  char text[160];
  if (kind == HitKind::kTrunk && index >= 0 && index < static_cast<int>(world.trunks.size()))
  {
    const TrunkSpec& t = world.trunks[static_cast<std::size_t>(index)];
    std::snprintf(text, sizeof(text), "trunk %d (r %.2f m at %.2f, %.2f)", index, t.radius, t.x, t.y);
  }
  else if (kind == HitKind::kBox && index >= 0 && index < static_cast<int>(world.boxes.size()))
  {
    const BoxSpec& b = world.boxes[static_cast<std::size_t>(index)];
    std::snprintf(text, sizeof(text), "box %d (%.1f x %.1f m at %.2f, %.2f)", index, b.length, b.width, b.x, b.y);
  }
  else
  {
    std::snprintf(text, sizeof(text), "nothing");
  }
  return text;
}

Collision ForestSimulator::touching(const Pose2& pose) const
{
  Collision c;
  c.pose = pose;
  const ForestWorld& w = caster_.world();
  const RobotConfig& r = config_.robot;
  const bool car = r.model == RobotModel::kAckermann;
  BoxSpec body;
  double reach = r.footprint_radius;  // [m] from base_link to the farthest point of the footprint
  if (car)
  {
    const double ahead = 0.5 * r.length - r.rear_overhang;  // body centre ahead of the rear axle
    body.x = pose.x + ahead * std::cos(pose.theta);
    body.y = pose.y + ahead * std::sin(pose.theta);
    body.yaw = pose.theta;
    body.length = r.length;
    body.width = r.width;
    reach = std::hypot(std::max(r.rear_overhang, r.length - r.rear_overhang), 0.5 * r.width);
  }
  const Eigen::Vector2d at(pose.x, pose.y);
  for (std::size_t i = 0; i < w.trunks.size(); ++i)
  {
    const TrunkSpec& t = w.trunks[i];
    const Eigen::Vector2d foot(t.x, t.y);
    const double bound = reach + t.radius;
    if ((foot - at).squaredNorm() > bound * bound)
      continue;
    if (car ? boxDistance(body, foot) < t.radius : (foot - at).norm() < r.footprint_radius + t.radius)
    {
      c.kind = HitKind::kTrunk;
      c.index = static_cast<int>(i);
      return c;
    }
  }
  for (std::size_t i = 0; i < w.boxes.size(); ++i)
  {
    const BoxSpec& b = w.boxes[i];
    const double bound = reach + 0.5 * std::hypot(b.length, b.width);
    if ((Eigen::Vector2d(b.x, b.y) - at).squaredNorm() > bound * bound)
      continue;
    if (car ? boxesOverlap(body, b) : boxDistance(b, at) < r.footprint_radius)
    {
      c.kind = HitKind::kBox;
      c.index = static_cast<int>(i);
      return c;
    }
  }
  return c;
}

void ForestSimulator::step(SimulatorOutput* out)
{
  if (!collided_)
  {
    robot_->step(command_, dt());
    if (!image_)
    {
      const Collision c = touching(robot_->pose());
      if (c.kind != HitKind::kNone)
      {
        robot_->halt();
        collided_ = true;
        collision_ = c;
        collision_.stamp = static_cast<double>(tick_ + 1) / config_.physics_rate;
      }
    }
  }
  ++tick_;
  history_.emplace_back(tick_, robot_->pose());
  const std::int64_t keep = static_cast<std::int64_t>(config_.physics_rate) + sweep_period_ + scan_period_ + 2;
  while (static_cast<std::int64_t>(history_.size()) > keep)
    history_.pop_front();
  const double now = time();

  if (tick_ % odom_period_ == 0)
  {
    OdometrySample s;
    s.stamp = now;
    s.pose = robot_->readOdometry(&s.linear, &s.angular, static_cast<double>(tick_ - last_odom_tick_) * dt());
    last_odom_tick_ = tick_;
    pending_odometry_.emplace_back(tick_ + latency_ticks_, s);
  }
  while (!pending_odometry_.empty() && pending_odometry_.front().first <= tick_)
  {
    out->odometry.push_back(pending_odometry_.front().second);
    pending_odometry_.pop_front();
  }

  if (config_.imu.enabled && tick_ % imu_period_ == 0)
  {
    const Eigen::Isometry3d body = bodyPose(robot_->pose());
    const double h = static_cast<double>(imu_period_) * dt();
    const Eigen::Vector3d velocity = (body.translation() - last_imu_body_.translation()) / h;
    if (have_imu_state_)
    {
      ImuSample s;
      s.stamp = now;
      const Eigen::AngleAxisd delta(last_imu_body_.linear().transpose() * body.linear());
      s.angular_velocity = delta.axis() * delta.angle() / h + gyro_bias_;
      const Eigen::Vector3d accel_world = (velocity - last_imu_velocity_) / h + Eigen::Vector3d(0.0, 0.0, 9.80665);
      s.linear_acceleration = body.linear().transpose() * accel_world + accel_bias_;
      for (int i = 0; i < 3; ++i)
      {
        s.angular_velocity[i] += random_.gaussian(config_.imu.gyro_sigma);
        s.linear_acceleration[i] += random_.gaussian(config_.imu.accel_sigma);
      }
      out->imu.push_back(s);
    }
    have_imu_state_ = true;
    last_imu_body_ = body;
    last_imu_velocity_ = velocity;
  }

  // A sweep (scan) is delivered when its last column (beam) has been measured.
  if (config_.lidar3d.enabled && !image_ && tick_ % sweep_period_ == 0)
  {
    out->sweeps.emplace_back();
    castSweep(static_cast<double>(tick_ - sweep_period_) * dt(), &out->sweeps.back());
  }
  if (config_.lidar2d.enabled && tick_ % scan_period_ == 0)
  {
    out->scans.emplace_back();
    castScan(static_cast<double>(tick_ - scan_period_) * dt(), &out->scans.back());
  }
  if (tick_ % truth_period_ == 0)
    out->truth.push_back({ now, robot_->pose(), bodyPose(robot_->pose()) });
  if (gnss_ && tick_ % gnss_period_ == 0)
  {
    const Eigen::Vector3d antenna = bodyPose(robot_->pose()) * config_.gnss.antenna;
    out->gnss.push_back(gnss_->sample(now, antenna, image_ ? 0.0 : canopyAt(antenna.x(), antenna.y())));
  }
}

double ForestSimulator::canopyAt(double x, double y) const
{
  const GnssConfig& g = config_.gnss;
  const double disc = M_PI * g.canopy_radius * g.canopy_radius;
  double covered = 0.0;
  for (const TrunkSpec& t : world().trunks)
  {
    const double crown = g.crown_ratio * t.radius;
    if (std::hypot(t.x - x, t.y - y) > g.canopy_radius + crown)
      continue;
    covered += M_PI * crown * crown;
  }
  return std::min(1.0, covered / disc);
}

}  // namespace sim
}  // namespace rbpf_slam
