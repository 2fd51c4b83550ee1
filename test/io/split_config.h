// The checks of a filter's configuration split in two files (a short file of the keys a user sets, an advanced file
// with the rest, read first): shared by the FastSLAM and grid SLAM configuration tests.
#ifndef RBPF_SLAM_TEST_IO_SPLIT_CONFIG_H
#define RBPF_SLAM_TEST_IO_SPLIT_CONFIG_H

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/io/param_source.h"

namespace split_config
{
/** @brief A source that has no key and records every key asked of it: the keys a reader knows. */
class AskedKeys : public rbpf_slam::io::ParamSource
{
public:
  bool get(const std::string& key, double*) const override { return ask(key); }
  bool get(const std::string& key, int*) const override { return ask(key); }
  bool get(const std::string& key, bool*) const override { return ask(key); }
  bool get(const std::string& key, std::string*) const override { return ask(key); }
  mutable std::set<std::string> keys;

private:
  bool ask(const std::string& key) const
  {
    keys.insert(key);
    return false;
  }
};

inline bool isNodeOnlyKey(const std::string& key)
{
  const std::vector<std::string>& node = rbpf_slam::io::nodeOnlyKeys();
  return std::find(node.begin(), node.end(), key) != node.end();
}

/** @brief Reads a source into a fresh configuration of the filter (its io reader). */
using Reader = std::function<void(const rbpf_slam::io::ParamSource&)>;

/**
 * @brief The short file holds at most 25 keys, among them @p user_keys; no key is in both files; every key @p read
 * asks for is in one of them, and every key of the files is the reader's or the node's own (more than @p min_known).
 */
inline void expectSplitKeys(const std::string& user_file, const std::string& advanced_file,
                            const std::vector<std::string>& user_keys, std::size_t min_known, const Reader& read)
{
  // Before any read, a source's unused keys are all its leaf keys.
  const std::vector<std::string> user = rbpf_slam::io::YamlParamSource(user_file).unusedKeys();
  const std::vector<std::string> advanced = rbpf_slam::io::YamlParamSource(advanced_file).unusedKeys();
  EXPECT_LE(user.size(), 25u) << user_file << " holds the keys a user sets; the others go in the advanced file";
  EXPECT_GE(user.size(), 10u);
  EXPECT_GT(advanced.size(), user.size());
  const std::set<std::string> user_set(user.begin(), user.end());
  std::set<std::string> all = user_set;
  for (const auto& k : advanced)
  {
    EXPECT_EQ(user_set.count(k), 0u) << "key " << k << " is in both files";
    all.insert(k);
  }
  EXPECT_EQ(all.size(), user.size() + advanced.size());
  for (const auto& k : user_keys)
    EXPECT_EQ(user_set.count(k), 1u) << k;
  AskedKeys asked;
  read(asked);
  EXPECT_GT(asked.keys.size(), min_known);
  for (const auto& k : asked.keys)
    EXPECT_EQ(all.count(k), 1u) << "key " << k << " is in neither file";
  for (const auto& k : all)
    EXPECT_TRUE(asked.keys.count(k) || isNodeOnlyKey(k)) << "key " << k << " is read by no one";
}

/**
 * @brief A user's file @p user_text laid over the advanced file: the advanced file leaves only the node's keys unused
 * (no warning), the user's file exactly @p misspelt. @p read reads a source into one configuration, the user's after
 * the advanced; the caller checks what it holds.
 */
inline void expectMisspeltKeyReported(const std::string& advanced_file, const std::string& user_text,
                                      const std::string& misspelt, const Reader& read)
{
  const std::string path = std::string(::testing::TempDir()) + "split_config_user.yaml";
  std::ofstream(path) << user_text;
  rbpf_slam::io::YamlParamSource advanced(advanced_file), user(path);
  read(advanced);
  read(user);
  std::remove(path.c_str());
  for (const auto& k : advanced.unusedKeys())
    EXPECT_TRUE(isNodeOnlyKey(k)) << "key " << k << " of the advanced file would be warned of";
  EXPECT_EQ(user.unusedKeys(), std::vector<std::string>{ misspelt });
}

}  // namespace split_config

#endif  // RBPF_SLAM_TEST_IO_SPLIT_CONFIG_H
