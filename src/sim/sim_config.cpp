#include "rbpf_slam/sim/sim_config.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "rbpf_slam/sim/waypoints_file.h"

namespace rbpf_slam
{
namespace sim
{
namespace
{
constexpr double kDeg = M_PI / 180.0;

void readDegrees(const io::ParamSource& p, const std::string& key, double* radians)
{
  double deg = *radians / kDeg;
  if (p.get(key, &deg))
    *radians = deg * kDeg;
}

void readMount(const io::ParamSource& p, const std::string& prefix, sim::Mount* m)
{
  p.get(prefix + "/x", &m->x);
  p.get(prefix + "/y", &m->y);
  p.get(prefix + "/z", &m->z);
  readDegrees(p, prefix + "/roll_deg", &m->roll);
  readDegrees(p, prefix + "/pitch_deg", &m->pitch);
  readDegrees(p, prefix + "/yaw_deg", &m->yaw);
}
}  // namespace

void readSimulatorConfig(const io::ParamSource& p, sim::SimulatorConfig* c)
{
  p.getSeed("seed", &c->seed);
  p.get("physics_rate", &c->physics_rate);
  p.get("truth_rate", &c->truth_rate);
  p.get("start/x", &c->start.x);
  p.get("start/y", &c->start.y);
  readDegrees(p, "start/yaw_deg", &c->start.theta);

  std::string model;
  if (p.get("robot/model", &model) && !sim::parseRobotModel(model, &c->robot.model))
    throw std::runtime_error("invalid simulator parameter: robot/model must be diff_drive or ackermann, got '" +
                             model + "'");
  p.get("robot/track_width", &c->robot.track_width);
  p.get("robot/turn_slip", &c->robot.turn_slip);
  p.get("robot/max_linear_accel", &c->robot.max_linear_accel);
  p.get("robot/max_angular_accel", &c->robot.max_angular_accel);
  p.get("robot/footprint_radius", &c->robot.footprint_radius);
  p.get("robot/wheelbase", &c->robot.wheelbase);
  readDegrees(p, "robot/max_steer_deg", &c->robot.max_steer);
  readDegrees(p, "robot/max_steer_rate_deg", &c->robot.max_steer_rate);
  p.get("robot/length", &c->robot.length);
  p.get("robot/width", &c->robot.width);
  p.get("robot/rear_overhang", &c->robot.rear_overhang);

  p.get("odometry/left_scale", &c->odometry.left_scale);
  p.get("odometry/right_scale", &c->odometry.right_scale);
  p.get("odometry/wheel_sigma", &c->odometry.wheel_sigma);
  p.get("odometry/track_width", &c->odometry.track_width);
  p.get("odometry/speed_scale", &c->odometry.speed_scale);
  p.get("odometry/speed_sigma", &c->odometry.speed_sigma);
  readDegrees(p, "odometry/steer_bias_deg", &c->odometry.steer_bias);
  readDegrees(p, "odometry/steer_sigma_deg", &c->odometry.steer_sigma);
  p.get("odometry/wheelbase", &c->odometry.wheelbase);
  p.get("odometry/rate", &c->odometry.rate);
  p.get("odometry/latency", &c->odometry.latency);

  sim::Lidar3DConfig& l3 = c->lidar3d;
  p.get("lidar3d/enabled", &l3.enabled);
  p.get("lidar3d/rings", &l3.rings);
  readDegrees(p, "lidar3d/min_elevation_deg", &l3.min_elevation);
  readDegrees(p, "lidar3d/max_elevation_deg", &l3.max_elevation);
  readDegrees(p, "lidar3d/azimuth_resolution_deg", &l3.azimuth_resolution);
  p.get("lidar3d/rate", &l3.rate);
  p.get("lidar3d/min_range", &l3.min_range);
  p.get("lidar3d/max_range", &l3.max_range);
  p.get("lidar3d/range_sigma", &l3.range_sigma);
  readMount(p, "lidar3d/mount", &l3.mount);

  sim::Lidar2DConfig& l2 = c->lidar2d;
  p.get("lidar2d/enabled", &l2.enabled);
  readDegrees(p, "lidar2d/angle_min_deg", &l2.angle_min);
  readDegrees(p, "lidar2d/angle_max_deg", &l2.angle_max);
  p.get("lidar2d/beams", &l2.beams);
  p.get("lidar2d/rate", &l2.rate);
  p.get("lidar2d/min_range", &l2.min_range);
  p.get("lidar2d/max_range", &l2.max_range);
  p.get("lidar2d/range_sigma", &l2.range_sigma);
  readMount(p, "lidar2d/mount", &l2.mount);

  p.get("imu/enabled", &c->imu.enabled);
  p.get("imu/rate", &c->imu.rate);
  p.get("imu/gyro_sigma", &c->imu.gyro_sigma);
  p.get("imu/gyro_bias_sigma", &c->imu.gyro_bias_sigma);
  p.get("imu/accel_sigma", &c->imu.accel_sigma);
  p.get("imu/accel_bias_sigma", &c->imu.accel_bias_sigma);

  core::GnssConfig& g = c->gnss;
  p.get("gps/enabled", &g.enabled);
  p.get("gps/rate", &g.rate);
  p.get("gps/origin/latitude", &g.origin.latitude);
  p.get("gps/origin/longitude", &g.origin.longitude);
  p.get("gps/origin/altitude", &g.origin.altitude);
  readDegrees(p, "gps/world_yaw_deg", &g.world_yaw);
  p.get("gps/open_sigma", &g.open_sigma);
  p.get("gps/canopy_sigma", &g.canopy_sigma);
  p.get("gps/open_bias_sigma", &g.open_bias_sigma);
  p.get("gps/canopy_bias_sigma", &g.canopy_bias_sigma);
  p.get("gps/bias_time", &g.bias_time);
  p.get("gps/vertical_factor", &g.vertical_factor);
  p.get("gps/canopy_radius", &g.canopy_radius);
  p.get("gps/crown_ratio", &g.crown_ratio);
  p.get("gps/outage_interval", &g.outage_interval);
  p.get("gps/outage_duration", &g.outage_duration);
  p.get("gps/antenna/x", &g.antenna.x());
  p.get("gps/antenna/y", &g.antenna.y());
  p.get("gps/antenna/z", &g.antenna.z());

  std::string error;
  if (!c->validate(&error))
    throw std::runtime_error("invalid simulator parameter: " + error);
}

void readScenarioConfig(const io::ParamSource& p, sim::ScenarioConfig* c)
{
  readSimulatorConfig(p, &c->sim);
  p.get("follower/speed", &c->follower.speed);
  p.get("follower/lookahead", &c->follower.lookahead);
  p.get("follower/max_angular", &c->follower.max_angular);
  p.get("follower/goal_tolerance", &c->follower.goal_tolerance);
  sim::PathFollowerConfig& f = c->follower;
  p.get("follower/avoid_obstacles", &f.avoid_obstacles);
  p.get("follower/robot_radius", &f.robot_radius);
  p.get("follower/clearance", &f.clearance);
  p.get("follower/min_clearance", &f.min_clearance);
  p.get("follower/max_departure", &f.max_departure);
  p.get("follower/horizon", &f.horizon);
  p.get("follower/max_curvature", &f.max_curvature);
  p.get("follower/obstacle_memory", &f.obstacle_memory);
  p.get("follower/obstacle_range", &f.obstacle_range);
  p.get("follower/obstacle_min_height", &f.obstacle_min_height);
  p.get("follower/obstacle_max_height", &f.obstacle_max_height);
  p.get("follower/obstacle_min_extent", &f.obstacle_min_extent);
  std::string steer_on;
  if (p.get("follower/steer_on", &steer_on) && !sim::parseSteerOn(steer_on, &c->steer_on))
    throw std::runtime_error("invalid follower parameter: steer_on must be odometry or truth, got '" + steer_on + "'");
  p.get("relay/linear_sigma_abs", &c->relay.linear_sigma_abs);
  p.get("relay/linear_sigma_rel", &c->relay.linear_sigma_rel);
  p.get("relay/angular_sigma_abs", &c->relay.angular_sigma_abs);
  p.get("relay/angular_sigma_rel", &c->relay.angular_sigma_rel);
  p.get("relay/max_linear", &c->relay.max_linear);
  p.get("relay/max_angular", &c->relay.max_angular);
  p.get("timeout", &c->timeout);
  std::string error;
  if (!c->relay.validate(&error))
    throw std::runtime_error("invalid relay parameter: " + error);
  if (!(c->follower.speed > 0.0) || !(c->follower.lookahead > 0.0))
    throw std::runtime_error("invalid follower parameter: speed and lookahead must be > 0");
  std::string follower_error;
  if (!c->follower.validate(&follower_error))
    throw std::runtime_error("invalid follower parameter: " + follower_error);
}

ScenarioConfig loadScenario(const std::string& path, const std::string& drive, const core::Pose2* start,
                            std::vector<std::string>* unknown)
{
  ScenarioConfig config;
  unknown->clear();
  if (!path.empty())
  {
    io::YamlParamSource params(path);
    readScenarioConfig(params, &config);
    *unknown = params.unusedKeys();
  }
  if (start)
    config.sim.start = *start;
  std::string error;
  config.drive = namedDrive(drive, &error);
  if (config.drive.empty())
    throw std::runtime_error(error);
  return config;
}

}  // namespace sim
}  // namespace rbpf_slam
