#ifndef RBPF_SLAM_SIM_SIM_CONFIG_H
#define RBPF_SLAM_SIM_SIM_CONFIG_H

#include <string>
#include <vector>

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
/**
 * @brief A simulated run's scenario as the tools take it: the file @p path (keys of config/forest_sim.yaml; "" = the
 * defaults), the start pose @p start over the file's when not null, and the drive @p drive (straight, loop or a
 * waypoint file: sim::namedDrive). The file's keys no reader knows go to @p unknown (a tool warns of them).
 * @throws std::runtime_error for a file or value that cannot be read, or a drive that cannot.
 */
ScenarioConfig loadScenario(const std::string& path, const std::string& drive, const core::Pose2* start,
                            std::vector<std::string>* unknown);

}  // namespace sim
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_SIM_SIM_CONFIG_H
