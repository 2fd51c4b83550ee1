#include "rbpf_slam/sim/scenario.h"

namespace rbpf_slam
{
namespace core
{
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

bool Scenario::step(SimulatorOutput* out)
{
  sim_.step(out);
  for (const OdometrySample& odom : out->odometry)
  {
    // The path is in the start frame, as the odometry (which starts at identity there) and the true pose seen from
    // the start are.
    const Pose2 pose = config_.steer_on == SteerOn::kTruth ? between(config_.sim.start, sim_.robot().pose()) : odom.pose;
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

}  // namespace core
}  // namespace rbpf_slam
