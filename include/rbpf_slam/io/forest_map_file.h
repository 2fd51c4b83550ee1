#ifndef RBPF_SLAM_IO_FOREST_MAP_FILE_H
#define RBPF_SLAM_IO_FOREST_MAP_FILE_H

#include <functional>
#include <istream>
#include <string>
#include <vector>

#include "rbpf_slam/core/forest_map/forest_changes.h"
#include "rbpf_slam/core/forest_map/geodesy.h"
#include "rbpf_slam/core/fastslam/landmark_map.h"

namespace rbpf_slam
{
namespace io
{
/** @brief Where the map frame lies on the earth (core::GeoAnchor; not valid: a local frame only). */
using MapAnchor = core::GeoAnchor;

/** @brief A saved tree map: the trees of the best particle and the anchor of their frame. */
struct ForestMap
{
  MapAnchor anchor;
  std::vector<core::Landmark> trees;
  /// where the map was looked at from (core::ViewpointLog); empty: not known (e.g. a survey)
  std::vector<core::Viewpoint> viewpoints;
};

/**
 * @brief The package's one tree map file (the FastSLAM node's save_map and save_inventory, slam_bag's map.csv and
 * --save-map, the benchmarks' maps; rbpf_slam.evaluate.read_landmarks_csv reads it in Python). A CSV file:
 * optional comment lines first ('#'; the anchor as "# anchor: latitude=.. longitude=.. altitude=.. yaw=..
 * sigma=.."; each viewpoint as "# viewpoint: x=.. y=.. yaw=.. min_range=.. max_range=.. fov_min=.. fov_max=.."
 * (the sensor's pose [m, rad] in the map frame and its scope [m, rad]), then the header kForestMapHeader and one line per tree: id; centre x, y [m]; dbh (the trunk's
 * diameter, 2 r) [m]; the standard deviations of x, y and dbh [m]; observations (matches so far); provisional (1
 * until the filter confirmed the tree); cov_xy [m^2] (the centre's covariance, with sigma_x^2 and sigma_y^2);
 * first_seen and last_seen [s] (the clock of the data: ROS time of the sensor messages; empty when not known).
 */
extern const char* const kForestMapHeader;

/** @brief The file's text of @p map. */
std::string forestMapCsv(const ForestMap& map);
/** @brief Writes forestMapCsv() atomically (a temporary beside @p path, then a rename). @throws std::runtime_error. */
void writeForestMap(const std::string& path, const ForestMap& map);
/**
 * @brief Parses a tree map file's @p text (@p name in messages). Columns are found by the header's names, in any
 * order; id, x, y and dbh are required, the others default (sigma_x, sigma_y: 0.1 m; sigma_dbh: half the dbh;
 * observations 1; provisional 0; cov_xy 0; first_seen, last_seen unknown). Trees come back confirmed unless marked
 * provisional, with their covariance and radius variance from the sigmas.
 * @throws std::runtime_error "name:line: expected ..., got ..." on a malformed line, a missing header or column,
 * a duplicate id, a value that is not finite, a negative diameter or variance, or a value outside its physical
 * range (kMaxMapCoordinate and the other bounds below).
 */
/**
 * The physical range of a tree map's values: a value outside is refused with its file and line. A map frame is a
 * local tangent plane (kMaxMapCoordinate: at 100 km its flat-earth error passes a metre); the largest trunks
 * measured are about 11 m across.
 */
constexpr double kMaxMapCoordinate = 1e5;   ///< [m] |x|, |y| of trees and viewpoints
constexpr double kMaxDbh = 12.0;            ///< [m]
constexpr double kMaxPositionSigma = 1e3;   ///< [m] sigma_x, sigma_y
constexpr double kMaxViewpointRange = 1e3;  ///< [m] a viewpoint's max_range
constexpr double kMinAltitude = -500.0, kMaxAltitude = 9000.0;  ///< [m] the anchor's altitude
constexpr double kMaxAnchorSigma = 1e5;     ///< [m]

/** @brief How a tree map is read. */
struct ForestMapReadOptions
{
  /// More trees than this are refused at the line of the first one too many (0: no bound), so that a huge file
  /// costs neither time nor memory beyond the bound.
  std::size_t max_trees = 0;
  /// Asked every few thousand lines: true stops the reading (std::runtime_error "interrupted").
  std::function<bool()> cancelled;
};

ForestMap parseForestMap(const std::string& text, const std::string& name,
                         const ForestMapReadOptions& options = ForestMapReadOptions());
/** @brief The same from a stream, line by line (time and memory linear in the file's size, bounded by
 * options.max_trees). */
ForestMap parseForestMap(std::istream& in, const std::string& name,
                         const ForestMapReadOptions& options = ForestMapReadOptions());
/** @brief Reads and parses a tree map file, line by line. @throws std::runtime_error naming the file. */
ForestMap readForestMap(const std::string& path, const ForestMapReadOptions& options = ForestMapReadOptions());

/**
 * @brief [deg] WGS84 latitude and longitude of the map point (@p x, @p y) [m] of a valid @p anchor: the map frame
 * turned by the anchor's yaw onto east-north, then the local tangent plane at the anchor (the ellipsoid's radii of
 * curvature there; within a few millimetres over a kilometre).
 */
void toWgs84(const MapAnchor& anchor, double x, double y, double* latitude, double* longitude);

/** @brief The header of the change report CSV. */
extern const char* const kChangesHeader;
/**
 * @brief The change report as CSV: per change kind (felled, new, changed), id, centre x, y and their standard
 * deviations [m], dbh and its standard deviation before and after [m] (empty where there is none), this visit's
 * matches, first and last seen [s], and the evidence in words.
 */
std::string changesCsv(const std::vector<core::TreeChange>& changes);
/**
 * @brief A GeoJSON FeatureCollection (RFC 7946: WGS84 longitude, latitude) of the trees of @p map, one Point each
 * with id, dbh, the standard deviations, observations, provisional and the times as properties.
 * @throws std::invalid_argument when the map has no anchor (a local frame cannot be placed on the earth).
 */
std::string treesGeoJson(const ForestMap& map);
/** @brief The same for the change report (properties: kind, id, dbh before and after, evidence, ...). */
std::string changesGeoJson(const MapAnchor& anchor, const std::vector<core::TreeChange>& changes);

}  // namespace io
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_IO_FOREST_MAP_FILE_H
