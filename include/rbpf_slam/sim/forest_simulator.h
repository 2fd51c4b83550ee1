#ifndef RBPF_SLAM_SIM_FOREST_SIMULATOR_H
#define RBPF_SLAM_SIM_FOREST_SIMULATOR_H

#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "rbpf_slam/sim/diff_drive.h"
#include "rbpf_slam/sim/forest_world.h"
#include "rbpf_slam/core/forest_map/gnss.h"
#include "rbpf_slam/core/filter/pose2.h"
#include "rbpf_slam/core/filter/random.h"
#include "rbpf_slam/sim/ray_caster.h"

namespace rbpf_slam
{
namespace core
{
class OccupancyImage;
}  // namespace core

namespace sim
{
/** @brief Mounting of a sensor on base_link (x forward, z up, REP-103). */
struct Mount
{
  double x = 0.0, y = 0.0, z = 0.0;          ///< [m]
  double roll = 0.0, pitch = 0.0, yaw = 0.0;  ///< [rad]
  Eigen::Isometry3d transform() const;
};

/** @brief A multi-ring spinning lidar (defaults: VLP-16). */
struct Lidar3DConfig
{
  bool enabled = true;
  int rings = 16;
  double min_elevation = -15.0 * M_PI / 180.0;  ///< [rad] lowest ring
  double max_elevation = 15.0 * M_PI / 180.0;   ///< [rad] highest ring
  double azimuth_resolution = 0.2 * M_PI / 180.0; ///< [rad]
  double rate = 10.0;        ///< [Hz] sweeps per second
  double min_range = 0.4;    ///< [m]
  double max_range = 100.0;  ///< [m]
  double range_sigma = 0.02; ///< [m]
  Mount mount{ 0.0, 0.0, 1.8, 0.0, 0.0, 0.0 };
};

/** @brief One lidar return, in the sensor frame at the instant it was measured. */
struct LidarPoint
{
  float x, y, z;
  float intensity;
  std::uint16_t ring;
  float time;  ///< [s] after the sweep's stamp
};

struct LidarSweep
{
  double stamp = 0.0;  ///< [s] time of the first column
  std::vector<LidarPoint> points;
};

/** @brief A planar scanner (REP-117 ranges: +inf no return, -inf closer than min_range). */
struct Lidar2DConfig
{
  bool enabled = false;
  double angle_min = -135.0 * M_PI / 180.0;  ///< [rad]
  double angle_max = 135.0 * M_PI / 180.0;   ///< [rad]
  int beams = 1081;
  double rate = 40.0;        ///< [Hz]
  double min_range = 0.1;    ///< [m]
  double max_range = 30.0;   ///< [m]
  double range_sigma = 0.01; ///< [m]
  Mount mount{ 0.3, 0.0, 0.5, 0.0, 0.0, 0.0 };
};

struct LaserScan2D
{
  double stamp = 0.0;            ///< [s] time of the first beam
  double angle_min = 0.0, angle_increment = 0.0, time_increment = 0.0, scan_time = 0.0;
  double range_min = 0.0, range_max = 0.0;
  std::vector<float> ranges;
};

/** @brief A 6-axis IMU on base_link (gyro biases drawn once per run). */
struct ImuConfig
{
  bool enabled = false;
  double rate = 100.0;             ///< [Hz]
  double gyro_sigma = 0.002;       ///< [rad/s] white noise per sample
  double gyro_bias_sigma = 0.005;  ///< [rad/s] bias, drawn once
  double accel_sigma = 0.05;       ///< [m/s^2]
  double accel_bias_sigma = 0.05;  ///< [m/s^2]
};

struct ImuSample
{
  double stamp = 0.0;
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();     ///< [rad/s] body frame
  Eigen::Vector3d linear_acceleration = Eigen::Vector3d::Zero();  ///< [m/s^2] specific force, body frame
};

struct OdometrySample
{
  double stamp = 0.0;    ///< measurement time (delivered latency later)
  core::Pose2 pose;      ///< odom -> base_link
  double linear = 0.0;   ///< [m/s]
  double angular = 0.0;  ///< [rad/s]
};

struct TruthSample
{
  double stamp = 0.0;
  core::Pose2 pose;        ///< world (stand) frame
  Eigen::Isometry3d body;  ///< world -> base_link in 3D (on the ground)
};

/** @brief Where the robot's true footprint touched an obstacle; the simulator stopped it there. */
struct Collision
{
  double stamp = 0.0;             ///< [s] simulated time
  core::Pose2 pose;               ///< true pose of base_link in the world when it touched
  HitKind kind = HitKind::kNone;  ///< kTrunk (at the ground) or kBox
  int index = -1;                 ///< into the world's trunks or boxes
  /** @brief E.g. "trunk 12 (r 0.25 m at 10.00, 3.00)". */
  std::string what(const ForestWorld& world) const;
};

struct SimulatorConfig
{
  double physics_rate = 200.0;  ///< [Hz]; sensor rates and the latency are rounded to its ticks
  double truth_rate = 50.0;     ///< [Hz]
  core::Pose2 start{ 0.0, 15.0, 0.0 };
  std::uint64_t seed = 0;
  RobotConfig robot;
  OdometryConfig odometry;
  Lidar3DConfig lidar3d;
  Lidar2DConfig lidar2d;
  ImuConfig imu;
  core::GnssConfig gnss;  ///< the satellite receiver (off by default)

