#include "rbpf_slam/core/grid/occupancy_grid.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>

namespace rbpf_slam
{
namespace core
{
namespace
{
// Decimal resolutions put border points a few ulps off the border: snap within 1e-9 cells onto it (as
// OccupancyImage does), so 0.15 m at 0.05 m/cell is cell 3, not 2.
int cellIndex(double v, double resolution)
{
  const double g = v / resolution;
  // Beyond the cells a grid may hold (or NaN): the nearest such cell outside, which reads unknown and which
  // grow() refuses to create; casting an out-of-range double to int would be undefined.
  const double far = static_cast<double>(OccupancyGrid::kMaxTileIndex) * OccupancyGrid::kTileSize;
  if (!(std::abs(g) < far))
    return static_cast<int>(g > 0.0 ? far : -far);
  const double r = std::round(g);
  return static_cast<int>(std::abs(g - r) < 1e-9 ? r : std::floor(g));
}

/** Whether tiles with index @p t (on either axis) may exist. */
bool tileIndexInRange(int t)
{
  return t > -OccupancyGrid::kMaxTileIndex && t < OccupancyGrid::kMaxTileIndex;
}
}  // namespace

std::string OccupancyGridConfig::validate() const
{
  if (!(std::isfinite(resolution) && resolution > 0.0))
    return "resolution must be > 0";
  if (!(std::isfinite(log_odds_hit) && log_odds_hit > 0.0f))
    return "log_odds_hit must be > 0";
  if (!(std::isfinite(log_odds_free) && log_odds_free < 0.0f))
    return "log_odds_free must be < 0";
  if (!(std::isfinite(log_odds_clamp) && log_odds_clamp > 0.0f))
    return "log_odds_clamp must be > 0";
  if (!(std::isfinite(occupied_log_odds) && std::isfinite(free_log_odds) && free_log_odds <= occupied_log_odds))
    return "free_log_odds must be <= occupied_log_odds";
  if (occupied_log_odds < 0.0f)
    return "occupied_log_odds must be >= 0 (an unobserved cell, log-odds 0, is not occupied)";
  const double unit = static_cast<double>(log_odds_clamp) / OccupancyGrid::kCellMax;
  if (log_odds_hit < unit || -log_odds_free < unit)
    return "log_odds_hit and -log_odds_free must be >= log_odds_clamp / 32000 (the cells' fixed-point unit)";
  return "";
}

std::string ScanLimits::validate() const
{
  if (!(std::isfinite(range_min) && range_min >= 0.0))
    return "range_min must be >= 0";
  if (!(std::isfinite(range_max) && range_max > range_min))
    return "range_max must be > range_min";
  if (!(std::isfinite(no_return_free_range) && no_return_free_range >= 0.0))
    return "no_return_free_range must be >= 0";
  return "";
}

BeamKind classifyBeam(float r, const ScanData& scan, const ScanLimits& limits, double* length)
{
  if (std::isnan(r) || r == -std::numeric_limits<float>::infinity())
    return BeamKind::kSkip;
  if (r == std::numeric_limits<float>::infinity())
  {
    // No return within the sensor's range: the space in front is free, as far as we trust it.
    *length = std::min(limits.no_return_free_range, limits.range_max);
    return *length > 0.0 ? BeamKind::kFree : BeamKind::kSkip;
  }
  const double lo = std::max(limits.range_min, scan.range_min);
  if (r < lo)
    return BeamKind::kSkip;
  if (r > scan.range_max)
  {
    // REP-117 drivers report these as +Inf; a reading above the sensor's range_max is the same statement.
    *length = std::min(limits.no_return_free_range, limits.range_max);
    return *length > 0.0 ? BeamKind::kFree : BeamKind::kSkip;
  }
  if (r > limits.range_max)
  {
    // A real return beyond the usable window: the first range_max metres are free, the end is not mapped.
    *length = limits.range_max;
    return BeamKind::kFree;
  }
  *length = r;
  return BeamKind::kHit;
}

OccupancyGrid::OccupancyGrid(const OccupancyGridConfig& config)
  : config_(config), scale_(static_cast<float>(kCellMax) / std::max(config.log_odds_clamp, 1e-6f))
{
  raw_hit_ = rawDelta(config_.log_odds_hit);
  raw_free_ = rawDelta(config_.log_odds_free);
  const double occ = std::floor(static_cast<double>(config_.occupied_log_odds) * scale_);
  raw_occupied_ = static_cast<int>(std::max<double>(-kCellMax - 1, std::min<double>(kCellMax, occ)));
}

int OccupancyGrid::rawDelta(float delta) const
{
  const long r = std::lround(static_cast<double>(delta) * scale_);
  return static_cast<int>(std::max<long>(-2 * kCellMax, std::min<long>(2 * kCellMax, r)));
}

void OccupancyGrid::cellOf(double x, double y, int* ix, int* iy) const
{
  *ix = cellIndex(x, config_.resolution);
  *iy = cellIndex(y, config_.resolution);
}

void OccupancyGrid::grow(int tx, int ty)
{
  const auto refuse = [&](const std::string& why) {
    const double tile_m = kTileSize * config_.resolution;
    throw std::out_of_range("occupancy grid: refusing to grow to the tile at (" + std::to_string(tx * tile_m) + ", " +
                            std::to_string(ty * tile_m) + ") m: " + why);
  };
  if (!tileIndexInRange(tx) || !tileIndexInRange(ty))
    refuse("it is further from the origin than any map's cells (" + std::to_string(kMaxTileIndex) + " tiles)");
  if (ntx_ == 0)
  {
    // Start with some room around the first tile, so the first metres of travel do not reallocate.
    tx0_ = tx - 2;
    ty0_ = ty - 2;
    ntx_ = nty_ = 5;
    tiles_.assign(25, nullptr);
    return;
  }
  int nx0 = tx0_, ny0 = ty0_, nx1 = tx0_ + ntx_, ny1 = ty0_ + nty_;
  // Grow by at least half the current size in the needed direction: amortised O(1) per tile.
  if (tx < nx0)
    nx0 = std::min(tx, nx0 - std::max(2, ntx_ / 2));
  if (tx >= nx1)
    nx1 = std::max(tx + 1, nx1 + std::max(2, ntx_ / 2));
  if (ty < ny0)
    ny0 = std::min(ty, ny0 - std::max(2, nty_ / 2));
  if (ty >= ny1)
    ny1 = std::max(ty + 1, ny1 + std::max(2, nty_ / 2));
  const std::int64_t slots = static_cast<std::int64_t>(nx1 - nx0) * (ny1 - ny0);
  if (slots > kMaxTileSlots)
    refuse("the grid would span " + std::to_string(nx1 - nx0) + " x " + std::to_string(ny1 - ny0) +
           " tiles, more than " + std::to_string(kMaxTileSlots));
  std::vector<std::shared_ptr<Tile>> grown(static_cast<std::size_t>(slots));
  for (int j = 0; j < nty_; ++j)
    for (int i = 0; i < ntx_; ++i)
      grown[static_cast<std::size_t>(j + ty0_ - ny0) * (nx1 - nx0) + (i + tx0_ - nx0)] =
          std::move(tiles_[static_cast<std::size_t>(j) * ntx_ + i]);
  tiles_.swap(grown);
  tx0_ = nx0;
  ty0_ = ny0;
  ntx_ = nx1 - nx0;
  nty_ = ny1 - ny0;
}

OccupancyGrid::Tile& OccupancyGrid::mutableTile(int tx, int ty)
{
  if (tx < tx0_ || ty < ty0_ || tx >= tx0_ + ntx_ || ty >= ty0_ + nty_)
    grow(tx, ty);
  std::shared_ptr<Tile>& p = tiles_[static_cast<std::size_t>(ty - ty0_) * ntx_ + (tx - tx0_)];
  if (!p)
  {
    p = std::make_shared<Tile>();
    p->cells.fill(0);
    p->coarse.fill(0);
    if (config_.track_hits)
      p->hit_at.assign(static_cast<std::size_t>(kTileSize * kTileSize), static_cast<std::uint16_t>(kHitCentre));
  }
  else if (p.use_count() > 1)
    p = std::make_shared<Tile>(*p);  // copy-on-write: another grid still reads the old one
  return *p;
}

void OccupancyGrid::addLogOdds(int ix, int iy, float delta)
{
  addRaw(&mutableTile(ix >> kTileBits, iy >> kTileBits), ix, iy, rawDelta(delta));
}

void OccupancyGrid::bresenham(int x0, int y0, int x1, int y1, std::vector<std::pair<int, int>>* cells)
{
  cells->clear();
  const int dx = std::abs(x1 - x0), dy = std::abs(y1 - y0);
  const int sx = x1 >= x0 ? 1 : -1, sy = y1 >= y0 ? 1 : -1;
  cells->reserve(static_cast<std::size_t>(std::max(dx, dy)) + 1);
  int x = x0, y = y0;
  if (dx >= dy)
  {
    int err = 2 * dy - dx;
    for (int k = 0; k <= dx; ++k)
    {
      cells->emplace_back(x, y);
      if (err > 0)
      {
        y += sy;
        err -= 2 * dx;
      }
      err += 2 * dy;
      x += sx;
    }
  }
  else
  {
    int err = 2 * dx - dy;
    for (int k = 0; k <= dy; ++k)
    {
      cells->emplace_back(x, y);
      if (err > 0)
      {
        x += sx;
        err -= 2 * dy;
      }
      err += 2 * dx;
      y += sy;
    }
  }
}

void OccupancyGrid::updateRay(double sx, double sy, double ex, double ey, bool hit)
{
  int x0, y0, x1, y1;
  cellOf(sx, sy, &x0, &y0);
  cellOf(ex, ey, &x1, &y1);
  // The line's cells are listed before any is written: refuse a ray no grid could hold before listing them.
  const bool ends_in_range = tileIndexInRange(x0 >> kTileBits) && tileIndexInRange(y0 >> kTileBits) &&
                             tileIndexInRange(x1 >> kTileBits) && tileIndexInRange(y1 >> kTileBits);
  if (!ends_in_range || std::max(std::abs(x1 - x0), std::abs(y1 - y0)) > kMaxRayCells)
    throw std::out_of_range("occupancy grid: refusing the ray from (" + std::to_string(sx) + ", " + std::to_string(sy) +
                            ") to (" + std::to_string(ex) + ", " + std::to_string(ey) + ") m: " +
                            (ends_in_range ? "longer than " + std::to_string(kMaxRayCells) + " cells"
                                           : std::string("an end is further from the origin than any map's cells")));
  bresenham(x0, y0, x1, y1, &line_);
  // Cache the tile of the previous cell: a ray stays in one tile for up to 64 cells.
  int ctx = std::numeric_limits<int>::min(), cty = 0;
  Tile* t = nullptr;
  for (std::size_t k = 0; k < line_.size(); ++k)
  {
    const int ix = line_[k].first, iy = line_[k].second;
    const int tx = ix >> kTileBits, ty = iy >> kTileBits;
    if (tx != ctx || ty != cty || !t)
    {
      t = &mutableTile(tx, ty);
      ctx = tx;
      cty = ty;
    }
    const bool end = hit && k + 1 == line_.size();
    if (end && !t->hit_at.empty())
    {
      // The hit's place in its cell, in 256ths, into the cell's running mean.
      const double inv = 1.0 / config_.resolution;
      const int hx = std::min(255, std::max(0, static_cast<int>((ex * inv - ix) * 256.0)));
      const int hy = std::min(255, std::max(0, static_cast<int>((ey * inv - iy) * 256.0)));
      std::uint16_t& at = t->hit_at[static_cast<std::size_t>(index(ix, iy))];
      const int old = (*t)[static_cast<std::size_t>(index(ix, iy))];
      if (old <= 0)
        at = static_cast<std::uint16_t>((hx << 8) | hy);
      else
      {
        const int n = std::min(15, old / std::max(1, raw_hit_)) + 1;
        const auto toward = [n](int from, int to) {
          const int d = to - from;  // at least one unit towards the hit, so the mean does not stick
          return from + (d == 0 ? 0 : d > 0 ? std::max(1, d / n) : std::min(-1, d / n));
        };
        at = static_cast<std::uint16_t>((toward(at >> 8, hx) << 8) | toward(at & 255, hy));
      }
    }
    addRaw(t, ix, iy, end ? raw_hit_ : raw_free_);
  }
}

void OccupancyGrid::hitPoint(int ix, int iy, double* x, double* y) const
{
  const int at = hitBytes(ix, iy);
  *x = (ix + hitFraction(at >> 8)) * config_.resolution;
  *y = (iy + hitFraction(at & 255)) * config_.resolution;
}

int OccupancyGrid::insertScan(const Pose2& sensor_pose, const ScanData& scan, const ScanLimits& limits)
{
  int used = 0;
  for (std::size_t i = 0; i < scan.ranges.size(); ++i)
  {
    double length = 0.0;
    const BeamKind kind = classifyBeam(scan.ranges[i], scan, limits, &length);
    if (kind == BeamKind::kSkip)
      continue;
    const double a = sensor_pose.theta + scan.angle_min + static_cast<double>(i) * scan.angle_increment;
    updateRay(sensor_pose.x, sensor_pose.y, sensor_pose.x + length * std::cos(a), sensor_pose.y + length * std::sin(a),
              kind == BeamKind::kHit);
    ++used;
  }
  return used;
}

std::size_t OccupancyGrid::tileCount() const
{
  return static_cast<std::size_t>(std::count_if(tiles_.begin(), tiles_.end(), [](const auto& p) { return p != nullptr; }));
}

bool OccupancyGrid::sharesTileWith(const OccupancyGrid& other, int tx, int ty) const
{
  const Tile* a = tile(tx, ty);
  return a != nullptr && a == other.tile(tx, ty);
}

void OccupancyGrid::exportCells(const std::function<std::int8_t(float)>& convert, std::vector<std::int8_t>* data,
                                int* width, int* height, MapOrigin* origin) const
{
  // Bounding box of the tiles that exist.
  int i0 = ntx_, i1 = -1, j0 = nty_, j1 = -1;
  for (int j = 0; j < nty_; ++j)
    for (int i = 0; i < ntx_; ++i)
      if (tiles_[static_cast<std::size_t>(j) * ntx_ + i])
      {
        i0 = std::min(i0, i);
        i1 = std::max(i1, i);
        j0 = std::min(j0, j);
        j1 = std::max(j1, j);
      }
  data->clear();
  *origin = MapOrigin();
  if (i1 < 0)
  {
    *width = *height = 0;
    return;
  }
  const int w = (i1 - i0 + 1) * kTileSize, h = (j1 - j0 + 1) * kTileSize;
  *width = w;
  *height = h;
  const int cx0 = (tx0_ + i0) * kTileSize, cy0 = (ty0_ + j0) * kTileSize;
  origin->x = cx0 * config_.resolution;
  origin->y = cy0 * config_.resolution;
  data->assign(static_cast<std::size_t>(w) * h, -1);
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i)
    {
      const Tile* t = tiles_[static_cast<std::size_t>(j) * ntx_ + i].get();
      if (!t)
        continue;
      for (int r = 0; r < kTileSize; ++r)
      {
        std::int8_t* row = data->data() + static_cast<std::size_t>((j - j0) * kTileSize + r) * w + (i - i0) * kTileSize;
        for (int c = 0; c < kTileSize; ++c)
        {
          const float l = static_cast<float>((*t)[(r << kTileBits) | c]) / scale_;
          row[c] = convert(l);
        }
      }
    }
}

void OccupancyGrid::exportProbabilities(std::vector<std::int8_t>* data, int* width, int* height,
                                        MapOrigin* origin) const
{
  exportCells(
      [](float l) {
        return l == 0.0f ? std::int8_t(-1)
                         : static_cast<std::int8_t>(std::lround(100.0 / (1.0 + std::exp(-static_cast<double>(l)))));
      },
      data, width, height, origin);
}

OccupancyImage OccupancyGrid::toImage() const
{
  std::vector<std::int8_t> data;
  int w = 0, h = 0;
  MapOrigin origin;
  const float occ = config_.occupied_log_odds, fr = config_.free_log_odds;
  exportCells(
      [occ, fr](float l) {
        if (l == 0.0f)
          return OccupancyImage::kUnknown;
        return l > occ ? OccupancyImage::kOccupied : (l < fr ? OccupancyImage::kFree : OccupancyImage::kUnknown);
      },
      &data, &w, &h, &origin);
  return OccupancyImage(w, h, config_.resolution, origin, std::move(data));
}

}  // namespace core
}  // namespace rbpf_slam
