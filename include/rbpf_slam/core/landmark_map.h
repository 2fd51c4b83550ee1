#ifndef RBPF_SLAM_CORE_LANDMARK_MAP_H
#define RBPF_SLAM_CORE_LANDMARK_MAP_H

#include <array>
#include <cstddef>
#include <memory>
#include <vector>

#include <Eigen/Core>

namespace rbpf_slam
{
namespace core
{
/** @brief One landmark (a trunk) of one particle's map: a 2D Gaussian, a fused radius, evidence. */
struct Landmark
{
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();          ///< [m] map frame
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity(); ///< [m^2]
  double radius = 0.0;           ///< [m] fused (inverse-variance weighted) trunk radius
  double radius_variance = 1.0;  ///< [m^2]
  double evidence = 0.0;         ///< log odds of existence: + per match, - per miss inside the scope
  int observations = 0;          ///< matches so far
  bool provisional = true;       ///< until seen confirm_observations times
  int id = 0;                    ///< unique within the filter (for visualisation and evaluation)
};

/**
 * @brief A particle's landmarks, shared copy-on-write between particles in chunks of kChunk: copying a
 * map copies one pointer per chunk; changing a landmark copies only its chunk if another map shares it.
 * Indices are dense [0, size()); remove() moves the last landmark into the hole.
 */
class LandmarkMap
{
public:
  static constexpr std::size_t kChunk = 16;

  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  const Landmark& operator[](std::size_t i) const { return chunks_[i / kChunk]->items[i % kChunk]; }

  /** @brief Writable access: copies the chunk first when another map shares it. */
  Landmark& mutableAt(std::size_t i)
  {
    auto& chunk = chunks_[i / kChunk];
    if (chunk.use_count() > 1)
      chunk = std::make_shared<Chunk>(*chunk);
    return chunk->items[i % kChunk];
  }

  void add(const Landmark& l)
  {
    if (size_ % kChunk == 0)
      chunks_.push_back(std::make_shared<Chunk>());
    const std::size_t i = size_++;
    mutableAt(i) = l;
  }

  void remove(std::size_t i)
  {
    const std::size_t last = size_ - 1;
    if (i != last)
      mutableAt(i) = (*this)[last];
    --size_;
    if (size_ % kChunk == 0)
      chunks_.pop_back();
  }

  /** @brief Number of chunks shared with another map (for tests of the sharing). */
  std::size_t sharedChunks() const
  {
    std::size_t n = 0;
    for (const auto& c : chunks_)
      n += c.use_count() > 1;
    return n;
  }

private:
  struct Chunk
  {
    std::array<Landmark, kChunk> items;
  };
  std::vector<std::shared_ptr<Chunk>> chunks_;
  std::size_t size_ = 0;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_LANDMARK_MAP_H
