#ifndef RBPF_SLAM_CORE_FILTER_HISTORY_CHAIN_H
#define RBPF_SLAM_CORE_FILTER_HISTORY_CHAIN_H

#include <memory>
#include <utility>

namespace rbpf_slam
{
namespace core
{
/**
 * @brief One entry of a particle's history, its ancestors shared between the particles that descend from them.
 * Releasing the last reference to a long chain frees the ancestors that only it holds one by one, in a loop: the
 * default, recursive release would need one stack frame per entry and overflow the stack after hours of scans.
 */
template <typename T>
struct HistoryNode
{
  using Ptr = std::shared_ptr<const HistoryNode>;

  HistoryNode(const T& v, Ptr up) : value(v), parent(std::move(up)) {}
  HistoryNode(const HistoryNode&) = delete;
  HistoryNode& operator=(const HistoryNode&) = delete;
  ~HistoryNode()
  {
    Ptr up = std::move(parent);
    while (up && up.use_count() == 1)
    {
      Ptr next = std::move(up->parent);
      up = std::move(next);  // frees the entry, whose parent is already empty
    }
  }

  T value;
  mutable Ptr parent;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FILTER_HISTORY_CHAIN_H
