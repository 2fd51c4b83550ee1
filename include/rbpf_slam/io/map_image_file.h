#ifndef RBPF_SLAM_IO_MAP_IMAGE_FILE_H
#define RBPF_SLAM_IO_MAP_IMAGE_FILE_H

#include <string>
#include <vector>

#include "rbpf_slam/io/files.h"

#include "rbpf_slam/core/occupancy_image.h"

namespace rbpf_slam
{
namespace io
{
/**
 * @brief Loads a map in the ROS map_server layout: a YAML file naming an image (PGM, as map_saver writes it, PNG,
 * or any 8-bit image OpenCV reads).
 *
 * YAML keys: image (relative to the YAML's folder, or absolute), resolution [m/cell], origin [x, y, yaw]
 * (world pose of the image's lower-left corner), negate (0/1), occupied_thresh, free_thresh, and the
 * optional mode: trinary (default), scale or raw. scale and raw are read like trinary: the simulator
 * needs occupied / free / unknown only. Other keys are ignored.
 *
 * As map_server does, pixel values are on a 0..255 scale (a PGM with maxval < 255 is scaled up), colour
 * channels are averaged (alpha ignored) to a value v, and p = (255 - v) / 255 (v / 255 with negate): occupied
 * if p > occupied_thresh, free if p < free_thresh, unknown otherwise. The image is flipped so that row 0 of the
 * grid is the bottom row.
 *
 * @throws std::runtime_error with a message naming the file and the key, line or problem, e.g.
 * "maps/indoor.yaml: key 'resolution' is missing", "maps/indoor.pgm: truncated: expected 187200 pixel bytes, got 5".
 */
core::OccupancyImage loadMapImage(const std::string& yaml_path);

/** @brief The image file saveMapImage writes beside the YAML. */
enum class MapImageFormat
{
  kPgm,  ///< binary PGM (P5), map_saver's format
  kPng   ///< PNG: the same pixels, viewable anywhere; map_server reads it too
};

/**
 * @brief Saves @p map as map_server's map_saver does: an image (0 occupied, 254 free, 205 unknown, top row
 * first) named after the YAML (maps/indoor.yaml -> maps/indoor.pgm, or .png) and the YAML (image given relative,
 * negate 0, occupied_thresh 0.65, free_thresh 0.196), so that loadMapImage() gives the same cells back.
 *
 * Each file is written beside its final name and renamed into place, so a failure leaves no half file.
 * @throws std::runtime_error if the map is empty or a file cannot be written.
 */
void saveMapImage(const core::OccupancyImage& map, const std::string& yaml_path,
                  MapImageFormat format = MapImageFormat::kPgm);
/** @brief What saveMapImage writes, image first: for callers that write it with other files at once. */
std::vector<FileContent> encodeMapImage(const core::OccupancyImage& map, const std::string& yaml_path,
                                        MapImageFormat format = MapImageFormat::kPgm);

}  // namespace io
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_IO_MAP_IMAGE_FILE_H
