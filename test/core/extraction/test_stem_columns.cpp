// The stem finder by vertical continuity on synthetic clouds whose stems are known.
#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/extraction/stem_columns.h"
#include "rbpf_slam/core/filter/random.h"

using rbpf_slam::core::clusterSlice;
using rbpf_slam::core::findStems;
using rbpf_slam::core::fitStemCircles;
using rbpf_slam::core::GroundGrid;
using rbpf_slam::core::linkColumns;
using rbpf_slam::core::lowestDenseHeight;
using rbpf_slam::core::Random;
using rbpf_slam::core::Stem;
using rbpf_slam::core::StemCircle;
using rbpf_slam::core::StemColumnsConfig;
using rbpf_slam::core::StemColumnsStats;

namespace
{
constexpr double kPi = 3.14159265358979323846;
using Cloud = std::vector<Eigen::Vector3f>;

double groundAt(double x, double y)
{
  return 0.2 + 0.05 * x - 0.03 * y;  // a gentle slope
}

/** Ground points every 5 cm over the square of half side @p half around the origin. */
void addGround(double half, Random& rnd, Cloud* cloud)
{
  for (double x = -half; x <= half; x += 0.05)
    for (double y = -half; y <= half; y += 0.05)
      cloud->emplace_back(x, y, groundAt(x, y) + rnd.gaussian(0.01));
}

/** A stem: a leaning, tapering cylinder of radius @p r_bh at 1.3 m above the ground; @p arc its visible angle. */
struct StemSpec
{
  double x = 0.0, y = 0.0;  // axis at the ground
  double r_bh = 0.15;       // [m]
  double taper = 0.01;      // [m] less radius per metre up
  double lean_deg = 0.0;
  double lean_dir = 0.0;   // [rad]
  double height = 4.0;     // [m] above the ground
  double arc = 2.0 * kPi;  // [rad] visible, centred on arc_dir
  double arc_dir = 0.0;    // [rad]
};

Eigen::Vector2d axisAt(const StemSpec& s, double h)
{
  const double t = std::tan(s.lean_deg * kPi / 180.0) * h;
  return { s.x + t * std::cos(s.lean_dir), s.y + t * std::sin(s.lean_dir) };
}

double radiusAt(const StemSpec& s, double h)
{
  return s.r_bh + s.taper * (1.3 - h);
}

void addStem(const StemSpec& s, Random& rnd, Cloud* cloud)
{
  const double g = groundAt(s.x, s.y);
  for (double h = 0.0; h <= s.height; h += 0.02)
  {
    const Eigen::Vector2d c = axisAt(s, h);
    const double r = radiusAt(s, h);
    const int n = std::max(12, static_cast<int>(s.arc * r / 0.01));
    for (int i = 0; i < n; ++i)
    {
      const double a = s.arc_dir - 0.5 * s.arc + s.arc * (i + rnd.uniform()) / n;
      const double rr = r + rnd.gaussian(0.003);
      cloud->emplace_back(c.x() + rr * std::cos(a), c.y() + rr * std::sin(a), g + h + rnd.gaussian(0.005));
    }
  }
}

/** A whorl of @p count branches leaving the stem at height @p h, 0.8 m long, 2 cm thick, rising a little. */
void addWhorl(const StemSpec& s, double h, int count, Random& rnd, Cloud* cloud)
{
  const double g = groundAt(s.x, s.y);
  const Eigen::Vector2d c = axisAt(s, h);
  for (int b = 0; b < count; ++b)
  {
    const double a = 2.0 * kPi * (b + 0.3 * rnd.uniform()) / count;
    for (double t = radiusAt(s, h); t < 0.8; t += 0.01)
      for (int k = 0; k < 6; ++k)
        cloud->emplace_back(c.x() + t * std::cos(a) + rnd.gaussian(0.01), c.y() + t * std::sin(a) + rnd.gaussian(0.01),
                            g + h + 0.3 * t + rnd.gaussian(0.01));
  }
}

/** A shrub: random points in an ellipsoid of radius @p r and height @p top above the ground at (x, y). */
void addShrub(double x, double y, double r, double top, int n, Random& rnd, Cloud* cloud)
{
  const double g = groundAt(x, y);
  for (int i = 0; i < n; ++i)
  {
    const double a = rnd.uniform(0.0, 2.0 * kPi), d = r * std::sqrt(rnd.uniform());
    const double z = top * rnd.uniform();
    const double shrink = std::sqrt(std::max(0.0, 1.0 - std::pow((z - 0.5 * top) / (0.5 * top), 2)));
    cloud->emplace_back(x + shrink * d * std::cos(a), y + shrink * d * std::sin(a), g + z);
  }
}

void expectStem(const Stem& found, const StemSpec& s)
{
  const Eigen::Vector2d c = axisAt(s, 1.3);
  EXPECT_NEAR(found.dbh, 2.0 * s.r_bh, 0.01);
  EXPECT_NEAR(found.center.x(), c.x(), 0.02);
  EXPECT_NEAR(found.center.y(), c.y(), 0.02);
  EXPECT_GE(found.dbh_sigma, 0.0);
  EXPECT_LT(found.dbh_sigma, 0.02);
  EXPECT_GT(found.points, 100);
  EXPECT_LT(found.z_min, found.z_max);
}

std::vector<Eigen::Vector3f> ringSlice(const Eigen::Vector2d& c, double r, double a0, double a1, Random& rnd)
{
  Cloud cloud;
  for (double a = a0; a < a1; a += 0.01 / r)
    for (double z = -0.05; z <= 0.05; z += 0.02)
      cloud.emplace_back(c.x() + (r + rnd.gaussian(0.002)) * std::cos(a),
                         c.y() + (r + rnd.gaussian(0.002)) * std::sin(a), 1.3 + z);
  return cloud;
}
}  // namespace

