#include <dirent.h>
#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/sim/path_follower.h"
#include "rbpf_slam/sim/waypoints_file.h"
#include "rbpf_slam/sim/world_file.h"
#include "io/temp_files.h"

using rbpf_slam::sim::loadForestWorld;
using rbpf_slam::sim::loadTreeList;
using rbpf_slam::sim::ForestWorld;
using rbpf_slam::sim::TrunkSpec;

namespace
{
const std::string kSourceDir = RBPF_SLAM_SOURCE_DIR;
const std::string kWorldDir = kSourceDir + "/config/worlds/";

/** A fresh temporary folder per test, removed with its files afterwards. */
class WorldFileTest : public ::testing::Test
{
protected:
  void SetUp() override
  {
    char pattern[] = "/tmp/rbpf_slam_world_file_XXXXXX";
    ASSERT_NE(mkdtemp(pattern), nullptr);
    dir_ = pattern;
  }

  void TearDown() override
  {
    for (const std::string& f : files_)
      unlink(f.c_str());
    rmdir(dir_.c_str());
  }

  std::string write(const std::string& name, const std::string& text)
  {
    const std::string path = dir_ + "/" + name;
    std::ofstream(path) << text;
    files_.push_back(path);
    return path;
  }

  /** The message of the std::runtime_error that loading @p path throws ("" if none is thrown). */
  static std::string loadError(const std::string& path)
  {
    try
    {
      loadForestWorld(path);
    }
    catch (const std::runtime_error& e)
    {
      return e.what();
    }
    return std::string();
  }

  std::string dir_;
  std::vector<std::string> files_;
};

/** True for a map_server map description (top-level `image:`), which shares config/worlds with forest worlds. */
bool isMapImageYaml(const std::string& path)
{
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line))
  {
    if (line.compare(0, 6, "image:") == 0)
      return true;
  }
  return false;
}

/** Every forest world file in config/worlds (all YAML files but the map_server maps). */
std::vector<std::string> shippedWorlds()
{
  std::vector<std::string> worlds;
  DIR* dir = opendir(kWorldDir.c_str());
  if (!dir)
    return worlds;
  while (const dirent* entry = readdir(dir))
  {
    const std::string name = entry->d_name;
    if (name.size() > 5 && name.compare(name.size() - 5, 5, ".yaml") == 0 && !isMapImageYaml(kWorldDir + name))
      worlds.push_back(kWorldDir + name);
  }
  closedir(dir);
  return worlds;
}

using temp_files::readFile;

const char* const kMinimalYamlTrees = "trees: [[1, 2, 0.2], [5, 6, 0.3, 12]]\n";
}  // namespace

// --- Tree lists -----------------------------------------------------------------------------------

TEST_F(WorldFileTest, TreeListWithCommentsParses)
{
  const std::string path = write("stand.trees.txt",
                                 "# x y radius [height]\n"
                                 "\n"
                                 "1.5 2.5 0.2\n"
                                 "   # indented comment\n"
                                 "3 4 0.25 12.5   # trailing comment\n"
                                 "\t-1e1  7.0\t0.1\r\n"
                                 "   \n");
  const std::vector<TrunkSpec> trunks = loadTreeList(path);
  ASSERT_EQ(trunks.size(), 3u);
  EXPECT_DOUBLE_EQ(trunks[0].x, 1.5);
  EXPECT_DOUBLE_EQ(trunks[0].y, 2.5);
  EXPECT_DOUBLE_EQ(trunks[0].radius, 0.2);
  EXPECT_DOUBLE_EQ(trunks[0].height, TrunkSpec().height);
  EXPECT_DOUBLE_EQ(trunks[1].height, 12.5);
  EXPECT_DOUBLE_EQ(trunks[2].x, -10.0);
  EXPECT_DOUBLE_EQ(trunks[2].radius, 0.1);
  for (const TrunkSpec& t : trunks)
  {
    EXPECT_EQ(t.lean_x, 0.0);
    EXPECT_EQ(t.lean_y, 0.0);
    EXPECT_EQ(t.taper, 0.0);
  }
}

TEST_F(WorldFileTest, BadTreeLineNamesFileAndLine)
{
  const std::string path = write("bad.trees.txt", "# header\n1 2 0.2\n1.0 abc 0.2\n");
  try
  {
    loadTreeList(path);
    FAIL() << "no error for a non-number";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find(path + ":3: expected 'x y radius [height]', got '1.0 abc 0.2'"),
              std::string::npos)
        << e.what();
  }
}

TEST_F(WorldFileTest, EveryKindOfBadTreeLineIsAnError)
{
  const std::vector<std::string> bad_lines = { "1 2",      "1 2 0.2 15 3", "1 2 nan",  "1 2 inf",   "1 2 0",
                                               "1 2 -0.2", "1 2 0.2 0",    "1 2 0.2x", "1,2,0.2",   "1 2 1e999",
                                               "x y r",    "1 2 0x1p-3",   "1 2 .2.",  "1 2 0.2 #x 5 6 7 extra" };
  for (std::size_t i = 0; i + 1 < bad_lines.size(); ++i)
  {
    const std::string path = write("bad" + std::to_string(i) + ".txt", "0 0 0.1\n\n" + bad_lines[i] + "\n");
    try
    {
      loadTreeList(path);
      ADD_FAILURE() << "no error for '" << bad_lines[i] << "'";
    }
    catch (const std::runtime_error& e)
    {
      EXPECT_NE(std::string(e.what()).find(path + ":3: expected 'x y radius [height]', got '" + bad_lines[i] + "'"),
                std::string::npos)
          << e.what();
    }
  }
  // The last line is valid: the comment holds the rest.
  EXPECT_EQ(loadTreeList(write("good.txt", bad_lines.back() + "\n")).size(), 1u);
}

