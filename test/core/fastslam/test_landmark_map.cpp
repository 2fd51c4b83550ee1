// LandmarkMap: the spatial index against a brute-force scan, and copy-on-write independence.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "rbpf_slam/core/fastslam/landmark_map.h"

using namespace rbpf_slam::core;

namespace
{
std::vector<std::size_t> bruteForce(const std::vector<Landmark>& model, const Eigen::Vector2d& c, double r)
{
  std::vector<std::size_t> out;
  for (std::size_t j = 0; j < model.size(); ++j)
    if ((model[j].mean - c).squaredNorm() <= r * r)
      out.push_back(j);
  return out;
}

/** The same operations on a LandmarkMap and on a plain vector (the model). */
struct Pair
{
  LandmarkMap map;
  std::vector<Landmark> model;

  void add(const Landmark& l)
  {
    map.add(l);
    model.push_back(l);
  }
  void remove(std::size_t i)
  {
    map.remove(i);
    model[i] = model.back();
    model.pop_back();
  }
  void move(std::size_t i, const Eigen::Vector2d& to)
  {
    map.modify(i, [&](Landmark& l) { l.mean = to; });
    model[i].mean = to;
  }
};

void expectSame(const Pair& p)
{
  ASSERT_EQ(p.map.size(), p.model.size());
  for (std::size_t j = 0; j < p.model.size(); ++j)
  {
    ASSERT_EQ(p.map[j].id, p.model[j].id) << j;
    ASSERT_EQ(p.map[j].mean, p.model[j].mean) << j;
    ASSERT_EQ(p.map[j].evidence, p.model[j].evidence) << j;
  }
}

/** Random operation: add (60 %), remove (15 %), move a landmark (25 %, often across a tile border). */
void randomOperation(Pair* p, std::mt19937_64& rng, int* next_id, double extent)
{
  std::uniform_real_distribution<double> pos(-extent, extent), step(-10.0, 10.0), u(0.0, 1.0);
  const double op = u(rng);
  if (p->model.empty() || op < 0.6)
  {
    Landmark l;
    l.mean = Eigen::Vector2d(pos(rng), pos(rng));
    l.id = (*next_id)++;
    p->add(l);
  }
  else if (op < 0.75)
    p->remove(std::uniform_int_distribution<std::size_t>(0, p->model.size() - 1)(rng));
  else
  {
    const std::size_t i = std::uniform_int_distribution<std::size_t>(0, p->model.size() - 1)(rng);
    p->move(i, p->model[i].mean + Eigen::Vector2d(step(rng), step(rng)));
  }
}
}  // namespace

TEST(LandmarkMap, NearReturnsExactlyWhatABruteForceScanReturns)
{
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 20; ++trial)
  {
    Pair p;
    int id = 0;
    const double extent = trial % 2 ? 100.0 : 20.0;  // sparse and dense maps; negative coordinates too
    const int ops = 50 + 50 * trial;
    for (int n = 0; n < ops; ++n)
      randomOperation(&p, rng, &id, extent);
    expectSame(p);
    std::uniform_real_distribution<double> pos(-1.3 * extent, 1.3 * extent), radius(0.0, 30.0);
    std::vector<std::size_t> got;
    for (int q = 0; q < 200; ++q)
    {
      const Eigen::Vector2d c(pos(rng), pos(rng));
      // Radii from zero to wider than the map; exactly on a landmark, on a tile border.
      double r = q % 50 == 0 ? 1e4 : radius(rng);
      Eigen::Vector2d centre = c;
      if (q % 7 == 0 && !p.model.empty())
      {
        centre = p.model[static_cast<std::size_t>(q) % p.model.size()].mean;
        r = q % 14 == 0 ? 0.0 : r;
      }
      if (q % 11 == 0)
        centre = Eigen::Vector2d(8.0 * std::round(c.x() / 8.0), 8.0 * std::round(c.y() / 8.0));
      p.map.near(centre, r, &got);
      ASSERT_EQ(got, bruteForce(p.model, centre, r)) << "trial " << trial << " query " << q;
    }
  }
}

