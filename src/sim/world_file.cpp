#include "rbpf_slam/sim/world_file.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <locale>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <utility>

#include <yaml-cpp/yaml.h>

#include "rbpf_slam/sim/waypoints_file.h"

namespace rbpf_slam
{
namespace sim
{
namespace
{
constexpr double kPi = 3.14159265358979323846;
constexpr double kDefaultBoundsMargin = 2.0;  // [m] around the trunk centres when no bounds are given
const char* const kTreeLineFormat = "expected 'x y radius [height]'";

// Numbers are parsed here with the classic locale rather than with strtod or yaml-cpp's conversions:
// strtod follows the process locale (a decimal comma breaks it) and yaml-cpp's conversions differ
// between versions (0.6 reads "-1" as a huge unsigned seed).
bool parseDouble(const std::string& text, double* value)
{
  std::istringstream in(text);
  in.imbue(std::locale::classic());
  double v = 0.0;
  in >> v;
  if (in.fail())
    return false;
  in >> std::ws;
  if (!in.eof() || !std::isfinite(v))
    return false;
  *value = v;
  return true;
}

bool parseInteger(const std::string& text, long long* value)
{
  std::istringstream in(text);
  in.imbue(std::locale::classic());
  long long v = 0;
  in >> v;
  if (in.fail())
    return false;
  in >> std::ws;
  if (!in.eof())
    return false;
  *value = v;
  return true;
}

bool parseSeed(const std::string& text, std::uint64_t* value)
{
  if (text.empty() || !std::isdigit(static_cast<unsigned char>(text[0])))
    return false;
  std::istringstream in(text);
  in.imbue(std::locale::classic());
  unsigned long long v = 0;
  in >> v;
  if (in.fail())
    return false;
  in >> std::ws;
  if (!in.eof())
    return false;
  *value = static_cast<std::uint64_t>(v);
  return true;
}

std::string trimRight(const std::string& text)
{
  std::string::size_type end = text.size();
  while (end > 0 && std::isspace(static_cast<unsigned char>(text[end - 1])))
    --end;
  return text.substr(0, end);
}

bool endsWithNoCase(const std::string& text, const std::string& suffix)
{
  if (text.size() < suffix.size())
    return false;
  for (std::string::size_type i = 0; i < suffix.size(); ++i)
  {
    const char c = text[text.size() - suffix.size() + i];
    if (std::tolower(static_cast<unsigned char>(c)) != suffix[i])
      return false;
  }
  return true;
}

/** A trunk from a tree list, and whether its line gave a height (else the world's default applies). */
struct TreeRow
{
  sim::TrunkSpec trunk;
  bool has_height = false;
};

/** Checks the numbers of one tree; returns an empty string or the reason why they are no tree. */
std::string checkTree(const std::vector<double>& values)
{
  if (values.size() < 3)
    return "too few numbers";
  if (values.size() > 4)
    return "too many numbers";
  if (values[2] <= 0.0)
    return "radius must be > 0";
  if (values.size() == 4 && values[3] <= 0.0)
    return "height must be > 0";
  return std::string();
}

TreeRow makeTree(const std::vector<double>& values)
{
  TreeRow row;
  row.trunk.x = values[0];
  row.trunk.y = values[1];
  row.trunk.radius = values[2];
  if (values.size() == 4)
  {
    row.trunk.height = values[3];
    row.has_height = true;
  }
  return row;
}


/** The number rows of a plain-text list ('#' comments, blank lines skipped); @p check gives why a row is wrong. */
template <typename Check>
std::vector<std::vector<double>> readNumberRows(const std::string& path, const char* what, const char* format,
                                                Check check)
{
  std::ifstream in(path);
  if (!in)
    throw std::runtime_error(path + ": cannot open " + what);
  std::vector<std::vector<double>> rows;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line))
  {
    ++line_number;
    if (!line.empty() && line.back() == '\r')
      line.pop_back();
    if (line_number == 1 && line.compare(0, 3, "\xEF\xBB\xBF") == 0)
      line.erase(0, 3);
    std::istringstream fields(line.substr(0, line.find('#')));
    std::vector<double> values;
    std::string token;
    std::string reason;
    while (fields >> token && reason.empty())
    {
      double value = 0.0;
      if (parseDouble(token, &value))
        values.push_back(value);
      else
        reason = "'" + token + "' is not a finite number";
    }
    if (values.empty() && reason.empty())
      continue;
    if (reason.empty())
      reason = check(values);
    if (!reason.empty())
      throw std::runtime_error(path + ":" + std::to_string(line_number) + ": " + format + ", got '" +
                               trimRight(line) + "' (" + reason + ")");
    rows.push_back(values);
  }
  if (in.bad())
    throw std::runtime_error(path + ": read error in " + what);
  return rows;
}

std::vector<TreeRow> readTreeRows(const std::string& path)
{
  std::vector<TreeRow> rows;
  for (const std::vector<double>& values : readNumberRows(path, "tree list", kTreeLineFormat, checkTree))
    rows.push_back(makeTree(values));
  return rows;
}

// --- Box lists -----------------------------------------------------------------------------------

const char* const kBoxLineFormat = "expected 'x y yaw_deg [length width height]'";

/** Checks the numbers of one box; returns an empty string or the reason why they are no box. */
std::string checkBox(const std::vector<double>& values)
{
  if (values.size() < 3)
    return "too few numbers";
  if (values.size() != 3 && values.size() != 6)
    return values.size() > 6 ? "too many numbers" : "give all of length, width and height or none";
  if (values.size() == 6 && (values[3] <= 0.0 || values[4] <= 0.0 || values[5] <= 0.0))
    return "length, width and height must be > 0";
  return std::string();
}

sim::BoxSpec makeBox(const std::vector<double>& values)
{
  sim::BoxSpec box;
  box.x = values[0];
  box.y = values[1];
  box.yaw = values[2] * kPi / 180.0;
  if (values.size() == 6)
  {
    box.length = values[3];
    box.width = values[4];
    box.height = values[5];
  }
  return box;
}

// --- YAML world files -----------------------------------------------------------------------------

/** Reads the nodes of one YAML world file, every message naming the file and, where known, the line. */
class YamlReader
{
public:
  explicit YamlReader(std::string path) : path_(std::move(path)) {}

