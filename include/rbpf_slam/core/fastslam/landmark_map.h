#ifndef RBPF_SLAM_CORE_FASTSLAM_LANDMARK_MAP_H
#define RBPF_SLAM_CORE_FASTSLAM_LANDMARK_MAP_H

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/filter/cell_key.h"

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
  /// The id is the detector's (known association): the landmark is matched by it wherever it is predicted, and
  /// never deleted by the miss rule.
  bool known_id = false;
  double first_seen = NAN;       ///< [s] the filter's clock at the first sighting (NaN: not known)
  double last_seen = NAN;        ///< [s] the filter's clock at the last match (NaN: not known)
  /// The radius from this run's observations alone (a tree of a saved map keeps its old radius in `radius`, fused
  /// with the new observations; this one shows growth), its variance, and this run's matches.
  double visit_radius = NAN;
  double visit_radius_variance = 0.0;
  int visit_observations = 0;
  /// Distinct views that counted as evidence (see EvidenceConfig::view_change), and the last of them: the direction
  /// [rad] from the landmark to the sensor and the log of the range [ln m] (NaN: none yet).
  int views = 0;
  double view_direction = NAN;
  double view_log_range = NAN;
  /// [m] The farthest range it was seen from in this run (NaN: not known). It is expected to be seen, and missed
  /// when it is not, only that near: how far a sensor detects a trunk depends on its size and the beams' spacing.
  double seen_range = NAN;
};

/**
 * @brief A particle's landmarks, shared copy-on-write between particles, with a spatial index.
 *
 * Storage: chunks of kChunk landmarks; copying a map copies one pointer per chunk and one pointer for the
 * index; changing a landmark copies only its chunk if another map shares it. Indices are dense [0, size());
 * remove() moves the last landmark into the hole.
 *
 * Index: square tiles of kTileSize metres (a sorted table of tile -> landmark indices), itself shared
 * copy-on-write at two levels (the table, then each tile's list), so that an update which adds, removes or
 * moves a landmark across a tile border copies the table of pointers and the one or two tiles concerned,
 * never the landmarks. near() visits only the tiles that overlap the query disc.
 *
 * The mean of a landmark changes only through modify() (which keeps the index current); mutableAt() is
 * private for that reason.
 */
class LandmarkMap
{
public:
  static constexpr std::size_t kChunk = 16;
  static constexpr double kTileSize = 8.0;  ///< [m]

  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  const Landmark& operator[](std::size_t i) const { return chunks_[i / kChunk]->items[i % kChunk]; }

  /**
   * @brief Applies @p f (a callable taking Landmark&) to landmark @p i, copying its chunk first when another
   * map shares it, and moves it in the index when its mean left its tile.
   */
  template <class F>
  void modify(std::size_t i, F&& f)
  {
    const std::int64_t before = tileKey((*this)[i].mean);
    Landmark& l = mutableAt(i);
    f(l);
    const std::int64_t after = tileKey(l.mean);
    if (after != before)
    {
      eraseIndex(before, static_cast<std::uint32_t>(i));
      insertIndex(after, static_cast<std::uint32_t>(i));
    }
  }

  void add(const Landmark& l)
  {
    if (size_ % kChunk == 0)
      chunks_.push_back(std::make_shared<Chunk>());
    const std::size_t i = size_++;
    mutableAt(i) = l;
    insertIndex(tileKey(l.mean), static_cast<std::uint32_t>(i));
  }

  void remove(std::size_t i)
  {
    const std::size_t last = size_ - 1;
    eraseIndex(tileKey((*this)[i].mean), static_cast<std::uint32_t>(i));
    if (i != last)
    {
      replaceIndex(tileKey((*this)[last].mean), static_cast<std::uint32_t>(last), static_cast<std::uint32_t>(i));
      mutableAt(i) = (*this)[last];
    }
    --size_;
    if (size_ % kChunk == 0)
      chunks_.pop_back();
  }

  /**
   * @brief Appends to @p out (cleared first) the indices, ascending, of the landmarks whose mean lies within
   * @p radius of @p center (inclusive): exactly what a scan of all landmarks would return.
   */
  void near(const Eigen::Vector2d& center, double radius, std::vector<std::size_t>* out) const
  {
    out->clear();
    if (!tiles_ || tiles_->empty() || !(radius >= 0.0))
      return;
    const double r2 = radius * radius;
    const auto take = [&](const Tile& t) {
      for (std::uint32_t j : *t.items)
        if (((*this)[j].mean - center).squaredNorm() <= r2)
          out->push_back(j);
    };
    const double x0 = std::floor((center.x() - radius) / kTileSize), x1 = std::floor((center.x() + radius) / kTileSize);
    const double y0 = std::floor((center.y() - radius) / kTileSize), y1 = std::floor((center.y() + radius) / kTileSize);
    const double cells = (x1 - x0 + 1.0) * (y1 - y0 + 1.0);
    if (!(cells <= static_cast<double>(tiles_->size())))
    {
      // A disc wider than the map (or not finite): scanning the tiles is cheaper than probing cells.
      for (const Tile& t : *tiles_)
        take(t);
    }
    else
    {
      for (double ix = x0; ix <= x1; ++ix)
        for (double iy = y0; iy <= y1; ++iy)
        {
          const std::int64_t key = packKey(static_cast<std::int64_t>(ix), static_cast<std::int64_t>(iy));
          const auto it = findTile(key);
          if (it != tiles_->end() && it->key == key)
            take(*it);
        }
    }
    std::sort(out->begin(), out->end());
  }