TEST_F(WorldFileTest, MissingFileIsAnErrorNamingIt)
{
  const std::string path = dir_ + "/no_such.trees.txt";
  EXPECT_NE(loadError(path).find(path), std::string::npos);
  EXPECT_NE(loadError(dir_ + "/no_such.yaml").find(dir_ + "/no_such.yaml"), std::string::npos);
}

TEST_F(WorldFileTest, BareTreeListIsFlatWithoutClutter)
{
  const std::string path = write("stand.txt", "1 2 0.2\n11 22 0.3\n");
  const ForestWorld world = loadForestWorld(path);
  ASSERT_EQ(world.trunks.size(), 2u);
  EXPECT_EQ(world.ground.amplitude, 0.0);
  EXPECT_TRUE(world.foliage.empty());
  EXPECT_TRUE(world.rocks.empty());
  EXPECT_TRUE(world.branches.empty());
  EXPECT_DOUBLE_EQ(world.min_x, -1.0);
  EXPECT_DOUBLE_EQ(world.min_y, 0.0);
  EXPECT_DOUBLE_EQ(world.max_x, 13.0);
  EXPECT_DOUBLE_EQ(world.max_y, 24.0);
}

// --- YAML world files -----------------------------------------------------------------------------

TEST_F(WorldFileTest, YamlWithTreeFileAndDefaults)
{
  write("stand.trees.txt", "10 10 0.2\n20 20 0.25 18\n");
  const std::string path = write("world.yaml", "trees: stand.trees.txt\n");
  const ForestWorld world = loadForestWorld(path);
  ASSERT_EQ(world.trunks.size(), 2u);
  EXPECT_DOUBLE_EQ(world.trunks[0].height, 15.0);
  EXPECT_DOUBLE_EQ(world.trunks[1].height, 18.0);
  EXPECT_EQ(world.trunks[0].lean_x, 0.0);
  EXPECT_EQ(world.trunks[0].taper, 0.0);
  EXPECT_DOUBLE_EQ(world.ground.amplitude, 0.3);
  EXPECT_DOUBLE_EQ(world.ground.wavelength, 15.0);
  EXPECT_DOUBLE_EQ(world.min_x, 8.0);
  EXPECT_DOUBLE_EQ(world.max_y, 22.0);
  EXPECT_EQ(world.foliage.size(), 2u);  // crowns are on by default, no other clutter
  EXPECT_TRUE(world.rocks.empty());
  EXPECT_TRUE(world.branches.empty());
}

TEST_F(WorldFileTest, YamlWithEverySetting)
{
  const std::string path = write("world.yml",
                                 "# a comment\n"
                                 "trees: [[5, 5, 0.2], [15, 15, 0.1, 20]]\n"
                                 "bounds: [0, 0, 20, 20]\n"
                                 "tree: {height: 12, lean_sigma_deg: 2, taper: 0.01, seed: 3}\n"
                                 "ground:\n"
                                 "  amplitude: 0.2\n"
                                 "  wavelength: 10\n"
                                 "  seed: 4\n"
                                 "clutter: {seed: 5, bushes: 3, rocks: 2, branches: 1, crowns: false, crown_base: 4,"
                                 " clearance: 0.5}\n");
  const ForestWorld world = loadForestWorld(path);
  ASSERT_EQ(world.trunks.size(), 2u);
  EXPECT_DOUBLE_EQ(world.trunks[0].height, 12.0);
  EXPECT_DOUBLE_EQ(world.trunks[1].height, 20.0);
  EXPECT_NE(world.trunks[0].lean_x, 0.0);
  EXPECT_NE(world.trunks[1].lean_y, 0.0);
  EXPECT_DOUBLE_EQ(world.trunks[0].taper, 0.01);
  EXPECT_DOUBLE_EQ(world.trunks[1].taper, 0.01);
  EXPECT_DOUBLE_EQ(world.ground.amplitude, 0.2);
  EXPECT_DOUBLE_EQ(world.ground.wavelength, 10.0);
  EXPECT_EQ(world.ground.seed, 4u);
  EXPECT_DOUBLE_EQ(world.max_x, 20.0);
  EXPECT_EQ(world.foliage.size(), 3u);  // bushes only
  EXPECT_EQ(world.rocks.size(), 2u);
  EXPECT_EQ(world.branches.size(), 1u);
  // Same file, same world.
  const ForestWorld again = loadForestWorld(path);
  EXPECT_EQ(again.trunks[0].lean_x, world.trunks[0].lean_x);
  EXPECT_EQ(again.foliage[0].center, world.foliage[0].center);
}

TEST_F(WorldFileTest, YamlUnknownKeyIsNamed)
{
  const std::string top = write("top.yaml", std::string(kMinimalYamlTrees) + "grund: {amplitude: 0.3}\n");
  const std::string error = loadError(top);
  EXPECT_NE(error.find(top + ":2:"), std::string::npos) << error;
  EXPECT_NE(error.find("unknown key 'grund'"), std::string::npos) << error;

  const std::string nested = write("nested.yaml", std::string(kMinimalYamlTrees) + "clutter:\n  bushs: 3\n");
  const std::string nested_error = loadError(nested);
  EXPECT_NE(nested_error.find(nested + ":3:"), std::string::npos) << nested_error;
  EXPECT_NE(nested_error.find("unknown key 'clutter.bushs'"), std::string::npos) << nested_error;
}