  const std::string& path() const { return path_; }

  [[noreturn]] void fail(const YAML::Node& node, const std::string& message) const
  {
    throw std::runtime_error(where(node) + ": " + message);
  }

  [[noreturn]] void fail(const std::string& message) const { throw std::runtime_error(path_ + ": " + message); }

  /**
   * The entries of the map @p node (a null node is an empty map), each key checked against @p allowed:
   * an unknown key (a typo) or a key given twice is an error rather than silently ignored.
   */
  std::vector<std::pair<std::string, YAML::Node>> entries(const YAML::Node& node, const std::string& name,
                                                          const std::vector<std::string>& allowed) const
  {
    std::vector<std::pair<std::string, YAML::Node>> result;
    if (node.IsNull())
      return result;
    if (!node.IsMap())
      fail(node, "'" + name + "' must be a map, got " + describe(node));
    std::set<std::string> seen;
    for (YAML::const_iterator it = node.begin(); it != node.end(); ++it)
    {
      const YAML::Node key_node = it->first;
      if (!key_node.IsScalar())
        fail(key_node, "a key of '" + name + "' is not a name, got " + describe(key_node));
      const std::string key = key_node.Scalar();
      const std::string full = qualified(name, key);
      if (std::find(allowed.begin(), allowed.end(), key) == allowed.end())
      {
        std::string list;
        for (const std::string& a : allowed)
          list += (list.empty() ? "" : ", ") + a;
        fail(key_node, "unknown key '" + full + "' (expected one of: " + list + ")");
      }
      if (!seen.insert(key).second)
        fail(key_node, "key '" + full + "' given twice");
      result.emplace_back(key, it->second);
    }
    return result;
  }

  double number(const YAML::Node& node, const std::string& key) const
  {
    double value = 0.0;
    if (!node.IsScalar() || !parseDouble(node.Scalar(), &value))
      fail(node, "'" + key + "' must be a finite number, got " + describe(node));
    return value;
  }

  double numberAtLeast(const YAML::Node& node, const std::string& key, double min, bool inclusive) const
  {
    const double value = number(node, key);
    if (inclusive ? value < min : value <= min)
    {
      std::ostringstream text;
      text.imbue(std::locale::classic());
      text << "'" << key << "' must be " << (inclusive ? ">= " : "> ") << min << ", got " << node.Scalar();
      fail(node, text.str());
    }
    return value;
  }

