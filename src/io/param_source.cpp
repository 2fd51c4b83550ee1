#include "rbpf_slam/io/param_source.h"

#include <stdexcept>

#include <yaml-cpp/yaml.h>

namespace rbpf_slam
{
namespace io
{
bool ParamSource::getSeed(const std::string& key, std::uint64_t* seed) const
{
  int value = static_cast<int>(*seed);
  if (!get(key, &value))
    return false;
  *seed = static_cast<std::uint64_t>(static_cast<std::int64_t>(value));
  return true;
}

const std::vector<std::string>& nodeOnlyKeys()
{
  static const std::vector<std::string> keys = { "map_frame",           "odom_frame",          "base_frame",
                                                 "tf_timeout",          "transform_tolerance", "map_update_interval",
                                                 "publish_tf",          "map_path",            "max_path_poses",
                                                 "odom_timeout",        "inventory_path",      "run_folder",
                                                 "time_jump_threshold", "level_frame",         "debug_report_address",
                                                 "map_file",            "initial_x",           "initial_y",
                                                 "initial_yaw",         "relocalize" };
  return keys;
}

void readResamplingPolicy(const ParamSource& p, core::ResamplingPolicy* policy)
{
  std::string name = core::resamplingMethodName(policy->method);
  if (p.get("resampling", &name) && !core::parseResamplingMethod(name, &policy->method))
    throw std::runtime_error("invalid parameter: resampling must be low_variance or multinomial (got '" + name + "')");
  p.get("resample_neff_ratio", &policy->neff_ratio);
}

struct YamlParamSource::Impl
{
  std::string path;
  YAML::Node root;
  mutable std::set<std::string> used;

  /** @brief The node at @p key in *out; false when absent (a default YAML::Node() is a defined null). */
  bool find(const std::string& key, YAML::Node* out) const
  {
    // Node::operator= writes through to the referenced node in yaml-cpp; walk with reset() on const
    // nodes instead, so that a lookup never changes the document (and keeps the line marks).
    YAML::Node node;
    node.reset(root);
    std::size_t start = 0;
    while (true)
    {
      const std::size_t slash = key.find('/', start);
      const std::string part = key.substr(start, slash == std::string::npos ? std::string::npos : slash - start);
      if (!node.IsMap())
        return false;
      const YAML::Node& parent = node;
      const YAML::Node child = static_cast<const YAML::Node&>(parent)[part];
      if (!child)
        return false;
      node.reset(child);
      if (slash == std::string::npos)
        break;
      start = slash + 1;
    }
    used.insert(key);
    out->reset(node);
    return true;
  }

  template <typename T>
  bool read(const std::string& key, T* value, const char* type) const
  {
    YAML::Node node;
    if (!find(key, &node))
      return false;
    try
    {
      *value = node.as<T>();
    }
    catch (const YAML::Exception&)
    {
      throw std::runtime_error(path + ":" + std::to_string(node.Mark().line + 1) + ": key '" + key + "' must be " +
                               type);
    }
    return true;
  }

  void collect(const YAML::Node& node, const std::string& prefix, std::vector<std::string>* out) const
  {
    if (!node.IsMap())
    {
      out->push_back(prefix);
      return;
    }
    for (const auto& kv : node)
      collect(kv.second, prefix.empty() ? kv.first.as<std::string>() : prefix + "/" + kv.first.as<std::string>(), out);
  }
};

YamlParamSource::YamlParamSource(const std::string& path) : impl_(new Impl)
{
  impl_->path = path;
  try
  {
    impl_->root = YAML::LoadFile(path);
  }
  catch (const YAML::BadFile&)
  {
    throw std::runtime_error(path + ": cannot open the file");
  }
  catch (const YAML::Exception& e)
  {
    throw std::runtime_error(path + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  if (impl_->root && !impl_->root.IsNull() && !impl_->root.IsMap())
    throw std::runtime_error(path + ": expected a map of keys at the top level");
}

YamlParamSource::~YamlParamSource() = default;

bool YamlParamSource::get(const std::string& key, double* value) const
{
  return impl_->read(key, value, "a number");
}
bool YamlParamSource::get(const std::string& key, int* value) const
{
  return impl_->read(key, value, "an integer");
}
bool YamlParamSource::get(const std::string& key, bool* value) const
{
  return impl_->read(key, value, "true or false");
}
bool YamlParamSource::get(const std::string& key, std::string* value) const
{
  return impl_->read(key, value, "a string");
}

std::vector<std::string> YamlParamSource::unusedKeys() const
{
  std::vector<std::string> all, unused;
  if (impl_->root && impl_->root.IsMap())
    impl_->collect(impl_->root, "", &all);
  for (const auto& k : all)
    if (!impl_->used.count(k))
      unused.push_back(k);
  return unused;
}

}  // namespace io
}  // namespace rbpf_slam
