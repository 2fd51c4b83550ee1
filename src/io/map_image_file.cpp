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

// --- PGM ------------------------------------------------------------------------------------------------------

struct Pgm
{
  int width = 0;
  int height = 0;
  int maxval = 0;
  std::vector<int> pixels;  ///< row-major, top row first, as in the file
};

/** Reads the whitespace-separated decimal tokens of a PGM, skipping '#' comments, tracking the line. */
class PgmScanner
{
public:
  PgmScanner(const std::string& path, const std::string& data, std::size_t pos) : path_(path), data_(data), pos_(pos)
  {
  }

  /** False at the end of the data. */
  bool skipSpace()
  {
    while (pos_ < data_.size())
    {
      const char c = data_[pos_];
      if (c == '#')
      {
        while (pos_ < data_.size() && data_[pos_] != '\n')
          ++pos_;
      }
      else if (std::isspace(static_cast<unsigned char>(c)))
      {
        if (c == '\n')
          ++line_;
        ++pos_;
      }
      else
      {
        return true;
      }
    }
    return false;
  }

  /** A non-negative decimal; @p what names it in messages. Throws "truncated" at the end of the data. */
  long readNumber(const std::string& what)
  {
    if (!skipSpace())
      throw fileError(path_, "truncated: file ends before the " + what);
    const std::size_t start = pos_;
    long value = 0;
    while (pos_ < data_.size() && std::isdigit(static_cast<unsigned char>(data_[pos_])))
    {
      value = value * 10 + (data_[pos_] - '0');
      if (value > 0x7fffffffL)
        throw lineError(path_, line_, what + " is too large");
      ++pos_;
    }
    const bool ends_token = pos_ >= data_.size() || std::isspace(static_cast<unsigned char>(data_[pos_])) ||
                            data_[pos_] == '#';
    if (pos_ == start || !ends_token)
    {
      std::size_t end = start;
      while (end < data_.size() && end - start < 16 && !std::isspace(static_cast<unsigned char>(data_[end])))
        ++end;
      throw lineError(path_, line_,
                      "expected a number for the " + what + ", got '" + printable(data_.substr(start, end - start)) + "'");
    }
    return value;
  }

  std::size_t pos() const { return pos_; }
  void setPos(std::size_t pos) { pos_ = pos; }
  int line() const { return line_; }

private:
  const std::string& path_;
  const std::string& data_;
  std::size_t pos_;
  int line_ = 1;
};

Pgm readPgm(const std::string& path)
{
  const std::string data = readFile(path);
  const std::string magic = data.substr(0, 2);
  if (magic != "P5" && magic != "P2")
    throw fileError(path, "not a PGM file (magic '" + printable(magic) + "')");
  const bool binary = magic == "P5";

  PgmScanner scan(path, data, 2);
  if (data.size() > 2 && !std::isspace(static_cast<unsigned char>(data[2])) && data[2] != '#')
    throw fileError(path, "not a PGM file (magic '" + printable(data.substr(0, 3)) + "')");
  const long width = scan.readNumber("width");
  const long height = scan.readNumber("height");
  if (width < 1 || width > kMaxSide || height < 1 || height > kMaxSide)
    throw lineError(path, scan.line(),
                    "image size " + std::to_string(width) + " x " + std::to_string(height) + " out of range 1.." +
                        std::to_string(kMaxSide));
  const long maxval = scan.readNumber("maxval");
  if (maxval < 1 || maxval > 255)
    throw lineError(path, scan.line(), "maxval " + std::to_string(maxval) + " not supported (must be 1..255)");

  Pgm pgm;
  pgm.width = static_cast<int>(width);
  pgm.height = static_cast<int>(height);
  pgm.maxval = static_cast<int>(maxval);
  const std::size_t count = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);

  if (binary)
  {
    // Exactly one whitespace byte separates maxval from the raster; the raster may begin with any byte value.
    std::size_t start = scan.pos();
    if (start >= data.size())
      throw fileError(path, "truncated: expected " + std::to_string(count) + " pixel bytes, got 0");
    if (!std::isspace(static_cast<unsigned char>(data[start])))
      throw lineError(path, scan.line(), "expected a whitespace byte between maxval and the pixels");
    ++start;
    const std::size_t available = data.size() - start;
    if (available < count)
      throw fileError(path, "truncated: expected " + std::to_string(count) + " pixel bytes, got " +
                                std::to_string(available));
    pgm.pixels.resize(count);
    for (std::size_t i = 0; i < count; ++i)
      pgm.pixels[i] = static_cast<unsigned char>(data[start + i]);
  }
  else
  {
    pgm.pixels.reserve(count);
    for (std::size_t i = 0; i < count; ++i)
    {
      if (!scan.skipSpace())
        throw fileError(path, "truncated: expected " + std::to_string(count) + " pixel values, got " +
                                  std::to_string(i));
      pgm.pixels.push_back(static_cast<int>(scan.readNumber("pixel value")));
    }
  }
  for (std::size_t i = 0; i < count; ++i)
  {
    if (pgm.pixels[i] > pgm.maxval)
      throw fileError(path, "pixel " + std::to_string(i % width) + ", " + std::to_string(i / width) + " has value " +
                                std::to_string(pgm.pixels[i]) + " > maxval " + std::to_string(pgm.maxval));
  }
  return pgm;
}

}  // namespace