TEST(StemColumns, DefaultsAreValidAndBadSettingsAreNamed)
{
  StemColumnsConfig c;
  EXPECT_EQ(c.validate(), "");
  c.slice_thickness = 0.5;
  EXPECT_NE(c.validate().find("slice_thickness"), std::string::npos);
  c = StemColumnsConfig();
  c.min_dbh = 0.5;
  c.max_dbh = 0.3;
  EXPECT_NE(c.validate().find("max_dbh"), std::string::npos);
  c = StemColumnsConfig();
  c.min_slices = 2;
  EXPECT_NE(c.validate().find("min_slices"), std::string::npos);
  c = StemColumnsConfig();
  c.has_sensor = true;
  c.sensor.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(c.validate().find("sensor"), std::string::npos);
  EXPECT_THROW(findStems(Cloud(), c), std::invalid_argument);
}

TEST(StemColumns, GroundIsTheLowestDenseHeightNotAStrayPointBelow)
{
  std::vector<float> z = { 5.0f, 0.31f, -2.0f, 0.30f, 0.33f, 1.5f, 3.0f };
  EXPECT_FLOAT_EQ(lowestDenseHeight(z.data(), z.size(), 3, 0.1), (0.30f + 0.31f + 0.33f) / 3.0f);
  std::vector<float> two = { 0.5f, 0.2f };
  EXPECT_FLOAT_EQ(lowestDenseHeight(two.data(), two.size(), 3, 0.1), 0.2f);
  EXPECT_TRUE(std::isnan(lowestDenseHeight(nullptr, 0, 3, 0.1)));
}

TEST(StemColumns, GroundUnderAStemIsTheGroundAroundIt)
{
  Random rnd(3);
  Cloud cloud;
  addGround(3.0, rnd, &cloud);
  // A wide stem whose cell shows no ground: its points start 0.8 m up (a shrub hid its foot).
  StemSpec s;
  s.r_bh = 0.3;
  addStem(s, rnd, &cloud);
  cloud.erase(std::remove_if(cloud.begin(), cloud.end(),
                             [](const Eigen::Vector3f& p) { return std::hypot(p.x(), p.y()) < 0.45 && p.z() < 1.0; }),
              cloud.end());
  GroundGrid ground;
  ground.build(cloud, StemColumnsConfig());
  for (const auto& q : { Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(2.0, -1.5), Eigen::Vector2d(-2.7, 2.7) })
    EXPECT_NEAR(ground.heightAt(q.x(), q.y()), groundAt(q.x(), q.y()), 0.06) << q.transpose();
  StemColumnsConfig with_prior;
  with_prior.ground_height = -1.0;
  ground.build(Cloud(), with_prior);
  EXPECT_DOUBLE_EQ(ground.heightAt(5.0, 5.0), -1.0);
}

TEST(StemColumns, ClustersOfASliceAreConnectedCells)
{
  Cloud slice = { { 0.0f, 0.0f, 1.0f },  { 0.03f, 0.0f, 1.0f },  { 0.06f, 0.01f, 1.0f }, { 1.0f, 1.0f, 1.0f },
                  { 1.02f, 1.0f, 1.0f }, { 1.04f, 1.01f, 1.0f }, { -3.0f, 0.0f, 1.0f } };
  const auto clusters = clusterSlice(slice, 0.04, 2);
  ASSERT_EQ(clusters.size(), 2u);
  EXPECT_EQ(clusters[0].size() + clusters[1].size(), 6u);
}

