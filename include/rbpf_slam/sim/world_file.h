#ifndef RBPF_SLAM_SIM_WORLD_FILE_H
#define RBPF_SLAM_SIM_WORLD_FILE_H

#include <string>
#include <vector>

#include "rbpf_slam/sim/forest_world.h"

namespace rbpf_slam
{
namespace sim
{
/**
 * @brief Reads a tree list: plain text, one trunk a line `x y radius [height]` in metres.
 *
 * '#' starts a comment (a whole line or the end of one); blank lines are skipped. A trunk without a
 * height gets TrunkSpec's default; lean and taper are 0.
 *
 * @throws std::runtime_error "FILE:LINE: expected 'x y radius [height]', got '...'" (followed by the
 *         reason) for a line that is not 3 or 4 finite numbers with radius > 0 and height > 0, and
 *         "FILE: cannot open ..." for a file that cannot be read.
 */
std::vector<sim::TrunkSpec> loadTreeList(const std::string& path);

/**
 * @brief Reads a box list: plain text, one box a line `x y yaw_deg [length width height]` (metres, degrees), standing
 * on the ground; without the size a box is a car, 4.5 x 1.8 x 1.5 m (sim::BoxSpec's defaults). Comments and blank
 * lines as in a tree list.
 * @throws std::runtime_error "FILE:LINE: expected 'x y yaw_deg [length width height]', got '...'" (with the reason)
 *         for a line that is not 3 or 6 finite numbers with positive sizes, "FILE: cannot open ..." otherwise.
 */
std::vector<sim::BoxSpec> loadBoxList(const std::string& path);

/**
 * @brief Loads a world: a YAML world file when @p path ends in .yaml or .yml, otherwise a tree list.
 *
 * A bare tree list gives the trunks only: flat ground (amplitude 0), no crowns and no clutter, bounds
 * the tree extent + 2 m. Realism is configured in a YAML world file:
 * @code
 * trees: FILE          # tree list, relative to the YAML file's folder; or inline:
 * trees: [[x, y, radius], [x, y, radius, height], ...]
 * boxes: FILE          # box list (loadBoxList), relative to the YAML file's folder; or inline:
 * boxes: [[x, y, yaw_deg], [x, y, yaw_deg, length, width, height], ...]    # default: none
 * bounds: [min_x, min_y, max_x, max_y]     # default: tree extent + 2 m
 * tree: {height: 15, lean_sigma_deg: 0, taper: 0, seed: 1}
 * ground: {amplitude: 0.3, wavelength: 15, seed: 1}
 * clutter: {seed: 1, bushes: 0, rocks: 0, branches: 0, crowns: true, crown_base: 5, clearance: 0.8}
 * @endcode
 * Only `trees` is required; the values shown are the defaults. tree.height is given to trunks without
 * their own height; each trunk leans by lean_x, lean_y ~ N(0, tan(lean_sigma_deg)) drawn from tree.seed
 * and gets tree.taper (a thin trunk whose radius reaches 0 below its height ends in a point there). The
 * tree list's radius is the radius at the ground, as in sim::TrunkSpec. Clutter is added with
 * sim::addClutter, which keeps the clutter clear of the boxes as of the trunks.
 *
 * @throws std::runtime_error naming the file (and the line where known) for a file that cannot be read
 *         or parsed, an unknown or duplicate key, a value of the wrong type (naming the key, e.g.
 *         'ground.amplitude') or out of range (amplitude, wavelength, radius, height, counts, clearance,
 *         lean < 0 or not finite; bounds with min >= max; no trees and no bounds).
 */
sim::ForestWorld loadForestWorld(const std::string& path);

}  // namespace sim
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_SIM_WORLD_FILE_H
