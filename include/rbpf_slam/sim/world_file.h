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
 * tree: {height: 15, lean_sigma_deg: 0, taper: 0, seed: 1, listed_at: ground, listed_taper: 0}
 * tree: {lean_deg: [lo, hi], taper: [lo, hi], ...}    # or lean and taper drawn from intervals
 * ground: {amplitude: 0.3, wavelength: 15, seed: 1, margin: 20, slope: [0, 0]}
 * clutter: {seed: 1, bushes: 0, rocks: 0, branches: 0, crowns: true, crown_base: 5, clearance: 0.8}
 * whorls: {seed: 1, heights: [1, 6], spacing: [0.5, 1.0], fill: 0.7, per_whorl: [1, 4], live: 0.3,
 *          dead_length: [0.2, 1.0], live_length: [0.5, 1.5], thickness: [0.01, 0.04], tuft_radius: [0.15, 0.4]}
 * understory: {seed: 1, clearance: 0.3,
 *              saplings: {count: 0, dbh: [0.01, 0.05], height: [1.5, 4], crown_base: [0.5, 2],
 *                         crown_radius: [0.3, 0.8]},
 *              shrubs: {count: 0, radius: [0.3, 1.0], top: [0.5, 2.0]}}
 * track: {start: [0, 15, 0], drives: [straight, loop], clearance: 2.0, headroom: 3.0}
 * @endcode
 * Only `trees` is required; the values shown are the defaults (whorls and understory: none without their
 * section). tree.height is given to trunks without their own height; each trunk leans by lean_x, lean_y ~
 * N(0, tan(lean_sigma_deg)) drawn from tree.seed, or (lean_deg) by an angle drawn from [lo, hi] degrees in a
 * direction drawn uniformly, and gets tree.taper, or one drawn from [lo, hi] (then at most what ends the stem
 * in a point at its top); a thin trunk whose radius reaches 0 below its height ends in a point there. The tree
 * list's radius is the radius at the ground, as in sim::TrunkSpec; with listed_at: breast_height the list gives
 * each stem's centre and radius 1.3 m above its foot (that radius is radius - 1.3 * listed_taper), the foot and
 * the ground radius following from the lean and the taper. ground.slope adds a plane (sim::GroundSpec). Clutter
 * is added with sim::addClutter, which keeps the clutter clear of the boxes as of the trunks, then the
 * understory (sim::addUnderstory) and the whorls (sim::addWhorls). A [lo, hi] may be one number (lo = hi).
 * track (none without the section; `drives` is required in it) gives sim::ForestWorld::track: each drive
 * (sim::namedDrive: straight, loop or a waypoint file, relative to the YAML file's folder) taken from the start frame
 * of start [x, y, yaw_deg] into the world; bushes, rocks, saplings and shrubs keep clearance [m] from every route and
 * no branch on a stem comes within it lower than headroom [m] (sim::TrackSpec).
 *
 * @throws std::runtime_error naming the file (and the line where known) for a file that cannot be read
 *         or parsed, an unknown or duplicate key, a value of the wrong type (naming the key, e.g.
 *         'ground.amplitude') or out of range (amplitude, wavelength, radius, height, counts, clearance,
 *         lean < 0 or not finite; bounds with min >= max; no trees and no bounds; an interval with lo > hi;
 *         a slope steeper than 1; lean_sigma_deg with lean_deg; a sapling height <= 1.3 m; a track without drives
 *         or with a drive that cannot be read).
 */
sim::ForestWorld loadForestWorld(const std::string& path);

}  // namespace sim
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_SIM_WORLD_FILE_H
