#include "rbpf_slam/io/forest_map_file.h"
#include "rbpf_slam/io/tum_file.h"

#include "rbpf_slam/io/files.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

namespace rbpf_slam
{
namespace io
{
const char* const kForestMapHeader =
    "id,x,y,dbh,sigma_x,sigma_y,sigma_dbh,observations,provisional,cov_xy,first_seen,last_seen";

namespace
{
std::string trim(const std::string& s)
{
  const std::size_t a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos)
    return "";
  const std::size_t b = s.find_last_not_of(" \t\r");
  return s.substr(a, b - a + 1);
}

std::vector<std::string> splitCommas(const std::string& line)
{
  std::vector<std::string> out;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ','))
    out.push_back(trim(field));
  if (!line.empty() && line.back() == ',')
    out.push_back("");
  return out;
}


std::string csvNumber(double v, const char* format);

[[noreturn]] void fail(const std::string& name, int line, const std::string& what)
{
  throw std::runtime_error(name + ":" + std::to_string(line) + ": " + what);
}

double number(const std::string& field, const std::string& column, const std::string& name, int line)
{
  std::size_t used = 0;
  double v = 0.0;
  try
  {
    v = std::stod(field, &used);
  }
  catch (const std::exception&)
  {
    used = 0;
  }
  if (used == 0 || used != field.size() || !std::isfinite(v))
    fail(name, line, "expected a finite number for " + column + ", got '" + field + "'");
  return v;
}

void parseAnchor(const std::string& rest, MapAnchor* anchor, const std::string& name, int line)
{
  std::istringstream in(rest);
  std::string item;
  std::set<std::string> seen;
  while (in >> item)
  {
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos)
      fail(name, line, "expected key=value in the anchor, got '" + item + "'");
    const std::string key = item.substr(0, eq);
    const double v = number(item.substr(eq + 1), "anchor " + key, name, line);
    if (key == "latitude")
      anchor->latitude = v;
    else if (key == "longitude")
      anchor->longitude = v;
    else if (key == "altitude")
      anchor->altitude = v;
    else if (key == "yaw")
      anchor->yaw = v;
    else if (key == "sigma")
      anchor->sigma = v;
    else
      fail(name, line, "expected latitude, longitude, altitude, yaw or sigma in the anchor, got '" + key + "'");
    seen.insert(key);
  }
  if (!seen.count("latitude") || !seen.count("longitude"))
    fail(name, line, "expected the anchor's latitude and longitude, got '" + trim(rest) + "'");
  if (std::abs(anchor->latitude) > 90.0 || std::abs(anchor->longitude) > 180.0)
    fail(name, line, "expected latitude in [-90, 90] and longitude in [-180, 180], got '" + trim(rest) + "'");
  if (anchor->altitude < kMinAltitude || anchor->altitude > kMaxAltitude || anchor->sigma < 0.0 ||
      anchor->sigma > kMaxAnchorSigma)
    fail(name, line, "expected altitude in [" + csvNumber(kMinAltitude, "%g") + ", " + csvNumber(kMaxAltitude, "%g") +
                         "] m and sigma in [0, " + csvNumber(kMaxAnchorSigma, "%g") + "] m, got '" + trim(rest) + "'");
  anchor->valid = true;
}

void parseViewpoint(const std::string& rest, std::vector<core::Viewpoint>* viewpoints, const std::string& name,
                    int line)
{
  static const char* const kKeys[] = { "x", "y", "yaw", "min_range", "max_range", "fov_min", "fov_max" };
  std::map<std::string, double> v;
  std::istringstream in(rest);
  std::string item;
  while (in >> item)
  {
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos)
      fail(name, line, "expected key=value in the viewpoint, got '" + item + "'");
    const std::string key = item.substr(0, eq);
    if (std::find(std::begin(kKeys), std::end(kKeys), key) == std::end(kKeys))
      fail(name, line, "expected x, y, yaw, min_range, max_range, fov_min or fov_max in the viewpoint, got '" + key +
                           "'");
    v[key] = number(item.substr(eq + 1), "viewpoint " + key, name, line);
  }
  for (const char* key : kKeys)
    if (!v.count(key))
      fail(name, line, std::string("expected the viewpoint's ") + key + ", got '" + trim(rest) + "'");
  if (v["min_range"] < 0.0 || v["max_range"] <= v["min_range"] || v["fov_max"] <= v["fov_min"] ||
      v["fov_max"] - v["fov_min"] > 2.0 * M_PI + 1e-3)
    fail(name, line, "expected 0 <= min_range < max_range and fov_min < fov_max within a turn, got '" + trim(rest) +
                         "'");
  if (std::abs(v["x"]) > kMaxMapCoordinate || std::abs(v["y"]) > kMaxMapCoordinate ||
      v["max_range"] > kMaxViewpointRange || std::abs(v["fov_min"]) > 4.0 * M_PI || std::abs(v["fov_max"]) > 4.0 * M_PI)
    fail(name, line, "expected |x|, |y| <= " + csvNumber(kMaxMapCoordinate, "%g") + " m and max_range <= " +
                         csvNumber(kMaxViewpointRange, "%g") + " m in the viewpoint, got '" + trim(rest) + "'");
  core::Viewpoint p;
  p.sensor = core::Pose2(v["x"], v["y"], v["yaw"]);
  p.scope.min_range = v["min_range"];
  p.scope.max_range = v["max_range"];
  p.scope.fov_min = v["fov_min"];
  p.scope.fov_max = v["fov_max"];
  viewpoints->push_back(p);
}
}  // namespace

