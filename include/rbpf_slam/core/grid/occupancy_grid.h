#ifndef RBPF_SLAM_CORE_GRID_OCCUPANCY_GRID_H
#define RBPF_SLAM_CORE_GRID_OCCUPANCY_GRID_H

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "rbpf_slam/core/grid/occupancy_image.h"
#include "rbpf_slam/core/filter/pose2.h"

namespace rbpf_slam
{
namespace core
{
/** @brief How rays change the log-odds of the cells they cross and end in. */
struct OccupancyGridConfig
{
  double resolution = 0.05;  ///< [m/cell]
  // Defaults: a hit is strong evidence, one free pass weak, and the
  // clamp keeps a cell able to change its mind after a few dozen scans.
  float log_odds_hit = 0.9f;    ///< added to the cell a beam ends in
  float log_odds_free = -0.1f;  ///< added to each cell a beam crosses
  float log_odds_clamp = 20.0f; ///< |log-odds| never exceeds this (cells store it in 16-bit fixed point:
                                ///< one unit = log_odds_clamp / 32000; hit and free must be at least one unit)
  // Export: occupied above, free below (log-odds 0 = p 0.5 = never observed, or evidence that cancelled).
  float occupied_log_odds = 0.0f;  ///< cells with log-odds > this are occupied in trinary exports
  float free_log_odds = 0.0f;      ///< cells with log-odds < this are free in trinary exports
  /// Keep each cell's mean hit point (Tile::hit_at; two bytes more per cell; hitPoint()).
  bool track_hits = false;

  /** @brief Empty when valid, else a message naming the bad parameter. */
  std::string validate() const;
};

/**
 * @brief A planar scan as REP-117 states it: ranges along bearings angle_min + i * angle_increment in the
 * sensor frame; NaN = invalid, +Inf = no return within range_max, -Inf = too close.
 */
struct ScanData
{
  std::vector<float> ranges;
  double angle_min = 0.0;        ///< [rad]
  double angle_increment = 0.0;  ///< [rad]
  double range_min = 0.0;        ///< [m] the sensor's
  double range_max = 1e9;        ///< [m] the sensor's
};

/**
 * @brief Which part of a scan a map uses: the usable range window (0.15 - 20 m by default) and how
 * far a no-return clears free space.
 */
struct ScanLimits
{
  double range_min = 0.15;  ///< [m] shorter readings are ignored (the robot's own body, dust)
  double range_max = 20.0;  ///< [m] longer readings mark no hit; free space is cleared up to here
  double no_return_free_range = 20.0;  ///< [m] +Inf (no return) clears free space up to here, no hit

  std::string validate() const;
};

/** @brief What a beam is, once the sensor's and the map's limits are applied. */
enum class BeamKind
{
  kSkip,  ///< NaN, -Inf, below range_min: no information
  kHit,   ///< free space up to the end point, which is occupied
  kFree   ///< free space up to @p length, no hit (no return, or beyond range_max)
};
/** @brief Classifies range @p r; @p length is the length to trace (the range, or the clearing limit). */
BeamKind classifyBeam(float r, const ScanData& scan, const ScanLimits& limits, double* length);

/**
 * @brief A log-odds occupancy grid that grows as the robot explores, stored in square tiles of
 * kTileSize x kTileSize cells held by shared pointers.
 *
 * Cell (ix, iy) covers [ix, ix + 1) x [iy, iy + 1) resolution-sized squares of the map frame: a point on a
 * border belongs to the cell above / to the right of it. Tiles that no ray has touched do not exist (their
 * cells read 0 = unknown). Copying a grid copies only tile pointers; a write to a tile that another copy
 * still holds clones that tile first (copy-on-write), so per-particle maps cost only the tiles they change.
 */
class OccupancyGrid
{
public:
  static constexpr int kTileBits = 6;
  static constexpr int kTileSize = 1 << kTileBits;  ///< 64 cells
  /// A cell's log-odds in fixed point (log-odds = raw * log_odds_clamp / kCellMax): half the memory of a float, which matters
  /// when 30 particles own maps; hit and free increments are whole units, so sums are exact.
  using Cell = std::int16_t;
  static constexpr int kCellMax = 32000;  ///< raw value of +log_odds_clamp
  /// Coarse level (a pyramid of one step) for coarse-to-fine scan matching: each coarse cell covers
  /// kCoarseSize x kCoarseSize cells and counts how many of them are occupied (raw > rawOccupiedThreshold()),
  /// kept current by every write.
  static constexpr int kCoarseBits = 2;
  static constexpr int kCoarseSize = 1 << kCoarseBits;  ///< 4 cells
  static constexpr int kCoarseTileBits = kTileBits - kCoarseBits;
  static constexpr int kCoarsePerTile = 1 << kCoarseTileBits;  ///< 16 coarse cells per tile side
  /// Tiles exist only within (-kMaxTileIndex, kMaxTileIndex) on each axis: cells within 2^30 of the origin
  /// (53 000 km at 0.05 m/cell), so cell indices and their sums stay far from int's limits.
  static constexpr int kMaxTileIndex = 1 << (30 - kTileBits);
  /// At most this many tile slots (pointers, null or not) in the grid's bounding box: 64 MiB of them, a
  /// 6.5 km square at 0.05 m/cell. A write that would grow the grid beyond it throws std::out_of_range.
  static constexpr std::int64_t kMaxTileSlots = std::int64_t{ 1 } << 22;
  /// updateRay() refuses (std::out_of_range) a ray across more cells than this (52 km at 0.05 m/cell).
  static constexpr int kMaxRayCells = 1 << 20;
  struct Tile
  {
    std::array<Cell, kTileSize * kTileSize> cells;
    std::array<std::uint8_t, kCoarsePerTile * kCoarsePerTile> coarse;  // occupied cells per coarse cell
    /// Where in each cell its hits lie (GMapping keeps the mean hit point per cell): x in the high byte, y in the
    /// low one, in 256ths of the cell (see hitFraction()). A running mean: the first hit on a cell without hit
    /// evidence sets it, each later one moves it by 1 / (n + 1) of the way, n the hits the cell's log-odds
    /// holds (at most 15).
    /// Empty unless the grid's config tracks hits.
    std::vector<std::uint16_t> hit_at;
    Cell& operator[](std::size_t i) { return cells[i]; }
    Cell operator[](std::size_t i) const { return cells[i]; }
  };

