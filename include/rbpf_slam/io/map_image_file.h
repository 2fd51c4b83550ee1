#ifndef RBPF_SLAM_IO_MAP_IMAGE_FILE_H
#define RBPF_SLAM_IO_MAP_IMAGE_FILE_H

#include <string>
#include <vector>

#include "rbpf_slam/io/files.h"

#include "rbpf_slam/core/grid/occupancy_image.h"

namespace rbpf_slam
{
namespace io
{
/**
 * @brief Loads a map in the ROS map_server layout: a YAML file naming a PGM image.
 *
 * YAML keys: image (relative to the YAML's folder, or absolute), resolution [m/cell], origin [x, y, yaw]
 * (world pose of the image's lower-left corner), negate (0/1), occupied_thresh, free_thresh, and the
 * optional mode: trinary (default), scale or raw. scale and raw are read like trinary: the simulator
 * needs occupied / free / unknown only. Other keys are ignored.
 *
 * The image must be a binary (P5) or ASCII (P2) PGM with maxval <= 255; '#' comments are allowed in the
 * header. As map_server does, each pixel value v gives p = (maxval - v) / maxval (v / maxval with negate):
 * occupied if p > occupied_thresh, free if p < free_thresh, unknown otherwise (with maxval 255 this is
 * map_server's (255 - v) / 255). The image is flipped so that row 0 of the grid is the bottom row.
 *
 * @throws std::runtime_error with a message naming the file and the key, line or problem, e.g.
 * "maps/indoor.yaml: key 'resolution' is missing", "maps/indoor.pgm: not a PGM file (magic 'XY')".
 */
core::OccupancyImage loadMapImage(const std::string& yaml_path);

/**
 * @brief Saves @p map as map_server's map_saver does: a P5 PGM (0 occupied, 254 free, 205 unknown, top row
 * first) named after the YAML (maps/indoor.yaml -> maps/indoor.pgm) and the YAML (image given relative,
 * negate 0, occupied_thresh 0.65, free_thresh 0.196), so that loadMapImage() gives the same cells back.
 *
 * Each file is written beside its final name and renamed into place, so a failure leaves no half file.
 * @throws std::runtime_error if the map is empty or a file cannot be written.
 */
void saveMapImage(const core::OccupancyImage& map, const std::string& yaml_path);
/** @brief What saveMapImage writes, image first: for callers that write it with other files at once. */
std::vector<FileContent> encodeMapImage(const core::OccupancyImage& map, const std::string& yaml_path);
/**
 * @brief Where the map that restart @p timeline + 1 ended is kept beside the map @p yaml_path (FILE.yaml ->
 * FILE.restartN.yaml + .pgm), by the node and slam_bag alike.
 */
std::string endedMapPath(const std::string& yaml_path, int timeline);

}  // namespace io
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_IO_MAP_IMAGE_FILE_H