std::string forestMapCsv(const ForestMap& map)
{
  std::string csv;
  char line[640];
  if (map.anchor.valid)
  {
    std::snprintf(line, sizeof(line), "# anchor: latitude=%.9f longitude=%.9f altitude=%.3f yaw=%.6f sigma=%.3f\n",
                  map.anchor.latitude, map.anchor.longitude, map.anchor.altitude, map.anchor.yaw, map.anchor.sigma);
    csv += line;
  }
  for (const core::Viewpoint& v : map.viewpoints)
  {
    std::snprintf(line, sizeof(line),
                  "# viewpoint: x=%.2f y=%.2f yaw=%.3f min_range=%.2f max_range=%.2f fov_min=%.4f fov_max=%.4f\n",
                  v.sensor.x, v.sensor.y, v.sensor.theta, v.scope.min_range, v.scope.max_range, v.scope.fov_min,
                  v.scope.fov_max);
    csv += line;
  }
  csv += std::string(kForestMapHeader) + "\n";
  for (const auto& l : map.trees)
  {
    std::snprintf(line, sizeof(line), "%d,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%d,%d,%.9f,%s,%s\n", l.id, l.mean.x(),
                  l.mean.y(), 2.0 * l.radius, std::sqrt(std::max(0.0, l.covariance(0, 0))),
                  std::sqrt(std::max(0.0, l.covariance(1, 1))), 2.0 * std::sqrt(std::max(0.0, l.radius_variance)),
                  l.observations, l.provisional ? 1 : 0, 0.5 * (l.covariance(0, 1) + l.covariance(1, 0)),
                  stampText(l.first_seen).c_str(), stampText(l.last_seen).c_str());
    csv += line;
  }
  return csv;
}

void writeForestMap(const std::string& path, const ForestMap& map)
{
  writeFileAtomic(path, forestMapCsv(map));
}

ForestMap parseForestMap(const std::string& text, const std::string& name, const ForestMapReadOptions& options)
{
  std::istringstream in(text);
  return parseForestMap(in, name, options);
}