  explicit OccupancyGrid(const OccupancyGridConfig& config = OccupancyGridConfig());

  const OccupancyGridConfig& config() const { return config_; }
  double resolution() const { return config_.resolution; }

  /** @brief The cell containing the map point (x, y). */
  void cellOf(double x, double y, int* ix, int* iy) const;

  /** @brief Log-odds of a cell (0 where nothing was observed). */
  float logOdds(int ix, int iy) const
  {
    const Tile* t = tile(ix >> kTileBits, iy >> kTileBits);
    return t ? static_cast<float>((*t)[index(ix, iy)]) / scale_ : 0.0f;
  }
  /** @brief The raw (fixed-point) value of a cell, 0 where nothing was observed. */
  int rawLogOdds(int ix, int iy) const
  {
    const Tile* t = tile(ix >> kTileBits, iy >> kTileBits);
    return t ? (*t)[index(ix, iy)] : 0;
  }
  /** @brief Occupied cells in coarse cell (cx, cy) (cells [cx * kCoarseSize, (cx + 1) * kCoarseSize) x ...). */
  int coarseCount(int cx, int cy) const
  {
    const Tile* t = tile(cx >> kCoarseTileBits, cy >> kCoarseTileBits);
    return t ? t->coarse[coarseIndex(cx, cy)] : 0;
  }
  static int coarseIndex(int cx, int cy)
  {
    return ((cy & (kCoarsePerTile - 1)) << kCoarseTileBits) | (cx & (kCoarsePerTile - 1));
  }
  /** @brief Raw threshold: a cell is occupied (log-odds > occupied_log_odds) iff its raw value is > this. */
  int rawOccupiedThreshold() const { return raw_occupied_; }
  /** @brief The tile (tx, ty) (cells [tx * kTileSize, (tx + 1) * kTileSize) x ...), null if it does not exist. */
  const Tile* tileAt(int tx, int ty) const { return tile(tx, ty); }
  /** @brief The position within its cell [0, 1) of a hit_at byte. */
  static double hitFraction(int byte) { return (byte + 0.5) / 256.0; }
  static constexpr int kHitCentre = 0x8080;  ///< hit_at of a cell without hits: about its centre
  /** @brief The mean hit point of cell (ix, iy) in map coordinates (about the cell's centre where it has no tile). */
  void hitPoint(int ix, int iy, double* x, double* y) const;
  /** @brief The raw hit_at value of cell (ix, iy) (kHitCentre where it has no tile). */
  int hitBytes(int ix, int iy) const
  {
    const Tile* t = tile(ix >> kTileBits, iy >> kTileBits);
    return t && !t->hit_at.empty() ? t->hit_at[static_cast<std::size_t>(index(ix, iy))] : kHitCentre;
  }
  /** @brief Index of cell (ix, iy) in its tile. */
  static int cellIndexInTile(int ix, int iy) { return index(ix, iy); }

  /**
   * @brief Adds @p delta to a cell (clamped), creating its tile if needed.
   * @throws std::out_of_range when the tile is out of bounds (kMaxTileIndex, kMaxTileSlots); the grid is unchanged.
   */
  void addLogOdds(int ix, int iy, float delta);

  /** @brief Occupied in the sense of the export threshold (log-odds > occupied_log_odds). */
  bool occupied(int ix, int iy) const { return rawLogOdds(ix, iy) > raw_occupied_; }

