#include "rbpf_slam/core/trunk_slam/trunk_slam_config.h"

namespace rbpf_slam
{
namespace core
{
std::string TrunkSlamConfig::validate() const
{
  const std::string filter = FastSlamConfig::validate();
  if (!filter.empty())
    return filter;
  const std::string loop = loop_closure.validate();
  if (!loop.empty())
    return loop;
  return gnss.validate();
}

}  // namespace core
}  // namespace rbpf_slam