TEST_F(WorldFileTest, YamlDuplicateKeyIsAnError)
{
  const std::string path =
      write("dup.yaml", std::string(kMinimalYamlTrees) + "ground: {amplitude: 0.3, amplitude: 0}\n");
  const std::string error = loadError(path);
  EXPECT_NE(error.find(path), std::string::npos) << error;
  EXPECT_NE(error.find("ground.amplitude"), std::string::npos) << error;
}

TEST_F(WorldFileTest, YamlWrongTypeNamesTheKey)
{
  struct Case
  {
    std::string text;
    std::string key;
  };
  const std::vector<Case> cases = {
    { "ground:\n  amplitude: abc\n", "'ground.amplitude' must be a finite number, got 'abc'" },
    { "ground:\n  amplitude: [1, 2]\n", "'ground.amplitude'" },
    { "clutter:\n  bushes: 2.5\n", "'clutter.bushes' must be an integer" },
    { "clutter:\n  crowns: maybe\n", "'clutter.crowns' must be true or false" },
    { "tree:\n  seed: -1\n", "'tree.seed'" },
    { "ground: 5\n", "'ground' must be a map" },
    { "bounds: [0, 0, 30]\n", "'bounds' must be [min_x, min_y, max_x, max_y]" },
  };
  for (std::size_t i = 0; i < cases.size(); ++i)
  {
    const std::string name = "type" + std::to_string(i) + ".yaml";
    const std::string path = write(name, std::string(kMinimalYamlTrees) + cases[i].text);
    const std::string error = loadError(path);
    EXPECT_NE(error.find(cases[i].key), std::string::npos) << error;
    // yaml-cpp's mark gives the line of the offending value (line 2 or 3 of the file).
    EXPECT_TRUE(error.find(path + ":2:") == 0 || error.find(path + ":3:") == 0) << error;
  }
}

TEST_F(WorldFileTest, YamlValuesAreValidated)
{
  const std::vector<std::string> bad = {
    "ground: {amplitude: -0.1}\n", "ground: {wavelength: 0}\n", "clutter: {rocks: -2}\n",
    "clutter: {clearance: -1}\n",  "bounds: [10, 0, 5, 30]\n",  "bounds: [0, 0, 30, 0]\n",
    "tree: {height: 0}\n",         "tree: {lean_sigma_deg: -1}\n", "tree: {taper: -0.01}\n",
    "ground: {amplitude: .nan}\n",
  };
  for (std::size_t i = 0; i < bad.size(); ++i)
  {
    const std::string path = write("value" + std::to_string(i) + ".yaml", std::string(kMinimalYamlTrees) + bad[i]);
    const std::string error = loadError(path);
    EXPECT_EQ(error.find(path + ":2:"), 0u) << bad[i] << " -> " << error;
  }
  const std::string bad_tree = write("tree.yaml", "trees: [[1, 2, 0.2], [1, 2, -0.2]]\n");
  EXPECT_NE(loadError(bad_tree).find("'trees[1]': radius must be > 0"), std::string::npos) << loadError(bad_tree);
  const std::string no_trees = write("none.yaml", "ground: {amplitude: 0.3}\n");
  EXPECT_NE(loadError(no_trees).find("'trees' is required"), std::string::npos) << loadError(no_trees);
  const std::string empty = write("empty.yaml", "");
  EXPECT_NE(loadError(empty).find(empty), std::string::npos);
  const std::string syntax = write("syntax.yaml", "trees: [[1, 2, 0.2]\nground: {\n");
  EXPECT_EQ(loadError(syntax).find(syntax + ":"), 0u) << loadError(syntax);
}