TEST(StemColumns, AFullRingAndAHalfRingBothFit)
{
  Random rnd(5);
  StemColumnsConfig cfg;
  for (double arc : { 2.0 * kPi, kPi })
  {
    Cloud cluster = ringSlice({ 2.0, -1.0 }, 0.12, 0.3, 0.3 + arc, rnd);
    // Clutter on the ring: a branch stub leaving it.
    for (double t = 0.12; t < 0.5; t += 0.005)
      cluster.emplace_back(2.0 + t, -1.0 + 0.02 * rnd.gaussian(), 1.3f);
    Random rng(cfg.seed);
    const auto circles = fitStemCircles(cluster, 3, 1.25, cfg, &rng);
    ASSERT_EQ(circles.size(), 1u) << "arc " << arc;
    EXPECT_NEAR(circles[0].radius, 0.12, 0.004);
    EXPECT_NEAR(circles[0].center.x(), 2.0, 0.005);
    EXPECT_NEAR(circles[0].center.y(), -1.0, 0.005);
    EXPECT_EQ(circles[0].slice, 3);
    EXPECT_GE(circles[0].coverage, arc / (2.0 * kPi) - 0.1);
  }
}

TEST(StemColumns, ASolidBlobIsNoRing)
{
  Random rnd(6);
  Cloud blob;
  for (int i = 0; i < 2000; ++i)
  {
    const double a = rnd.uniform(0.0, 2.0 * kPi), d = 0.2 * std::sqrt(rnd.uniform());
    blob.emplace_back(d * std::cos(a), d * std::sin(a), 1.3f);
  }
  StemColumnsConfig cfg;
  Random rng(cfg.seed);
  EXPECT_TRUE(fitStemCircles(blob, 0, 1.3, cfg, &rng).empty());
}

TEST(StemColumns, ColumnsLinkCirclesOfOneStemAndKeepTwoStemsApart)
{
  std::vector<StemCircle> circles;
  for (int k = 0; k < 6; ++k)
    for (double x : { 0.0, 1.0 })
    {
      StemCircle c;
      c.slice = k;
      c.height = 0.5 + 0.25 * k;
      c.center = Eigen::Vector2d(x + 0.01 * k, 0.0);
      c.radius = 0.1 - 0.002 * k;
      circles.push_back(c);
    }
  const auto columns = linkColumns(circles, StemColumnsConfig());
  ASSERT_EQ(columns.size(), 2u);
  EXPECT_EQ(columns[0].size(), 6u);
  EXPECT_EQ(columns[1].size(), 6u);
}

TEST(StemColumns, ALeaningTaperedStemAmongWhorlsAndAShrubIsOneStem)
{
  Random rnd(7);
  Cloud cloud;
  addGround(3.0, rnd, &cloud);
  StemSpec s;
  s.x = 0.3;
  s.y = -0.2;
  s.r_bh = 0.14;
  s.taper = 0.012;
  s.lean_deg = 4.0;
  s.lean_dir = 0.7;
  s.height = 6.0;
  addStem(s, rnd, &cloud);
  for (double h : { 1.0, 1.9, 2.8, 3.7 })
    addWhorl(s, h, 5, rnd, &cloud);
  addShrub(s.x - 0.55, s.y + 0.1, 0.4, 1.4, 6000, rnd, &cloud);
  StemColumnsStats stats;
  const auto stems = findStems(cloud, StemColumnsConfig(), &stats);
  ASSERT_EQ(stems.size(), 1u);
  expectStem(stems[0], s);
  EXPECT_NEAR(stems[0].lean_deg, 4.0, 1.5);
  EXPECT_NEAR(stems[0].ground, groundAt(s.x, s.y), 0.05);
  EXPECT_EQ(stats.finite_points, cloud.size());
  EXPECT_EQ(stats.stems, 1);
  // The same cloud gives the same stem (seeded RANSAC).
  const auto again = findStems(cloud, StemColumnsConfig());
  ASSERT_EQ(again.size(), 1u);
  EXPECT_EQ(again[0].dbh, stems[0].dbh);
  EXPECT_EQ(again[0].center, stems[0].center);
}

TEST(StemColumns, TwoStemsAMetreApartStayTwo)
{
  Random rnd(8);
  Cloud cloud;
  addGround(2.5, rnd, &cloud);
  StemSpec a, b;
  a.x = -0.5;
  a.r_bh = 0.12;
  b.x = 0.5;
  b.r_bh = 0.2;
  addStem(a, rnd, &cloud);
  addStem(b, rnd, &cloud);
  const auto stems = findStems(cloud, StemColumnsConfig());
  ASSERT_EQ(stems.size(), 2u);
  expectStem(stems[0], a);  // sorted by x
  expectStem(stems[1], b);
}

