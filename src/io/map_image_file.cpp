#include "rbpf_slam/io/map_image_file.h"

#include "rbpf_slam/io/files.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <locale>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <yaml-cpp/yaml.h>

namespace rbpf_slam
{
namespace io
{
namespace
{
// map_saver's values and thresholds: 205 gives p = 50 / 255 = 0.19608 > 0.196, so it reads back as unknown.
constexpr int kSavedOccupied = 0;
constexpr int kSavedFree = 254;
constexpr int kSavedUnknown = 205;
constexpr double kSavedOccupiedThresh = 0.65;
constexpr double kSavedFreeThresh = 0.196;
// A bound on image sides so that a corrupt header cannot ask for gigabytes (1 << 20 cells = 52 km at 5 cm).
constexpr long kMaxSide = 1L << 20;

std::runtime_error fileError(const std::string& path, const std::string& what)
{
  return std::runtime_error(path + ": " + what);
}

std::runtime_error lineError(const std::string& path, int line, const std::string& what)
{
  return line > 0 ? std::runtime_error(path + ":" + std::to_string(line) + ": " + what) : fileError(path, what);
}

std::string directoryOf(const std::string& path)
{
  const std::size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? std::string() : path.substr(0, slash + 1);
}

std::string fileNameOf(const std::string& path)
{
  const std::size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

/** Bytes as they may be shown in a message: printable ASCII as is, the rest as \xNN. */
std::string printable(const std::string& bytes)
{
  std::string out;
  for (const char c : bytes)
  {
    const unsigned char u = static_cast<unsigned char>(c);
    if (u >= 0x20 && u < 0x7f)
    {
      out += c;
    }
    else
    {
      char buf[8];
      std::snprintf(buf, sizeof(buf), "\\x%02X", u);
      out += buf;
    }
  }
  return out;
}

std::string readFile(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw fileError(path, std::string("cannot open file (") + std::strerror(errno) + ")");
  std::ostringstream data;
  data << in.rdbuf();
  if (in.bad())
    throw fileError(path, "read error");
  return data.str();
}

/** The shortest decimal that reads back as @p v, always with a '.' so that YAML sees a float. */
std::string formatDouble(double v)
{
  std::string text;
  for (int precision = 6; precision <= 17; ++precision)
  {
    std::ostringstream out;
    out.imbue(std::locale::classic());
    out.precision(precision);
    out << v;
    text = out.str();
    std::istringstream in(text);
    in.imbue(std::locale::classic());
    double back = 0.0;
    in >> back;
    if (back == v)
      break;
  }
  if (text.find_first_of(".eE") == std::string::npos)
    text += ".0";
  return text;
}

/** A file name as a YAML scalar: plain when it is safe, double-quoted otherwise. */
std::string yamlString(const std::string& s)
{
  bool plain = !s.empty();
  for (const char c : s)
    plain = plain && (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-');
  if (plain)
    return s;
  std::string out = "\"";
  for (const char c : s)
  {
    if (c == '"' || c == '\\')
      out += '\\';
    out += c;
  }
  return out + "\"";
}

// --- YAML -----------------------------------------------------------------------------------------------------

struct MapYaml
{
  std::string image;
  double resolution = 0.0;
  core::MapOrigin origin;
  bool negate = false;
  double occupied_thresh = 0.0;
  double free_thresh = 0.0;
};

int lineOf(const YAML::Node& node)
{
  const YAML::Mark mark = node.Mark();
  return mark.line >= 0 ? mark.line + 1 : 0;
}

YAML::Node requireKey(const YAML::Node& root, const std::string& path, const char* key)
{
  const YAML::Node node = root[key];
  if (!node.IsDefined())
    throw fileError(path, std::string("key '") + key + "' is missing");
  if (node.IsNull())
    throw lineError(path, lineOf(node), std::string("key '") + key + "' has no value");
  return node;
}

std::string scalarText(const YAML::Node& node)
{
  return node.IsScalar() ? node.Scalar() : std::string(node.IsSequence() ? "a list" : "a map");
}

double toFinite(const YAML::Node& node, const std::string& path, const std::string& what)
{
  double v = 0.0;
  if (!node.IsScalar() || !YAML::convert<double>::decode(node, v) || !std::isfinite(v))
    throw lineError(path, lineOf(node), what + " must be a finite number (got '" + scalarText(node) + "')");
  return v;
}

double readThreshold(const YAML::Node& root, const std::string& path, const char* key)
{
  const std::string what = std::string("key '") + key + "'";
  const YAML::Node node = requireKey(root, path, key);
  const double v = toFinite(node, path, what);
  if (v < 0.0 || v > 1.0)
    throw lineError(path, lineOf(node), what + " must be in [0, 1] (got " + node.Scalar() + ")");
  return v;
}

MapYaml readMapYaml(const std::string& path)
{
  YAML::Node root;
  try
  {
    root = YAML::Load(readFile(path));
  }
  catch (const YAML::Exception& e)
  {
    throw lineError(path, e.mark.line >= 0 ? e.mark.line + 1 : 0, "YAML syntax error: " + e.msg);
  }
  if (!root.IsMap())
    throw fileError(path, "not a map_server map YAML (expected a map of keys at the top level)");

  MapYaml map;
  const YAML::Node image = requireKey(root, path, "image");
  if (!image.IsScalar() || image.Scalar().empty())
    throw lineError(path, lineOf(image), "key 'image' must be a file name");
  map.image = image.Scalar();

  const YAML::Node resolution = requireKey(root, path, "resolution");
  map.resolution = toFinite(resolution, path, "key 'resolution'");
  if (map.resolution <= 0.0)
    throw lineError(path, lineOf(resolution), "key 'resolution' must be > 0 (got " + resolution.Scalar() + ")");

  const YAML::Node origin = requireKey(root, path, "origin");
  if (!origin.IsSequence() || origin.size() != 3)
    throw lineError(path, lineOf(origin), "key 'origin' must be a list [x, y, yaw]");
  map.origin.x = toFinite(origin[0], path, "key 'origin' x");
  map.origin.y = toFinite(origin[1], path, "key 'origin' y");
  map.origin.yaw = toFinite(origin[2], path, "key 'origin' yaw");

  // map_server reads negate as an int; true / false are accepted too since YAML writers produce them.
  const YAML::Node negate = requireKey(root, path, "negate");
  int negate_int = 0;
  bool negate_bool = false;
  if (negate.IsScalar() && YAML::convert<int>::decode(negate, negate_int) && (negate_int == 0 || negate_int == 1))
    map.negate = negate_int == 1;
  else if (negate.IsScalar() && YAML::convert<bool>::decode(negate, negate_bool))
    map.negate = negate_bool;
  else
    throw lineError(path, lineOf(negate), "key 'negate' must be 0 or 1 (got '" + scalarText(negate) + "')");

  map.occupied_thresh = readThreshold(root, path, "occupied_thresh");
  map.free_thresh = readThreshold(root, path, "free_thresh");

  const YAML::Node mode = root["mode"];
  if (mode.IsDefined() && !mode.IsNull())
  {
    const std::string m = mode.IsScalar() ? mode.Scalar() : std::string();
    if (m != "trinary" && m != "scale" && m != "raw")
      throw lineError(path, lineOf(mode), "key 'mode' must be trinary, scale or raw (got '" + scalarText(mode) + "')");
  }
  return map;
}

// --- Image ----------------------------------------------------------------------------------------------------

/**
 * The little OpenCV does not report about a binary PGM: maxval (OpenCV scales an ASCII PGM's pixels to 0..255
 * but returns a binary one's as stored) and whether the raster is complete (OpenCV would print its own error).
 * False when @p data is not a binary PGM with a readable header.
 */
bool binaryPgmHeader(const std::string& data, long* width, long* height, long* maxval, std::size_t* raster)
{
  if (data.compare(0, 2, "P5") != 0)
    return false;
  std::size_t pos = 2;
  long* fields[3] = { width, height, maxval };
  for (long* field : fields)
  {
    while (pos < data.size() && (std::isspace(static_cast<unsigned char>(data[pos])) || data[pos] == '#'))
      pos = data[pos] == '#' ? data.find('\n', pos) : pos + 1;
    if (pos >= data.size() || !std::isdigit(static_cast<unsigned char>(data[pos])))
      return false;
    *field = 0;
    for (; pos < data.size() && std::isdigit(static_cast<unsigned char>(data[pos])) && *field < kMaxSide; ++pos)
      *field = *field * 10 + (data[pos] - '0');
  }
  *raster = pos + 1;  // one whitespace byte after maxval
  return true;
}

/** The image at @p path on map_server's 0..255 scale (8-bit, 1 to 4 channels; a binary PGM's maxval applied). */
cv::Mat readImage(const std::string& path)
{
  const std::string data = readFile(path);
  long width = 0, height = 0, maxval = 255;
  std::size_t raster = 0;
  const bool pgm = binaryPgmHeader(data, &width, &height, &maxval, &raster);
  if (pgm && (width < 1 || width >= kMaxSide || height < 1 || height >= kMaxSide))
    throw fileError(path, "image size " + std::to_string(width) + " x " + std::to_string(height) +
                              " out of range 1.." + std::to_string(kMaxSide - 1));
  if (pgm && (maxval < 1 || maxval > 255))
    throw fileError(path, "maxval " + std::to_string(maxval) + " not supported (must be 1..255)");
  const std::size_t count = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (pgm && (raster > data.size() || data.size() - raster < count))
    throw fileError(path, "truncated: expected " + std::to_string(count) + " pixel bytes, got " +
                              std::to_string(raster > data.size() ? 0 : data.size() - raster));

  cv::Mat image;
  try
  {
    const cv::Mat bytes(1, static_cast<int>(data.size()), CV_8UC1, const_cast<char*>(data.data()));
    image = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  }
  catch (const cv::Exception& e)
  {
    throw fileError(path, "cannot decode the image (" + e.err + ")");
  }
  if (image.empty())
    throw fileError(path, "not an image OpenCV can read, e.g. PGM or PNG (starts with '" +
                              printable(data.substr(0, 4)) + "')");
  if (image.depth() != CV_8U)
    throw fileError(path, "16-bit images are not supported (map_server reads 8-bit ones)");
  if (pgm && maxval < 255)
    image.convertTo(image, CV_8U, 255.0 / static_cast<double>(maxval));  // as map_server's loader scales it
  return image;
}

}  // namespace

core::OccupancyImage loadMapImage(const std::string& yaml_path)
{
  const MapYaml yaml = readMapYaml(yaml_path);
  const std::string image_path = yaml.image[0] == '/' ? yaml.image : directoryOf(yaml_path) + yaml.image;
  const cv::Mat image = readImage(image_path);

  // map_server's trinary mode: the mean of the colour channels (alpha ignored), p = (255 - mean) / 255 (mean / 255
  // with negate), in double so that the thresholds cut at exactly the same values.
  const int colours = image.channels() >= 3 ? 3 : 1;
  const int w = image.cols, h = image.rows;
  std::vector<std::int8_t> cells(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
  for (int row = 0; row < h; ++row)
  {
    const std::uint8_t* src = image.ptr<std::uint8_t>(h - 1 - row);  // the image's top row is the grid's last
    std::int8_t* dst = cells.data() + static_cast<std::size_t>(row) * static_cast<std::size_t>(w);
    for (int col = 0; col < w; ++col, src += image.channels())
    {
      double sum = 0.0;
      for (int c = 0; c < colours; ++c)
        sum += src[c];
      const double mean = sum / colours;
      const double p = yaml.negate ? mean / 255.0 : (255.0 - mean) / 255.0;
      dst[col] = p > yaml.occupied_thresh ? core::OccupancyImage::kOccupied :
                 p < yaml.free_thresh     ? core::OccupancyImage::kFree :
                                            core::OccupancyImage::kUnknown;
    }
  }
  return core::OccupancyImage(w, h, yaml.resolution, yaml.origin, std::move(cells));
}

std::vector<FileContent> encodeMapImage(const core::OccupancyImage& map, const std::string& yaml_path,
                                        MapImageFormat format)
{
  if (map.empty())
    throw fileError(yaml_path, "cannot save an empty map");
  const std::string yaml_name = fileNameOf(yaml_path);
  const std::size_t dot = yaml_name.find_last_of('.');
  const std::string base = dot == std::string::npos || dot == 0 ? yaml_name : yaml_name.substr(0, dot);
  if (base.empty())
    throw fileError(yaml_path, "not a file name");
  const std::string extension = format == MapImageFormat::kPng ? ".png" : ".pgm";
  const std::string image_name = base + extension;
  const std::string image_path = directoryOf(yaml_path) + image_name;
  if (image_path == yaml_path)
    throw fileError(yaml_path, "the YAML file must not be named " + extension + " (the image takes that name)");

  cv::Mat image(map.height(), map.width(), CV_8UC1);
  for (int row = 0; row < map.height(); ++row)
  {
    std::uint8_t* dst = image.ptr<std::uint8_t>(map.height() - 1 - row);  // top row first
    for (int col = 0; col < map.width(); ++col)
    {
      const std::int8_t v = map.cell(col, row);
      dst[col] = static_cast<std::uint8_t>(v == core::OccupancyImage::kOccupied ? kSavedOccupied :
                                           v == core::OccupancyImage::kFree     ? kSavedFree :
                                                                                  kSavedUnknown);
    }
  }
  std::vector<std::uint8_t> encoded;
  try
  {
    const std::vector<int> binary_pgm = { cv::IMWRITE_PXM_BINARY, 1 };
    if (!cv::imencode(extension, image, encoded, format == MapImageFormat::kPng ? std::vector<int>() : binary_pgm))
      throw fileError(image_path, "OpenCV cannot encode the image");
  }
  catch (const cv::Exception& e)
  {
    throw fileError(image_path, "cannot encode the image (" + e.err + ")");
  }

  const core::MapOrigin& o = map.origin();
  std::string yaml = "image: " + yamlString(image_name) + "\n";
  yaml += "resolution: " + formatDouble(map.resolution()) + "\n";
  yaml += "origin: [" + formatDouble(o.x) + ", " + formatDouble(o.y) + ", " + formatDouble(o.yaw) + "]\n";
  yaml += "negate: 0\n";
  yaml += "occupied_thresh: " + formatDouble(kSavedOccupiedThresh) + "\n";
  yaml += "free_thresh: " + formatDouble(kSavedFreeThresh) + "\n";

  // The image first: a YAML on disk always names an image that is complete.
  return { { image_path, std::string(encoded.begin(), encoded.end()) }, { yaml_path, yaml } };
}

void saveMapImage(const core::OccupancyImage& map, const std::string& yaml_path, MapImageFormat format)
{
  writeFilesAtomic(encodeMapImage(map, yaml_path, format));
}

}  // namespace io
}  // namespace rbpf_slam