TEST_F(WorldFileTest, YamlRealisticStandKeys)
{
  const std::string path = write("real.yaml",
                                 "trees: [[5, 5, 0.2], [15, 15, 0.12], [10, 3, 0.3]]\n"
                                 "bounds: [0, 0, 20, 20]\n"
                                 "tree: {height: 15, lean_deg: [2, 4], taper: [0.004, 0.012], listed_at: breast_height,"
                                 " listed_taper: 0.01, seed: 2}\n"
                                 "ground: {amplitude: 0.5, slope: [0.10, -0.02]}\n"
                                 "clutter: {bushes: 2, branches: 2}\n"
                                 "whorls: {seed: 3, heights: [1, 6], spacing: [0.5, 1.0], fill: 1, per_whorl: 2,"
                                 " live: 0.5, dead_length: [0.2, 1.0], live_length: [0.5, 1.5],"
                                 " thickness: [0.01, 0.04],"
                                 " tuft_radius: 0.2}\n"
                                 "understory:\n"
                                 "  seed: 4\n"
                                 "  clearance: 0.2\n"
                                 "  saplings: {count: 5, dbh: [0.01, 0.05], height: [1.5, 4], crown_base: [0.5, 2],"
                                 " crown_radius: [0.3, 0.8]}\n"
                                 "  shrubs: {count: 6, radius: [0.3, 1.0], top: [0.5, 2.0]}\n");
  const ForestWorld world = loadForestWorld(path);
  EXPECT_EQ(world.ground.slope, Eigen::Vector2d(0.10, -0.02));
  EXPECT_EQ(world.ground.amplitude, 0.5);
  const double list[3][3] = { { 5, 5, 0.2 }, { 15, 15, 0.12 }, { 10, 3, 0.3 } };
  ASSERT_EQ(world.trunks.size(), 3u);
  for (int i = 0; i < 3; ++i)
  {
    const TrunkSpec& t = world.trunks[i];
    const double lean = std::hypot(t.lean_x, t.lean_y);
    EXPECT_GE(lean, std::tan(2.0 * M_PI / 180.0) - 1e-12) << i;
    EXPECT_LE(lean, std::tan(4.0 * M_PI / 180.0) + 1e-12) << i;
    EXPECT_GE(t.taper, 0.004) << i;
    EXPECT_LE(t.taper, 0.012) << i;
    // Listed at breast height: the stem's centre 1.3 m above its foot is the list's, its radius there the list's
    // less 1.3 * listed_taper (the clean worlds' radius at breast height).
    double radius = 0.0;
    const Eigen::Vector3d c = rbpf_slam::sim::trunkAxisAt(t, 0.0, 1.3, &radius);
    EXPECT_NEAR(c.x(), list[i][0], 1e-12) << i;
    EXPECT_NEAR(c.y(), list[i][1], 1e-12) << i;
    EXPECT_NEAR(c.z(), 1.3, 1e-12) << i;
    EXPECT_NEAR(radius, list[i][2] - 0.013, 1e-12) << i;
  }
  // Every whorl bears exactly two branches; the live ones carry tufts.
  ASSERT_FALSE(world.stubs.empty());
  EXPECT_EQ(world.stubs.size() % 2, 0u);
  std::size_t live = 0;
  for (const auto& stub : world.stubs)
    live += stub.live ? 1 : 0;
  EXPECT_EQ(world.saplings.size(), 5u);
  // Foliage: 3 crowns, 2 bushes, the saplings' crowns (1-6 spheres each), 6 shrubs and the tufts.
  EXPECT_GE(world.foliage.size(), 3u + 2u + 5u + 6u + live);
  EXPECT_LE(world.foliage.size(), 3u + 2u + 30u + 6u + live);
  EXPECT_EQ(world.branches.size(), 2u);
  // Same file, same world.
  const ForestWorld again = loadForestWorld(path);
  ASSERT_EQ(again.stubs.size(), world.stubs.size());
  EXPECT_EQ(again.stubs.back().b, world.stubs.back().b);
  EXPECT_EQ(again.saplings.back().x, world.saplings.back().x);
  EXPECT_EQ(again.trunks[2].lean_y, world.trunks[2].lean_y);
}

TEST_F(WorldFileTest, YamlRealisticStandKeysAreValidated)
{
  struct Case
  {
    std::string text;
    std::string message;
  };
  const std::vector<Case> cases = {
    { "tree: {lean_sigma_deg: 1, lean_deg: [2, 4]}\n", "not both" },
    { "tree: {lean_deg: [4, 2]}\n", "'tree.lean_deg' [lo, hi] must have lo <= hi" },
    { "tree: {lean_deg: 50}\n", "'tree.lean_deg' must be <= 44.9" },
    { "tree: {listed_at: top}\n", "'tree.listed_at' must be ground or breast_height" },
    { "tree: {taper: [0.01]}\n", "'tree.taper' must be a number or [lo, hi]" },
    { "tree: {taper: [-0.01, 0.01]}\n", "'tree.taper' must be >= 0" },
    { "tree: {listed_taper: -1}\n", "'tree.listed_taper' must be >= 0" },
    { "ground: {slope: [2, 0]}\n", "'ground.slope' must be no steeper than 1" },
    { "ground: {slope: 0.1}\n", "'ground.slope' must be [along x, along y]" },
    { "whorls: {fill: 1.5}\n", "'whorls.fill' must be within [0, 1]" },
    { "whorls: {per_whorl: [1.5, 3]}\n", "'whorls.per_whorl' must be whole numbers" },
    { "whorls: {per_whorl: 0}\n", "'whorls.per_whorl' must be >= 1" },
    { "whorls: {spacing: 0}\n", "'whorls.spacing' must be > 0" },
    { "whorls: {branches: 3}\n", "unknown key 'whorls.branches'" },
    { "understory: {saplings: {height: [1, 3]}}\n", "'understory.saplings.height' must be > 1.3" },
    { "understory: {shrubs: {count: -1}}\n", "'understory.shrubs.count' must be an integer in [0, 1000000]" },
    { "understory: {shrubs: {top: [2, 1]}}\n", "'understory.shrubs.top' [lo, hi] must have lo <= hi" },
    { "understory: {bushes: 3}\n", "unknown key 'understory.bushes'" },
  };
  for (std::size_t i = 0; i < cases.size(); ++i)
  {
    const std::string path =
        write("real" + std::to_string(i) + ".yaml", std::string(kMinimalYamlTrees) + cases[i].text);
    const std::string error = loadError(path);
    EXPECT_EQ(error.find(path + ":2:"), 0u) << cases[i].text << " -> " << error;
    EXPECT_NE(error.find(cases[i].message), std::string::npos) << cases[i].text << " -> " << error;
  }
  // A listed radius at breast height that the listed taper would make negative.
  const std::string thin =
      write("thin.yaml", "trees: [[1, 2, 0.01]]\ntree: {listed_at: breast_height, listed_taper: 0.01}\n");
  EXPECT_NE(loadError(thin).find("tree 1 of the list: radius - 1.3 * tree.listed_taper must be > 0"), std::string::npos)
      << loadError(thin);
}

