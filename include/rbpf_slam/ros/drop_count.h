#ifndef RBPF_SLAM_ROS_DROP_COUNT_H
#define RBPF_SLAM_ROS_DROP_COUNT_H

#include <algorithm>
#include <cstddef>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace rbpf_slam
{
/**
 * @brief A node's dropped messages counted per cause, for its warnings: "12 dropped so far: 10 before the previous
 * stamp, 2 no transform base_link -> laser" instead of one sum of every kind. At most kMaxCauses causes are named;
 * the drops of any further ones count as "other causes".
 */
class DropCount
{
public:
  static constexpr std::size_t kMaxCauses = 8;

  /** @brief One more drop for @p cause; returns summary(). */
  std::string add(const std::string& cause)
  {
    ++total_;
    const bool known = by_cause_.count(cause) > 0;
    ++by_cause_[known || by_cause_.size() < kMaxCauses ? cause : std::string("other causes")];
    return summary();
  }

  std::size_t total() const { return total_; }
  std::size_t count(const std::string& cause) const
  {
    const auto it = by_cause_.find(cause);
    return it == by_cause_.end() ? 0 : it->second;
  }

  /** @brief "N dropped so far: a CAUSE, b CAUSE", the most frequent cause first (ties by name). */
  std::string summary() const
  {
    std::vector<std::pair<std::size_t, std::string>> causes;
    for (const auto& c : by_cause_)
      causes.emplace_back(c.second, c.first);
    std::sort(causes.begin(), causes.end(), [](const std::pair<std::size_t, std::string>& a,
                                               const std::pair<std::size_t, std::string>& b) {
      return a.first != b.first ? a.first > b.first : a.second < b.second;
    });
    std::string text = std::to_string(total_) + " dropped so far";
    for (std::size_t i = 0; i < causes.size(); ++i)
      text += (i == 0 ? ": " : ", ") + std::to_string(causes[i].first) + " " + causes[i].second;
    return text;
  }

private:
  std::map<std::string, std::size_t> by_cause_;
  std::size_t total_ = 0;
};

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_DROP_COUNT_H