  int count(const YAML::Node& node, const std::string& key) const
  {
    long long value = 0;
    if (!node.IsScalar() || !parseInteger(node.Scalar(), &value))
      fail(node, "'" + key + "' must be an integer, got " + describe(node));
    if (value < 0 || value > 1000000)
      fail(node, "'" + key + "' must be an integer in [0, 1000000], got " + node.Scalar());
    return static_cast<int>(value);
  }

  std::uint64_t seed(const YAML::Node& node, const std::string& key) const
  {
    std::uint64_t value = 0;
    if (!node.IsScalar() || !parseSeed(node.Scalar(), &value))
      fail(node, "'" + key + "' must be an integer >= 0, got " + describe(node));
    return value;
  }

  bool boolean(const YAML::Node& node, const std::string& key) const
  {
    static const std::set<std::string> kTrue = { "true", "True", "TRUE", "yes", "Yes", "YES", "on", "On", "ON" };
    static const std::set<std::string> kFalse = { "false", "False", "FALSE", "no", "No", "NO", "off", "Off", "OFF" };
    if (node.IsScalar() && kTrue.count(node.Scalar()))
      return true;
    if (node.IsScalar() && kFalse.count(node.Scalar()))
      return false;
    fail(node, "'" + key + "' must be true or false, got " + describe(node));
  }

  /** A list of numbers of one of the given lengths. */
  std::vector<double> numbers(const YAML::Node& node, const std::string& key, std::size_t min_size,
                              std::size_t max_size, const std::string& form) const
  {
    if (!node.IsSequence() || node.size() < min_size || node.size() > max_size)
      fail(node, "'" + key + "' must be " + form + ", got " + describe(node));
    std::vector<double> values;
    for (std::size_t i = 0; i < node.size(); ++i)
    {
      double value = 0.0;
      if (!node[i].IsScalar() || !parseDouble(node[i].Scalar(), &value))
        fail(node[i], "'" + key + "' must be " + form + " of finite numbers, got " + describe(node[i]));
      values.push_back(value);
    }
    return values;
  }

  /**
   * An interval to draw from: a number (lo = hi) or [lo, hi] with lo <= hi, lo >= @p min (> @p min unless
   * @p inclusive) and hi <= @p max.
   */
  sim::Interval interval(const YAML::Node& node, const std::string& key, double min, bool inclusive,
                         double max = std::numeric_limits<double>::infinity()) const
  {
    sim::Interval v;
    if (node.IsScalar())
      v.lo = v.hi = number(node, key);
    else
    {
      const std::vector<double> values = numbers(node, key, 2, 2, "a number or [lo, hi]");
      v.lo = values[0];
      v.hi = values[1];
    }
    std::ostringstream text;
    text.imbue(std::locale::classic());
    if (v.lo > v.hi)
      text << "'" << key << "' [lo, hi] must have lo <= hi";
    else if (inclusive ? v.lo < min : v.lo <= min)
      text << "'" << key << "' must be " << (inclusive ? ">= " : "> ") << min;
    else if (v.hi > max)
      text << "'" << key << "' must be <= " << max;
    if (!text.str().empty())
      fail(node, text.str());
    return v;
  }

  /** A share within [0, 1]. */
  double share(const YAML::Node& node, const std::string& key) const
  {
    const double value = numberAtLeast(node, key, 0.0, true);
    if (value > 1.0)
      fail(node, "'" + key + "' must be within [0, 1], got " + node.Scalar());
    return value;
  }

  static std::string qualified(const std::string& parent, const std::string& key)
  {
    return parent.empty() ? key : parent + "." + key;
  }

private:
  std::string where(const YAML::Node& node) const
  {
    const YAML::Mark mark = node.Mark();
    return mark.line >= 0 ? path_ + ":" + std::to_string(mark.line + 1) : path_;
  }

  static std::string describe(const YAML::Node& node)
  {
    switch (node.Type())
    {
      case YAML::NodeType::Scalar:
        return "'" + node.Scalar() + "'";
      case YAML::NodeType::Sequence:
        return "a list of " + std::to_string(node.size());
      case YAML::NodeType::Map:
        return "a map";
      case YAML::NodeType::Null:
        return "nothing";
      default:
        return "an undefined value";
    }
  }