TEST(LandmarkMap, NearIsEmptyOnAnEmptyMapAndForABadRadius)
{
  LandmarkMap m;
  std::vector<std::size_t> got{ 3 };
  m.near(Eigen::Vector2d(0, 0), 10.0, &got);
  EXPECT_TRUE(got.empty());
  Landmark l;
  m.add(l);
  m.near(Eigen::Vector2d(0, 0), std::numeric_limits<double>::quiet_NaN(), &got);
  EXPECT_TRUE(got.empty());
  m.near(Eigen::Vector2d(0, 0), std::numeric_limits<double>::infinity(), &got);
  EXPECT_EQ(got, std::vector<std::size_t>{ 0 });
}

TEST(LandmarkMap, ChangingOneCopyNeverChangesAnother)
{
  // A family of maps copied from each other at random moments (as resampling does), each changed at random;
  // every map must always equal its own model, contents and spatial lookups alike.
  std::mt19937_64 rng(11);
  std::vector<Pair> family(1);
  int id = 0;
  for (int n = 0; n < 300; ++n)
    randomOperation(&family[0], rng, &id, 40.0);
  for (int step = 0; step < 3000; ++step)
  {
    const std::size_t k = std::uniform_int_distribution<std::size_t>(0, family.size() - 1)(rng);
    if (step % 50 == 0 && family.size() < 12)
      family.push_back(family[k]);  // a copy shares every chunk and the index
    else if (step % 97 == 0 && family.size() > 2)
      family[k] = family[(k + 1) % family.size()];  // assignment drops the old sharing
    else
      randomOperation(&family[k], rng, &id, 40.0);
    if (step % 100 == 0)
    {
      std::vector<std::size_t> got;
      for (const Pair& p : family)
      {
        expectSame(p);
        const Eigen::Vector2d c(std::uniform_real_distribution<double>(-40, 40)(rng), 0.0);
        p.map.near(c, 12.5, &got);
        ASSERT_EQ(got, bruteForce(p.model, c, 12.5));
      }
    }
  }
  for (const Pair& p : family)
    expectSame(p);
}

TEST(LandmarkMap, AnUpdateCopiesOnlyTheChunkAndTileItTouches)
{
  LandmarkMap a;
  for (int i = 0; i < 64; ++i)
  {
    Landmark l;
    l.id = i;
    l.mean = Eigen::Vector2d(1.0 * i, 0.5);  // 8 tiles along x
    a.add(l);
  }
  EXPECT_EQ(a.chunks(), 4u);
  EXPECT_EQ(a.tiles(), 8u);
  LandmarkMap b = a;
  EXPECT_EQ(b.sharedChunks(), 4u);
  // Evidence only: one chunk copied, the landmark stays in its tile.
  b.modify(20, [](Landmark& l) { l.evidence = -1.0; });
  EXPECT_EQ(b.sharedChunks(), 3u);
  EXPECT_EQ(a[20].evidence, 0.0);
  // Moving across a tile border: found at its new place in b only.
  b.modify(3, [](Landmark& l) { l.mean.x() = 60.5; });
  std::vector<std::size_t> got;
  b.near(Eigen::Vector2d(60.5, 0.5), 0.1, &got);
  EXPECT_EQ(got, std::vector<std::size_t>{ 3 });
  a.near(Eigen::Vector2d(60.5, 0.5), 0.1, &got);
  EXPECT_TRUE(got.empty());
  a.near(Eigen::Vector2d(3.0, 0.5), 0.1, &got);
  EXPECT_EQ(got, std::vector<std::size_t>{ 3 });
  EXPECT_EQ(b.sharedChunks(), 2u);  // chunk 0 copied too
  EXPECT_EQ(a.sharedChunks(), 2u);
}