  /**
   * @brief The cells of the Bresenham line from cell (x0, y0) to cell (x1, y1), both ends included, in
   * order from the start; every octant; each step moves to an 8-neighbour.
   */
  static void bresenham(int x0, int y0, int x1, int y1, std::vector<std::pair<int, int>>* cells);

  /**
   * @brief Traces one ray from the map point (sx, sy) to (ex, ey): every cell but the last gets
   * log_odds_free; the last gets log_odds_hit when @p hit, else log_odds_free too.
   * @throws std::out_of_range (nothing written) when an end is beyond the cells a grid holds (kMaxTileIndex;
   * NaN too) or the ray crosses more than kMaxRayCells cells; from addLogOdds' bounds too (cells before stay).
   */
  void updateRay(double sx, double sy, double ex, double ey, bool hit);

  /**
   * @brief Integrates a scan taken by a sensor at @p sensor_pose (map frame): each beam per classifyBeam().
   * @return the number of beams used.
   * @throws std::out_of_range when a beam reaches a tile out of bounds (see addLogOdds; the beams before it stay).
   */
  int insertScan(const Pose2& sensor_pose, const ScanData& scan, const ScanLimits& limits);

  /** @brief Number of tiles that exist. */
  std::size_t tileCount() const;
  /** @brief The bytes tile @p t takes: the Tile itself and its hit_at cells (when kept). */
  static std::size_t tileBytes(const Tile& t) { return sizeof(Tile) + t.hit_at.capacity() * sizeof(std::uint16_t); }
  /** @brief [m^2] The area one tile covers (kTileSize x kTileSize cells). */
  double tileArea() const
  {
    const double side = kTileSize * config_.resolution;
    return side * side;
  }
  /** @brief Tile bounds: tiles [tile_x0, tile_x0 + tiles_x) x [tile_y0, tile_y0 + tiles_y) may exist. */
  int tileX0() const { return tx0_; }
  int tileY0() const { return ty0_; }
  int tilesX() const { return ntx_; }
  int tilesY() const { return nty_; }
  /** @brief Whether two grids share the storage of tile (tx, ty) (copy-on-write not yet triggered). */
  bool sharesTileWith(const OccupancyGrid& other, int tx, int ty) const;

  /**
   * @brief The bounding box of the existing tiles as a nav_msgs/OccupancyGrid-like array: row-major, row 0 at
   * the bottom, -1 unknown (log-odds exactly 0), else 0..100 = round(100 * p) with p = 1 - 1 / (1 + e^l).
   * An empty grid gives a 0 x 0 array.
   */
  void exportProbabilities(std::vector<std::int8_t>* data, int* width, int* height, MapOrigin* origin) const;

  /** @brief The same box as a trinary OccupancyImage (occupied / free / unknown by the config's thresholds). */
  OccupancyImage toImage() const;

private:
  static int index(int ix, int iy) { return ((iy & (kTileSize - 1)) << kTileBits) | (ix & (kTileSize - 1)); }
  const Tile* tile(int tx, int ty) const
  {
    const int i = tx - tx0_, j = ty - ty0_;
    if (i < 0 || j < 0 || i >= ntx_ || j >= nty_)
      return nullptr;
    return tiles_[static_cast<std::size_t>(j) * ntx_ + i].get();
  }
  Tile& mutableTile(int tx, int ty);
  int rawDelta(float delta) const;
  /** @brief Adds raw @p delta to cell (ix, iy) of @p t (clamped), keeping its coarse count current. */
  void addRaw(Tile* t, int ix, int iy, int delta) const
  {
    Cell& v = (*t)[static_cast<std::size_t>(index(ix, iy))];
    const int old = v;
    const int now = std::max(-kCellMax, std::min(kCellMax, old + delta));
    v = static_cast<Cell>(now);
    const bool was = old > raw_occupied_, is = now > raw_occupied_;
    if (was != is)
    {
      std::uint8_t& c = t->coarse[static_cast<std::size_t>(coarseIndex(ix >> kCoarseBits, iy >> kCoarseBits))];
      c = static_cast<std::uint8_t>(is ? c + 1 : c - 1);
    }
  }
  void exportCells(const std::function<std::int8_t(float)>& convert, std::vector<std::int8_t>* data, int* width,
                   int* height, MapOrigin* origin) const;
  void grow(int tx, int ty);

  OccupancyGridConfig config_;
  float scale_ = 1.0f;         // raw units per log-odds unit
  int raw_hit_ = 0, raw_free_ = 0, raw_occupied_ = 0;
  int tx0_ = 0, ty0_ = 0, ntx_ = 0, nty_ = 0;
  std::vector<std::shared_ptr<Tile>> tiles_;  // row-major over the tile bounds; null = never touched
  std::vector<std::pair<int, int>> line_;     // scratch for rays
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_GRID_OCCUPANCY_GRID_H