  std::string path_;
};

std::string folderOf(const std::string& path)
{
  const std::string::size_type slash = path.rfind('/');
  if (slash == std::string::npos)
    return std::string();
  return path.substr(0, slash + 1);
}

struct TreeDefaults
{
  double height = 15.0;
  double lean_sigma_deg = 0.0;
  double taper = 0.0;
  std::uint64_t seed = 1;
  bool has_lean_sigma = false;
  bool has_lean_range = false;  ///< lean_deg given: the lean's size uniform in it, its direction uniform
  sim::Interval lean_deg;
  bool has_taper_range = false;  ///< taper given as [lo, hi]: drawn per trunk
  sim::Interval taper_range;
  bool at_breast_height = false;  ///< listed_at: breast_height
  double listed_taper = 0.0;
};

std::vector<TreeRow> readTrees(const YamlReader& reader, const YAML::Node& node)
{
  if (node.IsScalar())
  {
    const std::string& file = node.Scalar();
    if (file.empty())
      reader.fail(node, "'trees' must name a tree list file or be a list of trees");
    return readTreeRows(file[0] == '/' ? file : folderOf(reader.path()) + file);
  }
  if (!node.IsSequence())
    reader.fail(node, "'trees' must name a tree list file or be a list of [x, y, radius] / [x, y, radius, height]");
  std::vector<TreeRow> rows;
  for (std::size_t i = 0; i < node.size(); ++i)
  {
    const std::string key = "trees[" + std::to_string(i) + "]";
    const std::vector<double> values = reader.numbers(node[i], key, 3, 4, "[x, y, radius] or [x, y, radius, height]");
    const std::string reason = checkTree(values);
    if (!reason.empty())
      reader.fail(node[i], "'" + key + "': " + reason);
    rows.push_back(makeTree(values));
  }
  return rows;
}

std::vector<sim::BoxSpec> readBoxes(const YamlReader& reader, const YAML::Node& node)
{
  if (node.IsScalar())
  {
    const std::string& file = node.Scalar();
    if (file.empty())
      reader.fail(node, "'boxes' must name a box list file or be a list of boxes");
    return loadBoxList(file[0] == '/' ? file : folderOf(reader.path()) + file);
  }
  if (!node.IsSequence())
    reader.fail(node, "'boxes' must name a box list file or be a list of [x, y, yaw_deg] / "
                      "[x, y, yaw_deg, length, width, height]");
  std::vector<sim::BoxSpec> boxes;
  for (std::size_t i = 0; i < node.size(); ++i)
  {
    const std::string key = "boxes[" + std::to_string(i) + "]";
    const std::vector<double> values =
        reader.numbers(node[i], key, 3, 6, "[x, y, yaw_deg] or [x, y, yaw_deg, length, width, height]");
    const std::string reason = checkBox(values);
    if (!reason.empty())
      reader.fail(node[i], "'" + key + "': " + reason);
    boxes.push_back(makeBox(values));
  }
  return boxes;
}

TreeDefaults readTreeDefaults(const YamlReader& reader, const YAML::Node& node)
{
  TreeDefaults d;
  const std::vector<std::string> keys = { "height", "lean_sigma_deg", "lean_deg", "taper", "listed_at",
                                          "listed_taper", "seed" };
  YAML::Node lean_range_node;
  for (const auto& entry : reader.entries(node, "tree", keys))
  {
    const std::string key = YamlReader::qualified("tree", entry.first);
    if (entry.first == "height")
      d.height = reader.numberAtLeast(entry.second, key, 0.0, false);
    else if (entry.first == "lean_sigma_deg")
    {
      d.lean_sigma_deg = reader.numberAtLeast(entry.second, key, 0.0, true);
      d.has_lean_sigma = true;
      if (d.lean_sigma_deg >= 45.0)  // tan() grows without bound; no standing tree leans that much
        reader.fail(entry.second, "'" + key + "' must be < 45, got " + entry.second.Scalar());
    }
    else if (entry.first == "lean_deg")
    {
      d.lean_deg = reader.interval(entry.second, key, 0.0, true, 44.9);
      d.has_lean_range = true;
      lean_range_node = entry.second;
    }
    else if (entry.first == "taper" && entry.second.IsSequence())
    {
      d.taper_range = reader.interval(entry.second, key, 0.0, true);
      d.has_taper_range = true;
    }
    else if (entry.first == "taper")
      d.taper = reader.numberAtLeast(entry.second, key, 0.0, true);
    else if (entry.first == "listed_at")
    {
      const std::string at = entry.second.IsScalar() ? entry.second.Scalar() : std::string();
      if (at != "ground" && at != "breast_height")
        reader.fail(entry.second, "'" + key + "' must be ground or breast_height");
      d.at_breast_height = at == "breast_height";
    }
    else if (entry.first == "listed_taper")
      d.listed_taper = reader.numberAtLeast(entry.second, key, 0.0, true);
    else
      d.seed = reader.seed(entry.second, key);
  }
  if (d.has_lean_sigma && d.has_lean_range)
    reader.fail(lean_range_node, "give 'tree.lean_sigma_deg' or 'tree.lean_deg', not both");
  return d;
}

/**
 * The trunks of the tree list with the world's tree shape: height, lean and taper drawn as the tree defaults say
 * (tree.seed), and where the list gives the stems at breast height, the foot and the ground radius that put each
 * stem's centre and radius at 1.3 m where the list says.
 */
std::vector<sim::TrunkSpec> makeTrunks(const YamlReader& reader, const std::vector<TreeRow>& rows,
                                       const TreeDefaults& tree)
{
  constexpr double kBreastHeight = 1.3;
  core::Random random(tree.seed);
  const double lean_sigma = std::tan(tree.lean_sigma_deg * kPi / 180.0);
  std::vector<sim::TrunkSpec> trunks;
  for (std::size_t i = 0; i < rows.size(); ++i)
  {
    sim::TrunkSpec trunk = rows[i].trunk;
    if (!rows[i].has_height)
      trunk.height = tree.height;
    if (tree.has_lean_range)
    {
      const double lean = std::tan(random.uniform(tree.lean_deg.lo, tree.lean_deg.hi) * kPi / 180.0);
      const double direction = random.uniform(0.0, 2.0 * kPi);
      trunk.lean_x = lean * std::cos(direction);
      trunk.lean_y = lean * std::sin(direction);
    }
    else
    {
      trunk.lean_x = random.gaussian(lean_sigma);
      trunk.lean_y = random.gaussian(lean_sigma);
    }
    const double axis_norm = std::sqrt(1.0 + trunk.lean_x * trunk.lean_x + trunk.lean_y * trunk.lean_y);
    // The radius the taper starts from: at breast height (1.3 m up, 1.3 * axis_norm along the axis) or at the ground.
    const double r_listed = tree.at_breast_height ? trunk.radius - kBreastHeight * tree.listed_taper : trunk.radius;
    const double s_listed = tree.at_breast_height ? kBreastHeight * axis_norm : 0.0;
    if (!(r_listed > 0.0))
      reader.fail("tree " + std::to_string(i + 1) + " of the list: radius - 1.3 * tree.listed_taper must be > 0");
    // Not capped: a thin trunk whose radius reaches 0 below its height ends in a point there (the ray
    // caster stops a trunk where its radius reaches 0), and every trunk keeps the stated taper.
    trunk.taper = tree.taper;
    if (tree.has_taper_range)  // drawn, and at most what ends the stem in a point at its top
    {
      trunk.taper = random.uniform(tree.taper_range.lo, tree.taper_range.hi);
      if (trunk.height > s_listed)
        trunk.taper = std::min(trunk.taper, r_listed / (trunk.height - s_listed));
    }
    if (tree.at_breast_height)
    {
      trunk.x -= kBreastHeight * trunk.lean_x;
      trunk.y -= kBreastHeight * trunk.lean_y;
      trunk.radius = r_listed + trunk.taper * s_listed;
    }
    trunks.push_back(trunk);
  }
  return trunks;
}

sim::GroundSpec readGround(const YamlReader& reader, const YAML::Node& node)
{
  sim::GroundSpec g;
  for (const auto& entry : reader.entries(node, "ground", { "amplitude", "wavelength", "seed", "margin", "slope" }))
  {
    const std::string key = YamlReader::qualified("ground", entry.first);
    if (entry.first == "slope")
    {
      const std::vector<double> v = reader.numbers(entry.second, key, 2, 2, "[along x, along y]");
      if (std::hypot(v[0], v[1]) > 1.0)  // steeper than 45 degrees: no stand is driven there
        reader.fail(entry.second, "'" + key + "' must be no steeper than 1 (45 degrees)");
      g.slope = Eigen::Vector2d(v[0], v[1]);
    }
    else if (entry.first == "amplitude")
      g.amplitude = reader.numberAtLeast(entry.second, key, 0.0, true);
    else if (entry.first == "wavelength")
      g.wavelength = reader.numberAtLeast(entry.second, key, 0.0, false);
    else if (entry.first == "margin")
      g.margin = reader.numberAtLeast(entry.second, key, 0.0, true);
    else
      g.seed = reader.seed(entry.second, key);
  }
  return g;
}

sim::ClutterSpec readClutter(const YamlReader& reader, const YAML::Node& node)
{
  sim::ClutterSpec c;
  const std::vector<std::string> keys = { "seed", "bushes", "rocks", "branches", "crowns", "crown_base", "clearance" };
  for (const auto& entry : reader.entries(node, "clutter", keys))
  {
    const std::string key = YamlReader::qualified("clutter", entry.first);
    if (entry.first == "seed")
      c.seed = reader.seed(entry.second, key);
    else if (entry.first == "bushes")
      c.bushes = reader.count(entry.second, key);
    else if (entry.first == "rocks")
      c.rocks = reader.count(entry.second, key);
    else if (entry.first == "branches")
      c.branches = reader.count(entry.second, key);
    else if (entry.first == "crowns")
      c.crowns = reader.boolean(entry.second, key);
    else if (entry.first == "crown_base")
      c.crown_base = reader.numberAtLeast(entry.second, key, 0.0, true);
    else
      c.clearance = reader.numberAtLeast(entry.second, key, 0.0, true);
  }
  return c;
}

sim::WhorlSpec readWhorls(const YamlReader& reader, const YAML::Node& node)
{
  sim::WhorlSpec w;
  const std::vector<std::string> keys = { "seed", "heights", "spacing", "fill", "per_whorl", "live", "dead_length",
                                          "live_length", "thickness", "tuft_radius" };
  for (const auto& entry : reader.entries(node, "whorls", keys))
  {
    const std::string key = YamlReader::qualified("whorls", entry.first);
    const YAML::Node& v = entry.second;
    if (entry.first == "seed")
      w.seed = reader.seed(v, key);
    else if (entry.first == "heights")
      w.heights = reader.interval(v, key, 0.0, true);
    else if (entry.first == "spacing")
      w.spacing = reader.interval(v, key, 0.0, false);
    else if (entry.first == "fill")
      w.fill = reader.share(v, key);
    else if (entry.first == "live")
      w.live = reader.share(v, key);
    else if (entry.first == "per_whorl")
    {
      const sim::Interval n = reader.interval(v, key, 1.0, true, 32.0);
      if (n.lo != std::floor(n.lo) || n.hi != std::floor(n.hi))
        reader.fail(v, "'" + key + "' must be whole numbers");
      w.min_per_whorl = static_cast<int>(n.lo);
      w.max_per_whorl = static_cast<int>(n.hi);
    }
    else if (entry.first == "dead_length")
      w.dead_length = reader.interval(v, key, 0.0, true);
    else if (entry.first == "live_length")
      w.live_length = reader.interval(v, key, 0.0, true);
    else if (entry.first == "thickness")
      w.thickness = reader.interval(v, key, 0.0, false);
    else
      w.tuft_radius = reader.interval(v, key, 0.0, false);
  }
  return w;
}

void readSaplings(const YamlReader& reader, const YAML::Node& node, sim::UnderstorySpec* u)
{
  const std::string name = "understory.saplings";
  for (const auto& entry : reader.entries(node, name, { "count", "dbh", "height", "crown_base", "crown_radius" }))
  {
    const std::string key = YamlReader::qualified(name, entry.first);
    if (entry.first == "count")
      u->saplings = reader.count(entry.second, key);
    else if (entry.first == "dbh")
      u->sapling_dbh = reader.interval(entry.second, key, 0.0, false);
    else if (entry.first == "height")
      u->sapling_height = reader.interval(entry.second, key, 1.3, false);
    else if (entry.first == "crown_base")
      u->sapling_crown_base = reader.interval(entry.second, key, 0.0, true);
    else
      u->sapling_crown_radius = reader.interval(entry.second, key, 0.0, false);
  }
}

void readShrubs(const YamlReader& reader, const YAML::Node& node, sim::UnderstorySpec* u)
{
  const std::string name = "understory.shrubs";
  for (const auto& entry : reader.entries(node, name, { "count", "radius", "top" }))
  {
    const std::string key = YamlReader::qualified(name, entry.first);
    if (entry.first == "count")
      u->shrubs = reader.count(entry.second, key);
    else if (entry.first == "radius")
      u->shrub_radius = reader.interval(entry.second, key, 0.0, false);
    else
      u->shrub_top = reader.interval(entry.second, key, 0.0, false);
  }
}

sim::UnderstorySpec readUnderstory(const YamlReader& reader, const YAML::Node& node)
{
  sim::UnderstorySpec u;
  for (const auto& entry : reader.entries(node, "understory", { "seed", "clearance", "saplings", "shrubs" }))
  {
    const std::string key = YamlReader::qualified("understory", entry.first);
    if (entry.first == "seed")
      u.seed = reader.seed(entry.second, key);
    else if (entry.first == "clearance")
      u.clearance = reader.numberAtLeast(entry.second, key, 0.0, true);
    else if (entry.first == "saplings")
      readSaplings(reader, entry.second, &u);
    else
      readShrubs(reader, entry.second, &u);
  }
  return u;
}

/** Bounds of the trunk centres plus a margin; false when there are no trunks. */
bool treeExtent(const std::vector<sim::TrunkSpec>& trunks, sim::ForestWorld* world)
{
  if (trunks.empty())
    return false;
  double min_x = trunks[0].x, max_x = trunks[0].x, min_y = trunks[0].y, max_y = trunks[0].y;
  for (const sim::TrunkSpec& t : trunks)
  {
    min_x = std::min(min_x, t.x);
    max_x = std::max(max_x, t.x);
    min_y = std::min(min_y, t.y);
    max_y = std::max(max_y, t.y);
  }
  world->min_x = min_x - kDefaultBoundsMargin;
  world->max_x = max_x + kDefaultBoundsMargin;
  world->min_y = min_y - kDefaultBoundsMargin;
  world->max_y = max_y + kDefaultBoundsMargin;
  return true;
}

/**
 * The track: its drives (named, or waypoint files relative to the world file's folder) taken from the start frame
 * of `start` (x, y, yaw in degrees; the simulator's default start) into the world.
 */
sim::TrackSpec readTrack(const YamlReader& reader, const YAML::Node& node)
{
  sim::TrackSpec track;
  std::vector<double> start = { 0.0, 15.0, 0.0 };
  YAML::Node drives;
  for (const auto& entry : reader.entries(node, "track", { "start", "drives", "clearance", "headroom" }))
  {
    const std::string key = YamlReader::qualified("track", entry.first);
    if (entry.first == "start")
      start = reader.numbers(entry.second, key, 3, 3, "[x, y, yaw_deg]");
    else if (entry.first == "clearance")
      track.clearance = reader.numberAtLeast(entry.second, key, 0.0, true);
    else if (entry.first == "headroom")
      track.headroom = reader.numberAtLeast(entry.second, key, 0.0, true);
    else
      drives = entry.second;
  }
  if (!drives.IsSequence() || drives.size() == 0)
    reader.fail(drives.IsNull() ? node : drives,
                "'track.drives' must be a list of drives (straight, loop or a waypoint file), at least one");
  const double c = std::cos(start[2] * kPi / 180.0), s = std::sin(start[2] * kPi / 180.0);
  for (std::size_t i = 0; i < drives.size(); ++i)
  {
    const std::string key = "track.drives[" + std::to_string(i) + "]";
    if (!drives[i].IsScalar() || drives[i].Scalar().empty())
      reader.fail(drives[i], "'" + key + "' must name a drive (straight, loop or a waypoint file)");
    const std::string& name = drives[i].Scalar();
    const bool as_is = name == "straight" || name == "loop" || name[0] == '/';
    std::string error;
    const std::vector<Eigen::Vector2d> waypoints =
        sim::namedDrive(as_is ? name : folderOf(reader.path()) + name, &error);
    if (waypoints.empty())
      reader.fail(drives[i], "'" + key + "': " + error);
    std::vector<Eigen::Vector2d> route;
    for (const Eigen::Vector2d& p : waypoints)
      route.emplace_back(start[0] + c * p.x() - s * p.y(), start[1] + s * p.x() + c * p.y());
    track.routes.push_back(route);
  }
  return track;
}

/** The top-level sections of a world file by name (an unknown or repeated one is an error); 'trees' is required. */
std::map<std::string, YAML::Node> readSections(const YamlReader& reader, const YAML::Node& root)
{
  const std::vector<std::string> names = { "trees", "boxes", "bounds", "tree", "ground", "clutter", "whorls",
                                           "understory", "track" };
  std::map<std::string, YAML::Node> sections;
  for (const auto& entry : reader.entries(root, "", names))
    sections[entry.first] = entry.second;
  if (!sections.count("trees"))
    reader.fail("'trees' is required (a tree list file or a list of trees)");
  return sections;
}

/** The stand bounds: the section's, or the tree extent + 2 m. */
void readBounds(const YamlReader& reader, const std::map<std::string, YAML::Node>& sections, sim::ForestWorld* world)
{
  const auto bounds = sections.find("bounds");
  if (bounds != sections.end())
  {
    const YAML::Node& node = bounds->second;
    const std::vector<double> b = reader.numbers(node, "bounds", 4, 4, "[min_x, min_y, max_x, max_y]");
    if (!(b[0] < b[2]) || !(b[1] < b[3]))
      reader.fail(node, "'bounds' [min_x, min_y, max_x, max_y] must have min < max");
    world->min_x = b[0];
    world->min_y = b[1];
    world->max_x = b[2];
    world->max_y = b[3];
  }
  else if (!treeExtent(world->trunks, world))
  {
    reader.fail("no trees and no 'bounds': the stand has no extent");
  }
}

sim::ForestWorld loadYamlWorld(const std::string& path)
{
  const YamlReader reader(path);
  YAML::Node root;
  try
  {
    root = YAML::LoadFile(path);
  }
  catch (const YAML::BadFile&)
  {
    reader.fail("cannot open world file");
  }
  catch (const YAML::ParserException& e)
  {
    throw std::runtime_error(path + ":" + std::to_string(e.mark.line + 1) + ":" + std::to_string(e.mark.column + 1) +
                             ": YAML syntax error: " + e.msg);
  }
  if (root.IsNull())
    reader.fail("empty world file ('trees' is required)");

  std::map<std::string, YAML::Node> sections = readSections(reader, root);
  const bool has_whorls = sections.count("whorls") > 0;
  const bool has_understory = sections.count("understory") > 0;
  const std::vector<TreeRow> rows = readTrees(reader, sections["trees"]);
  const YAML::Node boxes_node = sections["boxes"];
  const std::vector<sim::BoxSpec> boxes =
      boxes_node.IsDefined() && !boxes_node.IsNull() ? readBoxes(reader, boxes_node) : std::vector<sim::BoxSpec>();
  const TreeDefaults tree = readTreeDefaults(reader, sections["tree"]);
  sim::ForestWorld world;
  world.boxes = boxes;
  world.ground = readGround(reader, sections["ground"]);
  const sim::ClutterSpec clutter = readClutter(reader, sections["clutter"]);
  const sim::UnderstorySpec understory =
      has_understory ? readUnderstory(reader, sections["understory"]) : sim::UnderstorySpec();
  const sim::WhorlSpec whorls = has_whorls ? readWhorls(reader, sections["whorls"]) : sim::WhorlSpec();
  if (sections.count("track"))
    world.track = readTrack(reader, sections["track"]);

  world.trunks = makeTrunks(reader, rows, tree);
  readBounds(reader, sections, &world);

  try
  {
    sim::addClutter(clutter, &world);
    // The understory keeps clear of the clutter; the branches on the stems come last, as they grow into both.
    if (has_understory)
      sim::addUnderstory(understory, &world);
    if (has_whorls)
      sim::addWhorls(whorls, &world);
  }
  catch (const std::invalid_argument& e)  // the checks above should have caught it; name the file anyway
  {
    reader.fail(e.what());
  }
  return world;
}
}  // namespace

