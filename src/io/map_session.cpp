#include "rbpf_slam/io/map_session.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <utility>

namespace rbpf_slam
{
namespace io
{
FastSlamMapSession::FastSlamMapSession(core::TrunkSlamPipeline* pipeline, const MapStart& start,
                                       const std::function<bool()>& cancelled)
  : pipeline_(pipeline), start_(start)
{
  if (start_.map_file.empty())
    return;
  ForestMapReadOptions options;
  options.max_trees = static_cast<std::size_t>(pipeline_->filter().config().max_landmarks);
  options.cancelled = cancelled;
  saved_ = readForestMap(start_.map_file, options);
  pipeline_->setMapAnchor(saved_.anchor);
  pipeline_->setMapViewpoints(saved_.viewpoints);
  try
  {
    if (start_.search)
      pipeline_->setPriorMap(saved_.trees, core::RelocalizationConfig());
    else
      pipeline_->setPriorMap(saved_.trees, start_.start);
  }
  catch (const std::exception& e)
  {
    throw std::runtime_error(start_.map_file + ": " + e.what());
  }
}

std::string FastSlamMapSession::startDescription() const
{
  if (!fromSavedMap())
    return "a new map (its frame: the odometry frame at the first update)";
  char text[256];
  if (start_.search)
    std::snprintf(text, sizeof(text), "%zu trees, the start pose searched from the trunks seen", saved_.trees.size());
  else
    std::snprintf(text, sizeof(text), "%zu trees, base_link at (%.2f, %.2f, %.1f deg) in its frame",
                  saved_.trees.size(), start_.start.x, start_.start.y, start_.start.theta * 180.0 / M_PI);
  return "starting from " + start_.map_file + ": " + text;
}

ForestMap FastSlamMapSession::currentMap(const core::SmoothedRun* smoothed) const
{
  ForestMap map;
  map.anchor = pipeline_->anchor();
  map.viewpoints = pipeline_->viewpoints();
  if (pipeline_->initialized())
  {
    // With loop closure the map is the smoothed one (every loop closed, the path and trees smoothed together).
    const core::SmoothedRun run = smoothed ? *smoothed : pipeline_->smoothed();
    map.trees = run.ok ? run.trees : pipeline_->filter().bestTrees();
  }
  return map;
}

std::vector<core::TreeChange> FastSlamMapSession::changes(const std::vector<core::Landmark>& now) const
{
  if (!fromSavedMap())
    return {};
  return core::detectChanges(saved_.trees, now, core::ChangeConfig(), saved_.viewpoints);
}

std::vector<FileContent> FastSlamMapSession::mapFiles(const std::string& path, std::string* summary,
                                                      const core::SmoothedRun* smoothed) const
{
  const ForestMap map = currentMap(smoothed);
  const std::string stem = withoutExtension(path);
  std::vector<FileContent> files;
  files.emplace_back(path, forestMapCsv(map));
  if (map.anchor.valid)  // the inventory for GIS tools beside it
    files.emplace_back(stem + ".geojson", treesGeoJson(map));
  std::string text = std::to_string(map.trees.size()) + " trees written to " + path;
  if (fromSavedMap())
  {
    const std::vector<core::TreeChange> found = changes(map.trees);
    files.emplace_back(stem + "_changes.csv", changesCsv(found));
    if (map.anchor.valid)
      files.emplace_back(stem + "_changes.geojson", changesGeoJson(map.anchor, found));
    int n[3] = { 0, 0, 0 };
    for (const core::TreeChange& c : found)
      ++n[static_cast<int>(c.kind)];
    text += "; changes since " + start_.map_file + ": " + std::to_string(n[0]) + " felled, " + std::to_string(n[1]) +
            " new, " + std::to_string(n[2]) + " changed radii in " + stem + "_changes.csv";
  }
  if (summary)
    *summary = text;
  return files;
}

std::vector<MapFile> FastSlamMapSession::endedMapFiles(const std::string& path)
{
  std::vector<MapFile> files;
  for (core::TimelineMap& ended : pipeline_->takeEndedMaps())
  {
    ForestMap map;
    map.trees = std::move(ended.trees);
    map.viewpoints = std::move(ended.viewpoints);
    map.anchor = ended.anchor;
    MapFile f;
    f.path = withoutExtension(path) + ".restart" + std::to_string(ended.timeline + 1) + ".csv";
    f.content = forestMapCsv(map);
    f.trees = map.trees.size();
    f.restart = ended.timeline + 1;
    files.push_back(std::move(f));
  }
  return files;
}

}  // namespace io
}  // namespace rbpf_slam
