#ifndef RBPF_SLAM_IO_PARAM_SOURCE_H
#define RBPF_SLAM_IO_PARAM_SOURCE_H

#include <cstdint>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "rbpf_slam/core/filter/particle_filter.h"

namespace rbpf_slam
{
namespace io
{
/**
 * @brief Where configuration values come from: a YAML file or the ROS parameter server. Keys are
 * '/'-separated paths ("lidar3d/rings"). A getter leaves the value alone and returns false when the
 * key is absent; it throws std::runtime_error naming the key when the value has the wrong type.
 */
class ParamSource
{
public:
  virtual ~ParamSource() = default;
  virtual bool get(const std::string& key, double* value) const = 0;
  virtual bool get(const std::string& key, int* value) const = 0;
  virtual bool get(const std::string& key, bool* value) const = 0;
  virtual bool get(const std::string& key, std::string* value) const = 0;
  /** @brief A seed: an int, negative values reinterpreted as unsigned (as `~seed` on the command line). */
  bool getSeed(const std::string& key, std::uint64_t* seed) const;
};

/**
 * @brief The resampling keys every particle filter shares: `resampling` (low_variance | multinomial) and
 * `resample_neff_ratio`.
 * @throws std::runtime_error for an unknown method name.
 */
void readResamplingPolicy(const ParamSource& params, core::ResamplingPolicy* policy);

/**
 * @brief Keys of the filters' YAML files (config/fastslam.yaml, config/grid_slam.yaml) that only the ROS nodes read
 * (frames, waits, files): offline tools know them and leave them unused without a warning.
 */
const std::vector<std::string>& nodeOnlyKeys();

/** @brief A YAML file as a ParamSource; remembers which keys were read so typos can be reported. */
class YamlParamSource : public ParamSource
{
public:
  /** @throws std::runtime_error naming the file when it cannot be read or parsed. */
  explicit YamlParamSource(const std::string& path);
  ~YamlParamSource() override;
  bool get(const std::string& key, double* value) const override;
  bool get(const std::string& key, int* value) const override;
  bool get(const std::string& key, bool* value) const override;
  bool get(const std::string& key, std::string* value) const override;
  /** @brief Leaf keys present in the file that no getter asked for (typos, unsupported keys). */
  std::vector<std::string> unusedKeys() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace io
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_IO_PARAM_SOURCE_H