std::vector<sim::BoxSpec> loadBoxList(const std::string& path)
{
  std::vector<sim::BoxSpec> boxes;
  for (const std::vector<double>& values : readNumberRows(path, "box list", kBoxLineFormat, checkBox))
    boxes.push_back(makeBox(values));
  return boxes;
}

std::vector<sim::TrunkSpec> loadTreeList(const std::string& path)
{
  std::vector<sim::TrunkSpec> trunks;
  for (const TreeRow& row : readTreeRows(path))
    trunks.push_back(row.trunk);
  return trunks;
}

sim::ForestWorld loadForestWorld(const std::string& path)
{
  if (endsWithNoCase(path, ".yaml") || endsWithNoCase(path, ".yml"))
  {
    try
    {
      return loadYamlWorld(path);
    }
    catch (const YAML::Exception& e)  // anything yaml-cpp throws that the reader did not turn into a message
    {
      throw std::runtime_error(path + ": " + e.what());
    }
  }
  sim::ForestWorld world;
  world.trunks = loadTreeList(path);
  world.ground.amplitude = 0.0;  // a bare tree list is the idealised stand: flat, no clutter
  if (!treeExtent(world.trunks, &world))
    throw std::runtime_error(path + ": no trees in tree list");
  return world;
}

}  // namespace sim
}  // namespace rbpf_slam