core::OccupancyImage loadMapImage(const std::string& yaml_path)
{
  const MapYaml yaml = readMapYaml(yaml_path);
  const std::string image_path = yaml.image[0] == '/' ? yaml.image : directoryOf(yaml_path) + yaml.image;
  const Pgm pgm = readPgm(image_path);

  // The same expressions as map_server, in double, so that the thresholds cut at exactly the same values.
  std::vector<std::int8_t> lookup(static_cast<std::size_t>(pgm.maxval) + 1);
  for (int v = 0; v <= pgm.maxval; ++v)
  {
    const double p = yaml.negate ? static_cast<double>(v) / pgm.maxval : (pgm.maxval - v) / static_cast<double>(pgm.maxval);
    lookup[v] = p > yaml.occupied_thresh ? core::OccupancyImage::kOccupied :
                p < yaml.free_thresh     ? core::OccupancyImage::kFree :
                                           core::OccupancyImage::kUnknown;
  }

  std::vector<std::int8_t> cells(pgm.pixels.size());
  const std::size_t w = static_cast<std::size_t>(pgm.width);
  for (int row = 0; row < pgm.height; ++row)
  {
    const std::size_t src = static_cast<std::size_t>(pgm.height - 1 - row) * w;  // the image's top row is last
    const std::size_t dst = static_cast<std::size_t>(row) * w;
    for (std::size_t col = 0; col < w; ++col)
      cells[dst + col] = lookup[pgm.pixels[src + col]];
  }
  return core::OccupancyImage(pgm.width, pgm.height, yaml.resolution, yaml.origin, std::move(cells));
}

std::vector<FileContent> encodeMapImage(const core::OccupancyImage& map, const std::string& yaml_path)
{
  if (map.empty())
    throw fileError(yaml_path, "cannot save an empty map");
  const std::string yaml_name = fileNameOf(yaml_path);
  const std::size_t dot = yaml_name.find_last_of('.');
  const std::string base = dot == std::string::npos || dot == 0 ? yaml_name : yaml_name.substr(0, dot);
  if (base.empty())
    throw fileError(yaml_path, "not a file name");
  const std::string image_name = base + ".pgm";
  const std::string image_path = directoryOf(yaml_path) + image_name;
  if (image_path == yaml_path)
    throw fileError(yaml_path, "the YAML file must not be named .pgm (the image takes that name)");

  std::ostringstream header;
  header.imbue(std::locale::classic());
  header << "P5\n# CREATOR: rbpf_slam saveMapImage " << formatDouble(map.resolution()) << " m/pix\n"
         << map.width() << ' ' << map.height() << "\n255\n";
  std::string pgm = header.str();
  const std::size_t raster = pgm.size();
  pgm.resize(raster + static_cast<std::size_t>(map.width()) * static_cast<std::size_t>(map.height()));
  std::size_t i = raster;
  for (int row = map.height() - 1; row >= 0; --row)
  {
    for (int col = 0; col < map.width(); ++col)
    {
      const std::int8_t v = map.cell(col, row);
      const int pixel = v == core::OccupancyImage::kOccupied ? kSavedOccupied :
                        v == core::OccupancyImage::kFree     ? kSavedFree :
                                                               kSavedUnknown;
      pgm[i++] = static_cast<char>(pixel);
    }
  }

  const core::MapOrigin& o = map.origin();
  std::string yaml = "image: " + yamlString(image_name) + "\n";
  yaml += "resolution: " + formatDouble(map.resolution()) + "\n";
  yaml += "origin: [" + formatDouble(o.x) + ", " + formatDouble(o.y) + ", " + formatDouble(o.yaw) + "]\n";
  yaml += "negate: 0\n";
  yaml += "occupied_thresh: " + formatDouble(kSavedOccupiedThresh) + "\n";
  yaml += "free_thresh: " + formatDouble(kSavedFreeThresh) + "\n";

  // The image first: a YAML on disk always names an image that is complete.
  return { { image_path, pgm }, { yaml_path, yaml } };
}

void saveMapImage(const core::OccupancyImage& map, const std::string& yaml_path)
{
  writeFilesAtomic(encodeMapImage(map, yaml_path));
}

std::string endedMapPath(const std::string& yaml_path, int timeline)
{
  return withoutExtension(yaml_path) + ".restart" + std::to_string(timeline + 1) + ".yaml";
}

}  // namespace io
}  // namespace rbpf_slam