TEST(StemColumns, AnEightCentimetreStemIsFound)
{
  Random rnd(9);
  Cloud cloud;
  addGround(2.0, rnd, &cloud);
  StemSpec s;
  s.x = 0.4;
  s.y = 0.9;
  s.r_bh = 0.04;
  s.taper = 0.005;
  addStem(s, rnd, &cloud);
  const auto stems = findStems(cloud, StemColumnsConfig());
  ASSERT_EQ(stems.size(), 1u);
  expectStem(stems[0], s);
}

TEST(StemColumns, AStemSeenFromOneSideIsFoundWithItsSensor)
{
  Random rnd(10);
  Cloud cloud;
  addGround(3.0, rnd, &cloud);
  StemSpec s;
  s.x = 1.0;
  s.r_bh = 0.16;
  s.arc = 0.9 * kPi;
  s.arc_dir = kPi;  // the sensor stands at -x
  addStem(s, rnd, &cloud);
  StemColumnsConfig cfg;
  cfg.has_sensor = true;
  cfg.sensor = Eigen::Vector3d(-4.0, 0.0, 1.8);
  const auto stems = findStems(cloud, cfg);
  ASSERT_EQ(stems.size(), 1u);
  expectStem(stems[0], s);
  // Seen from behind, that arc would be a hollow facing away: no stem.
  cfg.sensor = Eigen::Vector3d(6.0, 0.0, 1.8);
  EXPECT_TRUE(findStems(cloud, cfg).empty());
}

TEST(StemColumns, ABushySaplingOrABranchClumpIsNoStem)
{
  Random rnd(11);
  Cloud sapling;
  addGround(2.0, rnd, &sapling);
  StemSpec thin;  // a 2 cm sapling, below the smallest DBH, in a dense crown of leaves
  thin.r_bh = 0.01;
  thin.taper = 0.0;
  thin.height = 2.5;
  addStem(thin, rnd, &sapling);
  addShrub(0.0, 0.0, 0.45, 2.6, 30000, rnd, &sapling);
  EXPECT_TRUE(findStems(sapling, StemColumnsConfig()).empty());

  Cloud clump;
  addGround(2.0, rnd, &clump);
  for (int b = 0; b < 40; ++b)  // branches in every direction between 0.3 and 3 m
  {
    const Eigen::Vector3d start(rnd.uniform(-0.6, 0.6), rnd.uniform(-0.6, 0.6), rnd.uniform(0.3, 3.0));
    const Eigen::Vector3d dir = Eigen::Vector3d(rnd.gaussian(), rnd.gaussian(), 0.5 * rnd.gaussian()).normalized();
    for (double t = 0.0; t < 1.0; t += 0.005)
    {
      const Eigen::Vector3d p = start + t * dir;
      clump.emplace_back(p.x() + rnd.gaussian(0.01), p.y() + rnd.gaussian(0.01), p.z() + groundAt(p.x(), p.y()));
    }
  }
  EXPECT_TRUE(findStems(clump, StemColumnsConfig()).empty());
}

TEST(StemColumns, EmptyAndNonFiniteCloudsGiveNoStemAndNaNPointsAreSkipped)
{
  StemColumnsStats stats;
  EXPECT_TRUE(findStems(Cloud(), StemColumnsConfig(), &stats).empty());
  EXPECT_EQ(stats.finite_points, 0u);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  Cloud bad(100, Eigen::Vector3f(nan, 0.0f, 1.0f));
  bad.emplace_back(0.0f, inf, 0.0f);
  EXPECT_TRUE(findStems(bad, StemColumnsConfig(), &stats).empty());
  EXPECT_EQ(stats.input_points, 101u);
  EXPECT_EQ(stats.finite_points, 0u);

  Random rnd(12);
  Cloud cloud;
  addGround(2.0, rnd, &cloud);
  StemSpec s;
  addStem(s, rnd, &cloud);
  for (std::size_t i = 0; i < cloud.size(); i += 50)
    cloud[i].z() = nan;
  double last = -1.0;
  const auto stems = findStems(cloud, StemColumnsConfig(), &stats,
                               [&](double share)
                               {
                                 EXPECT_GE(share, last);
                                 last = share;
                               });
  ASSERT_EQ(stems.size(), 1u);
  expectStem(stems[0], s);
  EXPECT_DOUBLE_EQ(last, 1.0);
  EXPECT_LT(stats.finite_points, stats.input_points);
}