  /** @brief Number of landmark chunks shared with another map (for tests of the sharing). */
  std::size_t sharedChunks() const
  {
    std::size_t n = 0;
    for (const auto& c : chunks_)
      n += c.use_count() > 1;
    return n;
  }
  std::size_t chunks() const { return chunks_.size(); }
  /** @brief Number of non-empty tiles of the index. */
  std::size_t tiles() const { return tiles_ ? tiles_->size() : 0; }
  /** @brief Bytes held by this map alone, counting shared parts in full (an upper bound per particle). */
  std::size_t bytes() const
  {
    std::size_t b = sizeof(*this) + chunks_.capacity() * sizeof(chunks_[0]) + chunks_.size() * sizeof(Chunk);
    if (tiles_)
    {
      b += tiles_->capacity() * sizeof(Tile);
      for (const Tile& t : *tiles_)
        b += sizeof(*t.items) + t.items->capacity() * sizeof(std::uint32_t);
    }
    return b;
  }

  /** @brief The tile of a position (packed x and y tile numbers). */
  static std::int64_t tileKey(const Eigen::Vector2d& p)
  {
    const auto cell = [](double v) {
      const double c = std::floor(v / kTileSize);
      // Far-away or non-finite positions share the border tiles; near() still filters by distance.
      return static_cast<std::int64_t>(c >= -2e9 && c <= 2e9 ? c : (c > 0 ? 2e9 : -2e9));
    };
    return packKey(cell(p.x()), cell(p.y()));
  }

private:
  struct Chunk
  {
    std::array<Landmark, kChunk> items;
  };
  struct Tile
  {
    std::int64_t key;
    std::shared_ptr<std::vector<std::uint32_t>> items;
  };
  using Table = std::vector<Tile>;

  static std::int64_t packKey(std::int64_t ix, std::int64_t iy)
  {
    return packCell(ix, iy);
  }

  /** @brief Writable access: copies the chunk first when another map shares it. */
  Landmark& mutableAt(std::size_t i)
  {
    auto& chunk = chunks_[i / kChunk];
    if (chunk.use_count() > 1)
      chunk = std::make_shared<Chunk>(*chunk);
    return chunk->items[i % kChunk];
  }

  Table::const_iterator findTile(std::int64_t key) const
  {
    return std::lower_bound(tiles_->begin(), tiles_->end(), key, [](const Tile& t, std::int64_t k) { return t.key < k; });
  }

  /** @brief The table, unshared; and the tile @p key in it, created when @p create, its list unshared. */
  std::vector<std::uint32_t>* mutableTile(std::int64_t key, bool create)
  {
    if (!tiles_)
      tiles_ = std::make_shared<Table>();
    else if (tiles_.use_count() > 1)
      tiles_ = std::make_shared<Table>(*tiles_);
    auto it = std::lower_bound(tiles_->begin(), tiles_->end(), key, [](const Tile& t, std::int64_t k) { return t.key < k; });
    if (it == tiles_->end() || it->key != key)
    {
      if (!create)
        return nullptr;
      it = tiles_->insert(it, Tile{ key, std::make_shared<std::vector<std::uint32_t>>() });
    }
    else if (it->items.use_count() > 1)
      it->items = std::make_shared<std::vector<std::uint32_t>>(*it->items);
    return it->items.get();
  }

  void insertIndex(std::int64_t key, std::uint32_t i) { mutableTile(key, true)->push_back(i); }

  void eraseIndex(std::int64_t key, std::uint32_t i)
  {
    std::vector<std::uint32_t>* items = mutableTile(key, false);
    if (!items)
      return;
    const auto it = std::find(items->begin(), items->end(), i);
    if (it != items->end())
    {
      *it = items->back();
      items->pop_back();
    }
    if (items->empty())
    {
      const auto t = std::lower_bound(tiles_->begin(), tiles_->end(), key,
                                      [](const Tile& tile, std::int64_t k) { return tile.key < k; });
      tiles_->erase(t);
    }
  }

  void replaceIndex(std::int64_t key, std::uint32_t from, std::uint32_t to)
  {
    std::vector<std::uint32_t>* items = mutableTile(key, false);
    if (!items)
      return;
    std::replace(items->begin(), items->end(), from, to);
  }

  std::vector<std::shared_ptr<Chunk>> chunks_;
  std::shared_ptr<Table> tiles_;
  std::size_t size_ = 0;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FASTSLAM_LANDMARK_MAP_H