  bool validate(std::string* error) const;
};

/** @brief Everything delivered during one physics step. */
struct SimulatorOutput
{
  std::vector<OdometrySample> odometry;
  std::vector<LidarSweep> sweeps;
  std::vector<LaserScan2D> scans;
  std::vector<ImuSample> imu;
  std::vector<TruthSample> truth;
  std::vector<core::GnssSample> gnss;  ///< the receiver's fixes with their truth

  void clear();
  bool empty() const;
};

/**
 * @brief Deterministic forest (or indoor) simulator: a diff-drive robot or a car on undulating ground,
 * drifting odometry, a 3D and a 2D lidar cast from the pose the robot has at each beam's
 * instant, an IMU, and ground truth. Time advances in fixed physics ticks; the same world, config
 * and seed give the same outputs.
 *
 * Collisions: when the robot's true footprint (RobotConfig: a circle for the diff drive, the body's rectangle for
 * the car) touches a trunk at the ground or a box, the robot stops there for good and collision() says where and
 * what; the sensors go on.
 */
class ForestSimulator
{
public:
  ForestSimulator(const ForestWorld& world, const SimulatorConfig& config);
  /** @brief Indoor variant: the 2D lidar casts on @p image (flat ground, 3D lidar off). */
  ForestSimulator(const ForestWorld& world, const SimulatorConfig& config,
                  std::shared_ptr<const core::OccupancyImage> image);
  ~ForestSimulator();

  void setCommand(const VelocityCommand& command) { command_ = command; }
  /** @brief Advances one physics tick; fills @p out with what is delivered at its end. */
  void step(SimulatorOutput* out);

  double time() const { return static_cast<double>(tick_) / config_.physics_rate; }
  double dt() const { return 1.0 / config_.physics_rate; }
  const Robot& robot() const { return *robot_; }
  /** @brief The collision that stopped the robot, or nullptr. */
  const Collision* collision() const { return collided_ ? &collision_ : nullptr; }
  /** @brief What the robot touches at @p pose (kind kNone: nothing); stamp left 0. Public for tests. */
  Collision touching(const core::Pose2& pose) const;
  const SimulatorConfig& config() const { return config_; }
  const ForestWorld& world() const { return caster_.world(); }

  /** @brief The robot's 3D pose for a planar pose: on the ground, tilted with its slope. */
  Eigen::Isometry3d bodyPose(const core::Pose2& pose) const;
  /** @brief True planar pose at time @p t (interpolated; within the last second). */
  core::Pose2 poseAt(double t) const;

  /** @brief The canopy cover over @p x, @p y (GnssConfig: crowns in the circle of canopy_radius), 0..1. */
  double canopyAt(double x, double y) const;

  /** @brief Casts one full sweep starting at @p stamp (history must cover it). Public for benchmarks. */
  void castSweep(double stamp, LidarSweep* sweep);
  void castScan(double stamp, LaserScan2D* scan);

private:
  void init();

  SimulatorConfig config_;
  core::Random random_;  ///< robot, odometry, IMU
  /// lidar noise and foliage (independent stream: enabling a sensor leaves the path alone)
  core::Random sensor_random_;
  ForestRayCaster caster_;
  std::shared_ptr<const core::OccupancyImage> image_;
  std::unique_ptr<Robot> robot_;
  bool collided_ = false;
  Collision collision_;
  VelocityCommand command_;
  std::int64_t tick_ = 0;
  std::deque<std::pair<std::int64_t, core::Pose2>> history_;
  std::deque<std::pair<std::int64_t, OdometrySample>> pending_odometry_;  ///< (delivery tick, sample)
  std::int64_t odom_period_ = 1, latency_ticks_ = 0, sweep_period_ = 1, scan_period_ = 1, imu_period_ = 1,
               truth_period_ = 1;
  std::int64_t last_odom_tick_ = 0;
  Eigen::Vector3d gyro_bias_ = Eigen::Vector3d::Zero(), accel_bias_ = Eigen::Vector3d::Zero();
  bool have_imu_state_ = false;
  Eigen::Isometry3d last_imu_body_ = Eigen::Isometry3d::Identity();
  Eigen::Vector3d last_imu_velocity_ = Eigen::Vector3d::Zero();
  std::vector<double> ring_sin_, ring_cos_;
  std::unique_ptr<core::GnssReceiver> gnss_;
  std::int64_t gnss_period_ = 1;
};

}  // namespace sim
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_SIM_FOREST_SIMULATOR_H
