#include "rbpf_slam/io/trunk_detector_config.h"

#include <cstdint>
#include <stdexcept>
#include <string>

namespace rbpf_slam
{
namespace io
{
void readTrunkDetectorConfig(const ParamSource& p, core::TrunkDetectorConfig* c)
{
  std::string method = core::trunkMethodName(c->method);
  p.get("method", &method);
  if (!core::parseTrunkMethod(method, &c->method))
    throw std::runtime_error("method must be \"centroid\" or \"circle\", not \"" + method + "\"");
  p.get("ground_cell", &c->ground_cell);
  p.get("ground_max_slope", &c->ground_max_slope);
  p.get("ground_relief", &c->ground_relief);
  p.get("sensor_height", &c->sensor_height);
  p.get("min_height", &c->min_height);
  p.get("max_height", &c->max_height);
  p.get("voxel_size", &c->voxel_size);
  p.get("level_by_trunks", &c->level_by_trunks);
  p.get("cluster_tolerance", &c->cluster_tolerance);
  p.get("min_points", &c->min_points);
  p.get("scan_min_beams", &c->scan_min_beams);
  p.get("scan_min_jump", &c->scan_min_jump);
  p.get("max_points", &c->max_points);
  p.get("min_radius", &c->min_radius);
  p.get("max_radius", &c->max_radius);
  p.get("ransac_threshold", &c->ransac_threshold);
  p.get("ransac_iterations", &c->ransac_iterations);
  p.get("min_inlier_ratio", &c->min_inlier_ratio);
  p.get("min_vertical_extent", &c->min_vertical_extent);
  p.get("max_tilt", &c->max_tilt);
  p.get("column_fit", &c->column_fit);
  p.get("slice_height", &c->slice_height);
  p.get("min_slices", &c->min_slices);
  p.get("max_stem_lean", &c->max_stem_lean);
  p.get("stem_lean_sigma", &c->stem_lean_sigma);
  p.get("max_interior_share", &c->max_interior_share);
  p.get("max_see_through", &c->max_see_through);
  p.get("min_silhouette_coverage", &c->min_silhouette_coverage);
  p.get("seen_from_all_sides", &c->seen_from_all_sides);
  p.get("max_stems_per_cluster", &c->max_stems_per_cluster);
  p.get("max_arc_angle", &c->max_arc_angle);
  p.get("min_fit_points", &c->min_fit_points);
  p.get("min_fit_arc", &c->min_fit_arc);
  p.get("arc_radius_prior", &c->arc_radius_prior);
  p.get("arc_radius_sigma", &c->arc_radius_sigma);
  p.get("range_sigma", &c->range_sigma);
  p.get("range_offset", &c->range_offset);
  p.get("min_range", &c->min_range);
  p.get("max_range", &c->max_range);
  p.get("azimuth_resolution", &c->azimuth_resolution);
  p.get("sensor_reach", &c->sensor_reach);
  p.get("detection_probability", &c->detection_probability);
  p.getSeed("seed", &c->seed);
  const std::string error = c->validate();
  if (!error.empty())
    throw std::runtime_error("invalid parameter: " + error);
}

}  // namespace io
}  // namespace rbpf_slam
