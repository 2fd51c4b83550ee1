#include "rbpf_slam/sim/scenario.h"

#include <Eigen/Geometry>

namespace rbpf_slam
{
namespace sim
{
using core::between;
using core::OccupancyImage;
using core::Pose2;

bool parseSteerOn(const std::string& name, SteerOn* steer_on)
{
  if (name == "odometry")
    *steer_on = SteerOn::kOdometry;
  else if (name == "truth")
    *steer_on = SteerOn::kTruth;
  else
    return false;
  return true;
}

Scenario::Scenario(const ForestWorld& world, const ScenarioConfig& config, std::shared_ptr<const OccupancyImage> image)
  : config_(config)
  , sim_(world, config.sim, std::move(image))
  , relay_(config.relay, config.sim.seed * 2654435761ull + 1)
  , follower_(config.drive, config.follower)
{
}

void Scenario::rememberObstacles(const SimulatorOutput& out)
{
  // Seen from the pose the follower last steered on (the sweep's points are taken as seen at its end).
  const SimulatorConfig& sc = sim_.config();
  for (const LidarSweep& sweep : out.sweeps)
  {
    // Levelled, as a robot's IMU levels it (gravity gives roll and pitch without drift): on a 7 % slope a trunk
    // seen 1.8 m up lies 0.13 m from where its foot is in the tilted body's x-y.
    const Pose2 truth = sim_.robot().pose();
    const Eigen::Matrix3d tilt =
        Eigen::AngleAxisd(-truth.theta, Eigen::Vector3d::UnitZ()).toRotationMatrix() * sim_.bodyPose(truth).linear();
    const Eigen::Isometry3d mount = sc.lidar3d.mount.transform();
    cloud_.clear();
    cloud_.reserve(sweep.points.size());
    for (const LidarPoint& p : sweep.points)
      cloud_.push_back(tilt * (mount * Eigen::Vector3d(p.x, p.y, p.z)));
    follower_.addObstacles(sim_.time(), steer_pose_, obstaclesFromCloud(cloud_, config_.follower));
  }
  for (const LaserScan2D& scan : out.scans)
  {
    const Mount& m = sc.lidar2d.mount;
    follower_.addObstacles(sim_.time(), steer_pose_,
                           obstaclesFromScan(scan.ranges, scan.angle_min, scan.angle_increment, scan.range_min,
                                             scan.range_max, Pose2(m.x, m.y, m.yaw), config_.follower));
  }
}

bool Scenario::step(SimulatorOutput* out)
{
  sim_.step(out);
  if (config_.follower.avoid_obstacles)
    rememberObstacles(*out);
  for (const OdometrySample& odom : out->odometry)
  {
    // The path is in the start frame, as the odometry (which starts at identity there) and the true pose seen from
    // the start are.
    const Pose2 pose = config_.steer_on == SteerOn::kTruth ? between(config_.sim.start, sim_.robot().pose()) : odom.pose;
    steer_pose_ = pose;
    sim_.setCommand(follower_.done() ? VelocityCommand() : relay_.apply(follower_.command(pose)));
  }
  if (sim_.collision())
    return false;
  if (follower_.done() && done_time_ < 0.0)
  {
    sim_.setCommand(VelocityCommand());
    done_time_ = sim_.time();
  }
  if (done_time_ >= 0.0 && sim_.time() >= done_time_ + config_.settle)
    return false;
  return !timedOut();
}

}  // namespace sim
}  // namespace rbpf_slam
