#ifndef RBPF_SLAM_CORE_FILTER_CELL_KEY_H
#define RBPF_SLAM_CORE_FILTER_CELL_KEY_H

#include <cstdint>

namespace rbpf_slam
{
namespace core
{
/**
 * @brief One hash key for a 2D cell: ix in the high word, iy's low 32 bits in the low word.
 *
 * Shifted as unsigned, since cells left of or behind the origin have negative indices and a left shift of a
 * negative value is undefined.
 */
inline std::int64_t packCell(std::int64_t ix, std::int64_t iy)
{
  return static_cast<std::int64_t>((static_cast<std::uint64_t>(ix) << 32) ^
                                   (static_cast<std::uint64_t>(iy) & 0xffffffffULL));
}

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FILTER_CELL_KEY_H