TEST_F(WorldFileTest, YamlTrackTakesTheDrivesIntoTheWorld)
{
  write("bend.txt", "# start frame\n0 0\n10 0\n10 5\n");
  const ForestWorld world = loadForestWorld(
      write("track.yaml", "trees: [[20, 20, 0.2]]\nbounds: [0, 0, 40, 40]\n"
                          "track: {start: [2, 3, 90], drives: [straight, bend.txt], clearance: 1.2, headroom: 2.5}\n"));
  ASSERT_EQ(world.track.routes.size(), 2u);
  EXPECT_EQ(world.track.clearance, 1.2);
  EXPECT_EQ(world.track.headroom, 2.5);
  // From the start frame (at (2, 3) heading +y) into the world.
  const std::vector<Eigen::Vector2d>& straight = world.track.routes[0];
  ASSERT_EQ(straight.size(), rbpf_slam::sim::straightDrive().size());
  EXPECT_NEAR((straight.front() - Eigen::Vector2d(2, 3)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((straight.back() - Eigen::Vector2d(2, 33)).norm(), 0.0, 1e-12);
  const std::vector<Eigen::Vector2d>& bend = world.track.routes[1];
  ASSERT_EQ(bend.size(), 3u);
  EXPECT_NEAR((bend[2] - Eigen::Vector2d(-3, 13)).norm(), 0.0, 1e-12);
  // The defaults: the simulator's start, 2 m, 3 m; without the section, no track.
  const ForestWorld plain = loadForestWorld(write("plain.yaml", "trees: [[20, 20, 0.2]]\ntrack: {drives: [loop]}\n"));
  ASSERT_EQ(plain.track.routes.size(), 1u);
  EXPECT_NEAR((plain.track.routes[0].front() - Eigen::Vector2d(0, 15)).norm(), 0.0, 1e-12);
  EXPECT_EQ(plain.track.clearance, 2.0);
  EXPECT_EQ(plain.track.headroom, 3.0);
  EXPECT_TRUE(loadForestWorld(write("none.yaml", "trees: [[20, 20, 0.2]]\n")).track.routes.empty());
  // Errors name the file, the line and the key.
  const std::vector<std::pair<std::string, std::string>> cases = {
    { "track: {drives: []}\n", "'track.drives' must be a list of drives" },
    { "track: {clearance: 1}\n", "'track.drives' must be a list of drives" },
    { "track: {drives: [nowhere.txt]}\n", "'track.drives[0]': drive '" },
    { "track: {drives: [loop], clearance: -1}\n", "'track.clearance' must be >= 0" },
    { "track: {drives: [loop], start: [0, 15]}\n", "'track.start' must be [x, y, yaw_deg]" },
    { "track: {drives: [loop], width: 4}\n", "unknown key 'track.width'" },
  };
  for (std::size_t i = 0; i < cases.size(); ++i)
  {
    const std::string path = write("bad" + std::to_string(i) + ".yaml", "trees: [[20, 20, 0.2]]\n" + cases[i].first);
    const std::string error = loadError(path);
    EXPECT_EQ(error.find(path + ":2"), 0u) << cases[i].first << " -> " << error;
    EXPECT_NE(error.find(cases[i].second), std::string::npos) << cases[i].first << " -> " << error;
  }
}

TEST_F(WorldFileTest, YamlTreeFileErrorsNameTheTreeFile)
{
  const std::string trees = write("broken.trees.txt", "1 2 0.2\n1 2\n");
  const std::string path = write("world.yaml", "trees: broken.trees.txt\n");
  EXPECT_NE(loadError(path).find(trees + ":2: expected 'x y radius [height]'"), std::string::npos) << loadError(path);
}

// --- Shipped worlds -------------------------------------------------------------------------------

TEST(ShippedWorlds, AllLoad)
{
  const std::vector<std::string> worlds = shippedWorlds();
  EXPECT_NE(std::find(worlds.begin(), worlds.end(), kWorldDir + "paper_forest.yaml"), worlds.end());
  EXPECT_NE(std::find(worlds.begin(), worlds.end(), kWorldDir + "dense_forest.yaml"), worlds.end());
  for (const std::string& path : worlds)
  {
    ForestWorld world;
    EXPECT_NO_THROW(world = loadForestWorld(path)) << path;
    EXPECT_FALSE(world.trunks.empty()) << path;
  }
}

TEST(ShippedWorlds, PaperForestIsTheScenarioStand)
{
  // The 16 trunks of the reference scenario's tree list (x y radius).
  const double expected[16][3] = {
    { 1.391, 7.417, 0.172 },   { 2.702, 22.942, 0.247 }, { 3.977, 11.912, 0.250 }, { 4.667, 3.012, 0.119 },
    { 8.419, 26.358, 0.231 },  { 8.740, 1.880, 0.248 },  { 11.302, 12.354, 0.110 }, { 12.546, 18.753, 0.222 },
    { 13.170, 5.469, 0.129 },  { 15.547, 2.064, 0.212 }, { 15.886, 13.393, 0.147 }, { 21.830, 12.799, 0.202 },
    { 22.404, 27.825, 0.217 }, { 23.731, 4.704, 0.212 }, { 25.110, 22.308, 0.146 }, { 26.690, 18.377, 0.165 },
  };
  const ForestWorld world = loadForestWorld(kWorldDir + "paper_forest.yaml");
  ASSERT_EQ(world.trunks.size(), 16u);
  for (int i = 0; i < 16; ++i)
  {
    EXPECT_EQ(world.trunks[i].x, expected[i][0]) << i;
    EXPECT_EQ(world.trunks[i].y, expected[i][1]) << i;
    EXPECT_EQ(world.trunks[i].radius, expected[i][2]) << i;
  }
  // The reference realism: stand 30 x 30 m, ground +-0.3 m, bushes and fallen branches between the trunks.
  EXPECT_EQ(world.min_x, 0.0);
  EXPECT_EQ(world.min_y, 0.0);
  EXPECT_EQ(world.max_x, 30.0);
  EXPECT_EQ(world.max_y, 30.0);
  EXPECT_DOUBLE_EQ(world.ground.amplitude, 0.3);
  EXPECT_GT(world.foliage.size(), world.trunks.size());  // crowns and bushes
  EXPECT_FALSE(world.branches.empty());

  // Where the shared scenarios are at hand, the copy must be byte-for-byte.
  const std::string shared = std::string(RBPF_SLAM_SOURCE_DIR) + "/../shared/scenarios/paper_forest.trees.txt";
  if (access(shared.c_str(), R_OK) == 0)
  {
    EXPECT_EQ(readFile(shared), readFile(kWorldDir + "paper_forest.trees.txt"));
  }
}

TEST(ShippedWorlds, DenseForestKeepsTheDriveOpen)
{
  const ForestWorld world = loadForestWorld(kWorldDir + "dense_forest.yaml");
  ASSERT_GE(world.trunks.size(), 120u);
  EXPECT_EQ(world.max_x - world.min_x, 30.0);
  EXPECT_EQ(world.max_y - world.min_y, 30.0);
  for (std::size_t i = 0; i < world.trunks.size(); ++i)
  {
    const TrunkSpec& t = world.trunks[i];
    EXPECT_GE(t.radius, 0.10);
    EXPECT_LE(t.radius, 0.30);
    EXPECT_GE(std::fabs(t.y - 15.0) - t.radius, 1.5) << "trunk " << i << " blocks the drive along y = 15";
    for (std::size_t j = i + 1; j < world.trunks.size(); ++j)
      EXPECT_GE(std::hypot(t.x - world.trunks[j].x, t.y - world.trunks[j].y), 1.5) << i << ", " << j;
  }
  EXPECT_DOUBLE_EQ(world.ground.amplitude, 0.3);
  EXPECT_FALSE(world.branches.empty());
}

// --- Boxes ----------------------------------------------------------------------------------------

TEST_F(WorldFileTest, BoxesComeFromAListFileOrInline)
{
  write("park.trees.txt", "10 10 0.2\n");
  write("park.boxes.txt", "# x y yaw_deg [length width height]\n"
                          "20 5 90\n"
                          "30 6 0 6.0 2.5 3.0   # a van\n");
  const ForestWorld from_file = loadForestWorld(write("park.yaml", "trees: park.trees.txt\nboxes: park.boxes.txt\n"
                                                                    "bounds: [0, 0, 50, 50]\n"));
  ASSERT_EQ(from_file.boxes.size(), 2u);
  EXPECT_EQ(from_file.boxes[0].x, 20.0);
  EXPECT_EQ(from_file.boxes[0].y, 5.0);
  EXPECT_NEAR(from_file.boxes[0].yaw, M_PI / 2, 1e-12);
  EXPECT_EQ(from_file.boxes[0].length, 4.5);  // a car by default
  EXPECT_EQ(from_file.boxes[0].width, 1.8);
  EXPECT_EQ(from_file.boxes[0].height, 1.5);
  EXPECT_EQ(from_file.boxes[1].length, 6.0);
  EXPECT_EQ(from_file.boxes[1].width, 2.5);
  EXPECT_EQ(from_file.boxes[1].height, 3.0);

  const ForestWorld inline_boxes =
      loadForestWorld(write("inline.yaml", "trees: [[10, 10, 0.2]]\nboxes: [[1, 2, 45], [3, 4, 0, 1, 1, 1]]\n"));
  ASSERT_EQ(inline_boxes.boxes.size(), 2u);
  EXPECT_NEAR(inline_boxes.boxes[0].yaw, M_PI / 4, 1e-12);
  EXPECT_EQ(inline_boxes.boxes[1].height, 1.0);

  EXPECT_TRUE(loadForestWorld(write("none.yaml", "trees: [[10, 10, 0.2]]\n")).boxes.empty());
}

TEST_F(WorldFileTest, ABadBoxNamesFileLineAndReason)
{
  write("t.txt", "10 10 0.2\n");
  write("bad.boxes.txt", "20 5 90\n20 5 90 4.5\n");
  const std::string error = loadError(write("bad.yaml", "trees: t.txt\nboxes: bad.boxes.txt\n"));
  EXPECT_NE(error.find("bad.boxes.txt:2: expected 'x y yaw_deg [length width height]'"), std::string::npos) << error;
  EXPECT_NE(error.find("give all of length, width and height or none"), std::string::npos) << error;
  write("neg.boxes.txt", "20 5 90 4.5 -1 1\n");
  EXPECT_NE(loadError(write("neg.yaml", "trees: t.txt\nboxes: neg.boxes.txt\n")).find("must be > 0"),
            std::string::npos);
  EXPECT_NE(loadError(write("missing.yaml", "trees: t.txt\nboxes: nowhere.txt\n")).find("cannot open box list"),
            std::string::npos);
  EXPECT_NE(loadError(write("inl.yaml", "trees: t.txt\nboxes: [[1, 2]]\n")).find("'boxes[0]'"), std::string::npos);
}

TEST(ShippedWorlds, ParkCarsAreABoxList)
{
  const std::vector<rbpf_slam::sim::BoxSpec> cars = rbpf_slam::sim::loadBoxList(kWorldDir + "park.cars.txt");
  ASSERT_FALSE(cars.empty());
  EXPECT_EQ(cars[0].x, 77.331);
  EXPECT_EQ(cars[0].length, 4.5);
}

TEST(ShippedWorlds, RealisticVariantsKeepTheCleanStandsTrees)
{
  for (const char* name : { "paper_forest", "dense_forest", "clumped", "plantation_rows", "sparse_stand",
                            "touching_pairs" })
  {
    const ForestWorld clean = loadForestWorld(kWorldDir + name + ".yaml");
    const ForestWorld real = loadForestWorld(kWorldDir + name + "_realistic.yaml");
    // The clean stand is the ideal case: no branches on its stems, no understory, no slope.
    EXPECT_TRUE(clean.stubs.empty()) << name;
    EXPECT_TRUE(clean.saplings.empty()) << name;
    EXPECT_EQ(clean.ground.slope, Eigen::Vector2d::Zero()) << name;
    ASSERT_EQ(real.trunks.size(), clean.trunks.size()) << name;
    EXPECT_EQ(real.min_x, clean.min_x);
    EXPECT_EQ(real.max_y, clean.max_y);
    for (std::size_t i = 0; i < real.trunks.size(); ++i)
    {
      // The same trees at breast height: the tree list's centre (the clean stem's within its 1-degree lean) and the
      // clean stem's radius there.
      double r_real = 0.0, r_clean = 0.0;
      const Eigen::Vector3d c_real = rbpf_slam::sim::trunkAxisAt(real.trunks[i], 0.0, 1.3, &r_real);
      const Eigen::Vector3d c_clean = rbpf_slam::sim::trunkAxisAt(clean.trunks[i], 0.0, 1.3, &r_clean);
      EXPECT_NEAR(c_real.x(), clean.trunks[i].x, 1e-9) << name << " " << i;
      EXPECT_NEAR(c_real.y(), clean.trunks[i].y, 1e-9) << name << " " << i;
      EXPECT_LT((c_real - c_clean).head<2>().norm(), 0.1) << name << " " << i;
      EXPECT_NEAR(r_real, r_clean, 1e-4) << name << " " << i;
      // Leaning 2-4 degrees (the scenarios allow up to 5), tapering.
      const double lean_deg = std::atan(std::hypot(real.trunks[i].lean_x, real.trunks[i].lean_y)) * 180.0 / M_PI;
      EXPECT_GE(lean_deg, 2.0 - 1e-9) << name << " " << i;
      EXPECT_LE(lean_deg, 4.0 + 1e-9) << name << " " << i;
      EXPECT_GT(real.trunks[i].taper, 0.0) << name << " " << i;
    }
    // Sloping 10 %, relief +-0.5 m; branches on the stems, saplings (no trees: DBH < 8 cm), shrubs, fallen wood.
    EXPECT_NEAR(real.ground.slope.norm(), 0.10, 1e-12) << name;
    EXPECT_EQ(real.ground.amplitude, 0.5) << name;
    EXPECT_GT(real.stubs.size(), 5 * real.trunks.size()) << name;
    EXPECT_FALSE(real.saplings.empty()) << name;
    for (const TrunkSpec& s : real.saplings)
    {
      double r = 0.0;
      rbpf_slam::sim::trunkAxisAt(s, 0.0, 1.3, &r);
      EXPECT_LT(2.0 * r, 0.08) << name;
    }
    EXPECT_GT(real.foliage.size(), clean.foliage.size() + real.saplings.size()) << name;
    EXPECT_GE(real.branches.size(), clean.branches.size()) << name;
  }
}

/** The horizontal distance from the segment a-b to the nearest route, sampled (independent of the code under test). */
double routeDistance(const std::vector<std::vector<Eigen::Vector2d>>& routes, const Eigen::Vector2d& a,
                     const Eigen::Vector2d& b)
{
  double best = 1e300;
  for (int k = 0; k <= 20; ++k)
  {
    const Eigen::Vector2d p = a + (b - a) * (k / 20.0);
    for (const auto& route : routes)
      for (std::size_t i = 1; i < route.size(); ++i)
      {
        const Eigen::Vector2d u = route[i] - route[i - 1];
        const double t = std::max(0.0, std::min(1.0, (p - route[i - 1]).dot(u) / u.squaredNorm()));
        best = std::min(best, (p - route[i - 1] - t * u).norm());
      }
  }
  return best;
}

/** Whether foliage @p f is a sapling's crown sphere (its centre on the sapling's axis). */
bool onASapling(const ForestWorld& world, const rbpf_slam::sim::FoliageSpec& f)
{
  for (const TrunkSpec& s : world.saplings)
  {
    const Eigen::Vector2d d = f.center.head<2>() - Eigen::Vector2d(s.x, s.y), lean(s.lean_x, s.lean_y);
    const double t = lean.squaredNorm() > 0.0 ? d.dot(lean) / lean.squaredNorm() : 0.0;
    if ((d - t * lean).norm() < 1e-9)
      return true;
  }
  return false;
}

TEST(ShippedWorlds, RealisticStandsKeepTheirUnderstoryOffTheDrives)
{
  struct Stand
  {
    const char* name;
    std::size_t saplings;
    std::size_t low_foliage;  ///< bushes and shrubs (the world file's counts)
  };
  // Every sapling and shrub the world files ask for; the dense stand has room off the track for 11 of its 12 bushes.
  const std::vector<Stand> stands = { { "paper_forest", 25, 12 + 35 },    { "dense_forest", 15, 11 + 20 },
                                      { "clumped", 45, 21 + 60 },         { "plantation_rows", 30, 21 + 40 },
                                      { "sparse_stand", 110, 40 + 140 }, { "touching_pairs", 25, 12 + 35 } };
  for (const Stand& stand : stands)
  {
    const std::string name = stand.name;
    EXPECT_TRUE(loadForestWorld(kWorldDir + name + ".yaml").track.routes.empty()) << name;  // the clean stand
    const ForestWorld world = loadForestWorld(kWorldDir + name + "_realistic.yaml");
    // The straight drive and the loop from the simulator's start (0, 15) heading +x, the sparse stand's square too.
    std::vector<std::vector<Eigen::Vector2d>> routes = { rbpf_slam::sim::straightDrive(),
                                                         rbpf_slam::sim::loopDrive() };
    if (name == "sparse_stand")
      routes.push_back(rbpf_slam::sim::readWaypoints(kSourceDir + "/config/sim/sparse_loop.txt"));
    for (auto& route : routes)
      for (Eigen::Vector2d& p : route)
        p.y() += 15.0;
    ASSERT_EQ(world.track.routes.size(), routes.size()) << name;
    for (std::size_t r = 0; r < routes.size(); ++r)
      EXPECT_NEAR((world.track.routes[r].back() - routes[r].back()).norm(), 0.0, 1e-9) << name;
    const double clearance = 2.0, headroom = 3.0;
    EXPECT_EQ(world.track.clearance, clearance) << name;
    EXPECT_EQ(world.track.headroom, headroom) << name;
    EXPECT_EQ(world.saplings.size(), stand.saplings) << name;
    for (const TrunkSpec& s : world.saplings)
      EXPECT_GE(routeDistance(routes, Eigen::Vector2d(s.x, s.y), Eigen::Vector2d(s.x, s.y)), clearance) << name;
    for (const auto& r : world.rocks)
      EXPECT_GE(routeDistance(routes, r.center.head<2>(), r.center.head<2>()) - r.radius, clearance) << name;
    // Branches lower than the headroom (with their tufts) keep off; a tuft is checked with its branch.
    std::vector<Eigen::Vector2d> tips;
    for (const auto& b : world.stubs)
    {
      double reach = b.radius;
      for (const auto& f : world.foliage)
        if (b.live && (f.center.head<2>() - b.b.head<2>()).norm() < 1e-9)
          reach = std::max(reach, f.radius);
      tips.push_back(b.b.head<2>());
      if (std::min(b.a.z(), b.b.z()) - reach < headroom)
      {
        EXPECT_GE(routeDistance(routes, b.b.head<2>(), b.b.head<2>()) - reach, clearance) << name;
      }
    }
    // Bushes, shrubs and sapling crowns (the other foliage lower than the crowns of the trees, from 5 m up).
    std::size_t low_foliage = 0;
    for (const auto& f : world.foliage)
    {
      if (std::find(tips.begin(), tips.end(), f.center.head<2>()) != tips.end() || f.center.z() - f.radius >= 4.0)
        continue;
      EXPECT_GE(routeDistance(routes, f.center.head<2>(), f.center.head<2>()) - f.radius, clearance - 1e-6) << name;
      low_foliage += onASapling(world, f) ? 0 : 1;
    }
    EXPECT_EQ(low_foliage, stand.low_foliage) << name;
  }
}

TEST(ShippedWorlds, GeneratedStandsKeepBothDrivesOpen)
{
  // The straight drive runs along y = 15, the loop circles (15, 15) at 8.5 m: no trunk surface within 1.5 m.
  for (const char* name : { "touching_pairs.yaml", "clumped.yaml", "plantation_rows.yaml" })
  {
    const ForestWorld world = loadForestWorld(kWorldDir + name);
    ASSERT_GE(world.trunks.size(), 30u) << name;
    for (const TrunkSpec& t : world.trunks)
    {
      EXPECT_GE(std::fabs(t.y - 15.0) - t.radius, 1.5) << name << ": (" << t.x << ", " << t.y << ")";
      EXPECT_GE(std::fabs(std::hypot(t.x - 15.0, t.y - 15.0) - 8.5) - t.radius, 1.5)
          << name << ": (" << t.x << ", " << t.y << ")";
    }
  }
  // Twelve pairs whose bark gap at breast height (the list's radii are at the ground, taper 0.01) is 2-10 cm.
  const ForestWorld pairs = loadForestWorld(kWorldDir + "touching_pairs.yaml");
  int touching = 0;
  for (std::size_t i = 0; i < pairs.trunks.size(); ++i)
    for (std::size_t j = i + 1; j < pairs.trunks.size(); ++j)
    {
      const TrunkSpec &a = pairs.trunks[i], &b = pairs.trunks[j];
      const double gap = std::hypot(a.x - b.x, a.y - b.y) - a.radius - b.radius + 2.0 * 1.3 * 0.01;
      if (gap < 0.5)
      {
        ++touching;
        EXPECT_GE(gap, 0.02 - 1e-9);
        EXPECT_LE(gap, 0.10 + 1e-9);
      }
    }
  EXPECT_EQ(touching, 12);
}
