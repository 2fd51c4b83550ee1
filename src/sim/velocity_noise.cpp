#include "rbpf_slam/sim/velocity_noise.h"

#include <algorithm>
#include <cmath>

namespace rbpf_slam
{
namespace sim
{
namespace
{
bool checkNonNegative(double value, const char* name, std::string* error)
{
  if (std::isfinite(value) && value >= 0.0)
    return true;
  if (error)
    *error = std::string(name) + " must be finite and >= 0 (got " + std::to_string(value) + ")";
  return false;
}

bool checkFinite(double value, const char* name, std::string* error)
{
  if (std::isfinite(value))
    return true;
  if (error)
    *error = std::string(name) + " must be finite";
  return false;
}

double clampMagnitude(double value, double limit)
{
  return limit > 0.0 ? std::max(-limit, std::min(limit, value)) : value;
}
}  // namespace

bool VelocityNoiseConfig::validate(std::string* error) const
{
  return checkNonNegative(linear_sigma_abs, "linear_sigma_abs", error) &&
         checkNonNegative(linear_sigma_rel, "linear_sigma_rel", error) &&
         checkNonNegative(angular_sigma_abs, "angular_sigma_abs", error) &&
         checkNonNegative(angular_sigma_rel, "angular_sigma_rel", error) &&
         checkFinite(max_linear, "max_linear", error) && checkFinite(max_angular, "max_angular", error);
}

VelocityNoiseModel::VelocityNoiseModel(const VelocityNoiseConfig& config, std::uint64_t seed)
  : config_(config), random_(seed)
{
}

double VelocityNoiseModel::linearSigma(double linear) const
{
  return std::hypot(config_.linear_sigma_abs, config_.linear_sigma_rel * linear);
}

double VelocityNoiseModel::angularSigma(double angular) const
{
  return std::hypot(config_.angular_sigma_abs, config_.angular_sigma_rel * angular);
}

VelocityCommand VelocityNoiseModel::apply(const VelocityCommand& command)
{
  VelocityCommand noisy;
  noisy.linear = command.linear + random_.gaussian(linearSigma(command.linear));
  noisy.angular = command.angular + random_.gaussian(angularSigma(command.angular));
  noisy.linear = clampMagnitude(noisy.linear, config_.max_linear);
  noisy.angular = clampMagnitude(noisy.angular, config_.max_angular);
  return noisy;
}

}  // namespace sim
}  // namespace rbpf_slam
