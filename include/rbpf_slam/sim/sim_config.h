#ifndef RBPF_SLAM_SIM_SIM_CONFIG_H
#define RBPF_SLAM_SIM_SIM_CONFIG_H

#include "rbpf_slam/sim/scenario.h"
#include "rbpf_slam/io/param_source.h"

namespace rbpf_slam
{
namespace sim
{
/**
 * @brief Reads the simulator's configuration (keys of config/forest_sim.yaml) over the defaults in
 * @p config. Angles are in degrees in the file, radians in the struct.
 * @throws std::runtime_error naming the key for a wrong type or an invalid value.
 */
void readSimulatorConfig(const io::ParamSource& params, sim::SimulatorConfig* config);
/** @brief The follower's keys (`follower/...`) and the relay's (`relay/...`, as noise_relay.yaml). */
void readScenarioConfig(const io::ParamSource& params, sim::ScenarioConfig* config);

}  // namespace sim
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_SIM_SIM_CONFIG_H
