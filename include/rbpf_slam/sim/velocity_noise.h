#ifndef RBPF_SLAM_SIM_VELOCITY_NOISE_H
#define RBPF_SLAM_SIM_VELOCITY_NOISE_H

#include <cstdint>
#include <string>

#include "rbpf_slam/core/filter/random.h"

namespace rbpf_slam
{
namespace sim
{
/**
 * @brief Parameters of the velocity-command noise (motor noise between a controller and a robot).
 *
 * Each standard deviation has an absolute part and a part proportional to the command; the two are
 * independent sources, so they add in quadrature: sigma = sqrt(abs^2 + (rel * |command|)^2).
 */
struct VelocityNoiseConfig
{
  double linear_sigma_abs = 0.05;   ///< [m/s]
  double linear_sigma_rel = 0.05;   ///< [-] fraction of |v|
  double angular_sigma_abs = 0.02;  ///< [rad/s]
  double angular_sigma_rel = 0.05;  ///< [-] fraction of |w|
  double max_linear = 0.0;          ///< [m/s] clamp of |v| after noise; <= 0 disables
  double max_angular = 0.0;         ///< [rad/s] clamp of |w| after noise; <= 0 disables

  /** @brief False with a reason in @p error when a value is negative or not finite. */
  bool validate(std::string* error) const;
};

/** @brief A planar velocity command (REP-103: m/s, rad/s). */
struct VelocityCommand
{
  double linear = 0.0;
  double angular = 0.0;
};

/** @brief Adds seeded Gaussian noise to velocity commands. */
class VelocityNoiseModel
{
public:
  VelocityNoiseModel(const VelocityNoiseConfig& config, std::uint64_t seed);

  /** @brief The noisy (and clamped) command; consumes random draws only for non-zero sigmas. */
  VelocityCommand apply(const VelocityCommand& command);

  double linearSigma(double linear) const;
  double angularSigma(double angular) const;
  const VelocityNoiseConfig& config() const { return config_; }

private:
  VelocityNoiseConfig config_;
  core::Random random_;
};

}  // namespace sim
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_SIM_VELOCITY_NOISE_H