ForestMap parseForestMap(std::istream& in, const std::string& name, const ForestMapReadOptions& options)
{
  ForestMap map;
  std::string raw;
  int n = 0;
  std::map<std::string, std::size_t> col;
  std::size_t columns = 0;
  std::set<int> ids;
  while (std::getline(in, raw))
  {
    ++n;
    if (n % 4096 == 0 && options.cancelled && options.cancelled())
      throw std::runtime_error(name + ":" + std::to_string(n) + ": interrupted");
    if (raw.find('\0') != std::string::npos)
      fail(name, n, "expected a text file (a tree map CSV), got binary data");
    const std::string line = trim(raw);
    if (line.empty())
      continue;
    if (line[0] == '#')
    {
      const std::string body = trim(line.substr(1));
      if (body.compare(0, 7, "anchor:") == 0)
        parseAnchor(body.substr(7), &map.anchor, name, n);
      else if (body.compare(0, 10, "viewpoint:") == 0)
        parseViewpoint(body.substr(10), &map.viewpoints, name, n);
      continue;
    }
    const std::vector<std::string> fields = splitCommas(line);
    if (col.empty())
    {
      for (std::size_t i = 0; i < fields.size(); ++i)
        col[fields[i]] = i;
      for (const char* c : { "id", "x", "y", "dbh" })
        if (!col.count(c))
          fail(name, n, std::string("expected a header with the columns id,x,y,dbh (") + kForestMapHeader +
                            "), got '" + line + "'");
      columns = fields.size();
      continue;
    }
    if (options.max_trees > 0 && map.trees.size() >= options.max_trees)
      fail(name, n, "more than " + std::to_string(options.max_trees) + " trees (max_landmarks): not loaded");
    if (fields.size() != columns)
      fail(name, n, "expected " + std::to_string(columns) + " fields, got " + std::to_string(fields.size()) + ": '" +
                        line + "'");
    auto value = [&](const char* c, double fallback, bool may_be_empty) {
      const auto it = col.find(c);
      if (it == col.end())
        return fallback;
      const std::string& f = fields[it->second];
      if (f.empty() && may_be_empty)
        return fallback;
      return number(f, c, name, n);
    };
    core::Landmark l;
    const double id = value("id", 0.0, false);
    if (id != std::floor(id) || id < 0 || id > 2e9)
      fail(name, n, "expected a whole id >= 0, got '" + fields[col["id"]] + "'");
    l.id = static_cast<int>(id);
    if (!ids.insert(l.id).second)
      fail(name, n, "expected a unique id, got " + std::to_string(l.id) + " a second time");
    l.mean = Eigen::Vector2d(value("x", 0.0, false), value("y", 0.0, false));
    const double dbh = value("dbh", 0.0, false);
    const double sx = value("sigma_x", 0.1, false), sy = value("sigma_y", 0.1, false);
    const double sd = value("sigma_dbh", 0.5 * dbh, false);
    if (dbh < 0.0 || sx < 0.0 || sy < 0.0 || sd < 0.0)
      fail(name, n, "expected dbh and sigmas >= 0, got '" + line + "'");
    if (std::abs(l.mean.x()) > kMaxMapCoordinate || std::abs(l.mean.y()) > kMaxMapCoordinate)
      fail(name, n, "expected |x|, |y| <= " + csvNumber(kMaxMapCoordinate, "%g") + " m (a local map frame), got '" +
                        line + "'");
    if (dbh > kMaxDbh || sd > kMaxDbh || sx > kMaxPositionSigma || sy > kMaxPositionSigma)
      fail(name, n, "expected dbh and sigma_dbh <= " + csvNumber(kMaxDbh, "%g") + " m and sigma_x, sigma_y <= " +
                        csvNumber(kMaxPositionSigma, "%g") + " m, got '" + line + "'");
    const double cxy = value("cov_xy", 0.0, true);
    if (cxy * cxy > sx * sx * sy * sy * (1.0 + 1e-6) + 1e-18)
      fail(name, n, "expected |cov_xy| <= sigma_x * sigma_y, got '" + line + "'");
    l.covariance << sx * sx, cxy, cxy, sy * sy;
    l.radius = 0.5 * dbh;
    l.radius_variance = 0.25 * sd * sd;
    const double obs = value("observations", 1.0, false);
    if (obs != std::floor(obs) || obs < 0)
      fail(name, n, "expected a whole number of observations >= 0, got '" + line + "'");
    l.observations = static_cast<int>(obs);
    const double prov = value("provisional", 0.0, false);
    if (prov != 0.0 && prov != 1.0)
      fail(name, n, "expected provisional 0 or 1, got '" + line + "'");
    l.provisional = prov != 0.0;
    l.first_seen = value("first_seen", NAN, true);
    l.last_seen = value("last_seen", NAN, true);
    if (l.first_seen < 0.0 || l.last_seen < 0.0)
      fail(name, n, "expected first_seen and last_seen >= 0 s (ROS time), got '" + line + "'");
    map.trees.push_back(l);
  }
  if (col.empty())
    fail(name, std::max(n, 1), std::string("expected the header ") + kForestMapHeader + ", got an empty file");
  return map;
}

ForestMap readForestMap(const std::string& path, const ForestMapReadOptions& options)
{
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw std::runtime_error(path + ": cannot be read");
  return parseForestMap(in, path, options);
}

namespace
{
std::string csvNumber(double v, const char* format = "%.6f")
{
  if (!std::isfinite(v))
    return "";
  char buf[64];
  std::snprintf(buf, sizeof(buf), format, v);
  return buf;
}

std::string jsonNumber(double v, const char* format = "%.6f")
{
  return std::isfinite(v) ? csvNumber(v, format) : "null";
}

std::string jsonString(const std::string& s)
{
  std::string out = "\"";
  for (char c : s)
  {
    if (c == '"' || c == '\\')
      out += '\\';
    if (static_cast<unsigned char>(c) < 0x20)
      continue;
    out += c;
  }
  return out + "\"";
}

std::string point(const MapAnchor& anchor, const Eigen::Vector2d& p)
{
  double lat = 0.0, lon = 0.0;
  toWgs84(anchor, p.x(), p.y(), &lat, &lon);
  return "{\"type\": \"Point\", \"coordinates\": [" + jsonNumber(lon, "%.9f") + ", " + jsonNumber(lat, "%.9f") + "]}";
}

std::string collection(const std::vector<std::string>& features)
{
  std::string out = "{\"type\": \"FeatureCollection\", \"features\": [\n";
  for (std::size_t i = 0; i < features.size(); ++i)
    out += "  " + features[i] + (i + 1 < features.size() ? ",\n" : "\n");
  return out + "]}\n";
}

void requireAnchor(const MapAnchor& anchor)
{
  if (!anchor.valid)
    throw std::invalid_argument("the map has no anchor on the earth (a '# anchor:' line): GeoJSON needs WGS84");
}
}  // namespace

