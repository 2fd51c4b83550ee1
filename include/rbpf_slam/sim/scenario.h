#ifndef RBPF_SLAM_SIM_SCENARIO_H
#define RBPF_SLAM_SIM_SCENARIO_H

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/sim/forest_simulator.h"
#include "rbpf_slam/sim/path_follower.h"
#include "rbpf_slam/sim/velocity_noise.h"

namespace rbpf_slam
{
namespace sim
{
/**
 * @brief What the path follower steers on: the robot's odometry (a robot without SLAM), or the true pose (a human
 * driver, who sees the road). Either way the filters see only odometry and sensor data.
 */
enum class SteerOn
{
  kOdometry,
  kTruth,
};

/** @brief Parses "odometry" or "truth"; false for anything else. */
bool parseSteerOn(const std::string& name, SteerOn* steer_on);

/**
 * @brief The exit statuses of the tools that run a scenario (record_scenario, follower_benchmark), so that a script
 * driving them can tell the causes apart. 1 stays a file or a value that cannot be read.
 */
namespace exit_status
{
constexpr int kCollided = 3;   ///< the robot ran into a trunk or a box; the run ended there
constexpr int kRefused = 4;    ///< the drive (or its start) was refused before it started (checkDrive)
constexpr int kTimedOut = 5;   ///< the drive was not finished within the scenario's time-out
}  // namespace exit_status

struct ScenarioConfig
{
  SimulatorConfig sim;
  VelocityNoiseConfig relay;  ///< motor noise between the follower and the robot
  PathFollowerConfig follower;
  SteerOn steer_on = SteerOn::kOdometry;  ///< the follower's input (at each odometry message)
  std::vector<Eigen::Vector2d> drive = straightDrive();  ///< start frame
  double timeout = 600.0;  ///< [s] of simulated time
  double settle = 1.0;     ///< [s] run on after the follower is done, so the robot stops
};

/**
 * @brief The ROS graph of a simulated run (follower -> noise relay -> simulator -> odometry ->
 * follower), in one process and in lockstep: the follower answers every odometry message, as the
 * nodelet does, so a seed gives the same run here and in the graph. With the follower's avoid_obstacles, each
 * sweep (or scan) is handed to its local planner as it is delivered.
 */
class Scenario
{
public:
  Scenario(const ForestWorld& world, const ScenarioConfig& config,
           std::shared_ptr<const core::OccupancyImage> image = nullptr);

  /** @brief One physics tick; false once the drive is finished (or timed out) and settled, or the robot collided
   * (simulator().collision()). */
  bool step(SimulatorOutput* out);

  ForestSimulator& simulator() { return sim_; }
  const PathFollower& follower() const { return follower_; }
  bool timedOut() const { return sim_.time() >= config_.timeout; }

private:
  /** @brief Hands the sweeps' and scans' obstacle points to the follower's planner. */
  void rememberObstacles(const SimulatorOutput& out);

  ScenarioConfig config_;
  ForestSimulator sim_;
  VelocityNoiseModel relay_;
  PathFollower follower_;
  double done_time_ = -1.0;
  core::Pose2 steer_pose_;              ///< the pose the follower last steered on (start frame)
  std::vector<Eigen::Vector3d> cloud_;  ///< a sweep in base_link (reused)
};

}  // namespace sim
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_SIM_SCENARIO_H
