#ifndef RBPF_SLAM_IO_GRID_SLAM_CONFIG_H
#define RBPF_SLAM_IO_GRID_SLAM_CONFIG_H

#include "rbpf_slam/core/grid/grid_slam.h"
#include "rbpf_slam/io/param_source.h"

namespace rbpf_slam
{
namespace io
{
/**
 * @brief Reads the filter keys of config/grid_slam.yaml over the values in @p config (absent keys keep them):
 * `mode`, `particles`, `seed`, `resampling` (low_variance | multinomial), `resample_neff_ratio`,
 * `correlation_gain`, `score_beam_step`, `motion/alpha1..4`, `grid/resolution`, `grid/log_odds_hit`,
 * `grid/log_odds_free`, `grid/log_odds_clamp`, `grid/occupied_log_odds`, `grid/free_log_odds`,
 * `range_min`, `range_max`, `no_return_free_range`.
 * @throws std::runtime_error naming the key for a wrong type, an unknown name or, after reading, an invalid value.
 */
void readGridSlamConfig(const ParamSource& params, core::GridSlamConfig* config);

}  // namespace io
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_IO_GRID_SLAM_CONFIG_H