void toWgs84(const MapAnchor& anchor, double x, double y, double* latitude, double* longitude)
{
  const core::GeoPoint g = core::anchoredToGeo(anchor, x, y);
  *latitude = g.latitude;
  *longitude = g.longitude;
}

const char* const kChangesHeader =
    "kind,id,x,y,sigma_x,sigma_y,dbh_before,sigma_dbh_before,dbh_after,sigma_dbh_after,observations,first_seen,"
    "last_seen,evidence";

std::string changesCsv(const std::vector<core::TreeChange>& changes)
{
  std::string csv = std::string(kChangesHeader) + "\n";
  for (const core::TreeChange& c : changes)
  {
    std::string evidence = c.evidence;
    for (char& ch : evidence)
      if (ch == '"')
        ch = '\'';
    csv += std::string(core::toString(c.kind)) + "," + std::to_string(c.id) + "," + csvNumber(c.center.x()) + "," +
           csvNumber(c.center.y()) + "," + csvNumber(std::sqrt(std::max(0.0, c.covariance(0, 0)))) + "," +
           csvNumber(std::sqrt(std::max(0.0, c.covariance(1, 1)))) + "," + csvNumber(c.dbh_before) + "," +
           csvNumber(c.sigma_dbh_before) + "," + csvNumber(c.dbh_after) + "," + csvNumber(c.sigma_dbh_after) + "," +
           std::to_string(c.observations) + "," + csvNumber(c.first_seen) + "," + csvNumber(c.last_seen) + ",\"" +
           evidence + "\"\n";
  }
  return csv;
}

std::string treesGeoJson(const ForestMap& map)
{
  requireAnchor(map.anchor);
  std::vector<std::string> features;
  for (const core::Landmark& l : map.trees)
    features.push_back(
        "{\"type\": \"Feature\", \"geometry\": " + point(map.anchor, l.mean) + ", \"properties\": {\"id\": " +
        std::to_string(l.id) + ", \"dbh_m\": " + jsonNumber(2.0 * l.radius) + ", \"sigma_dbh_m\": " +
        jsonNumber(2.0 * std::sqrt(std::max(0.0, l.radius_variance))) + ", \"sigma_x_m\": " +
        jsonNumber(std::sqrt(std::max(0.0, l.covariance(0, 0)))) + ", \"sigma_y_m\": " +
        jsonNumber(std::sqrt(std::max(0.0, l.covariance(1, 1)))) + ", \"observations\": " +
        std::to_string(l.observations) + ", \"provisional\": " + (l.provisional ? "true" : "false") +
        ", \"first_seen\": " + jsonNumber(l.first_seen) + ", \"last_seen\": " + jsonNumber(l.last_seen) + "}}");
  return collection(features);
}

std::string changesGeoJson(const MapAnchor& anchor, const std::vector<core::TreeChange>& changes)
{
  requireAnchor(anchor);
  std::vector<std::string> features;
  for (const core::TreeChange& c : changes)
    features.push_back("{\"type\": \"Feature\", \"geometry\": " + point(anchor, c.center) +
                       ", \"properties\": {\"kind\": " + jsonString(core::toString(c.kind)) + ", \"id\": " +
                       std::to_string(c.id) + ", \"dbh_before_m\": " + jsonNumber(c.dbh_before) +
                       ", \"dbh_after_m\": " + jsonNumber(c.dbh_after) + ", \"sigma_x_m\": " +
                       jsonNumber(std::sqrt(std::max(0.0, c.covariance(0, 0)))) + ", \"sigma_y_m\": " +
                       jsonNumber(std::sqrt(std::max(0.0, c.covariance(1, 1)))) + ", \"observations\": " +
                       std::to_string(c.observations) + ", \"last_seen\": " + jsonNumber(c.last_seen) +
                       ", \"evidence\": " + jsonString(c.evidence) + "}}");
  return collection(features);
}

}  // namespace io
}  // namespace rbpf_slam
