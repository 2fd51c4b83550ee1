// Clustering of a sweep's height band and of a planar scan's arcs, on points whose clusters are known.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/core/filter/random.h"
#include "rbpf_slam/core/extraction/trunk_clustering.h"

using rbpf_slam::core::clusterHorizontal;
using rbpf_slam::core::downsampleVoxels;
using rbpf_slam::core::isArcOccluded;
using rbpf_slam::core::PlanarScan;
using rbpf_slam::core::Random;
using rbpf_slam::core::ScanArc;
using rbpf_slam::core::selectTrunkCandidates;
using rbpf_slam::core::splitScanIntoArcs;
using rbpf_slam::core::TrunkDetectorConfig;
using rbpf_slam::core::TrunkDetectorStats;

namespace
{
/** Which cluster each point is in. */
std::vector<int> labels(const std::vector<std::vector<int>>& clusters, std::size_t n)
{
  std::vector<int> label(n, -1);
  for (std::size_t c = 0; c < clusters.size(); ++c)
    for (int i : clusters[c])
    {
      EXPECT_EQ(label[static_cast<std::size_t>(i)], -1) << "point " << i << " in two clusters";
      label[static_cast<std::size_t>(i)] = static_cast<int>(c);
    }
  return label;
}

/**
 * The definition, brute force: one representative (the first point) per cell of tolerance / 3, representatives
 * closer than the tolerance linked, connected components; the label of a point is its component's.
 */
std::vector<int> bruteForceComponents(const std::vector<Eigen::Vector3f>& pts, double tolerance)
{
  const double leaf = tolerance / 3.0;
  std::map<std::pair<long, long>, int> cell_of;
  std::vector<Eigen::Vector2f> reps;
  std::vector<int> point_cell(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i)
  {
    const std::pair<long, long> key(static_cast<long>(std::floor(pts[i].x() / leaf)),
                                    static_cast<long>(std::floor(pts[i].y() / leaf)));
    const auto it = cell_of.emplace(key, static_cast<int>(reps.size()));
    if (it.second)
      reps.emplace_back(pts[i].x(), pts[i].y());
    point_cell[i] = it.first->second;
  }
  std::vector<int> comp(reps.size(), -1);
  const float tol2 = static_cast<float>(tolerance * tolerance);
  int next = 0;
  for (std::size_t s = 0; s < reps.size(); ++s)
  {
    if (comp[s] >= 0)
      continue;
    std::vector<std::size_t> queue{ s };
    comp[s] = next;
    for (std::size_t q = 0; q < queue.size(); ++q)
      for (std::size_t j = 0; j < reps.size(); ++j)
        if (comp[j] < 0 && (reps[j] - reps[queue[q]]).squaredNorm() < tol2)
        {
          comp[j] = next;
          queue.push_back(j);
        }
    ++next;
  }
  std::vector<int> label(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i)
    label[i] = comp[static_cast<std::size_t>(point_cell[i])];
  return label;
}

/** Two labelings name the same partition. */
bool samePartition(const std::vector<int>& a, const std::vector<int>& b)
{
  if (a.size() != b.size())
    return false;
  std::map<int, int> ab, ba;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (ab.emplace(a[i], b[i]).first->second != b[i] || ba.emplace(b[i], a[i]).first->second != a[i])
      return false;
  return true;
}

PlanarScan scanOf(const std::vector<float>& ranges)
{
  PlanarScan s;
  s.angle_min = -0.5;
  s.angle_increment = 0.01;
  s.range_min = 0.1;
  s.range_max = 30.0;
  s.ranges = ranges;
  return s;
}
}  // namespace

TEST(TrunkClustering, SeparateGroupsAreSeparateClustersAndHeightDoesNotSplit)
{
  std::vector<Eigen::Vector3f> pts;
  // A trunk's rings 0.4 m apart in height (one cluster), a second trunk 0.5 m away, a small bush further off.
  for (int ring = 0; ring < 5; ++ring)
    for (int k = 0; k < 30; ++k)
      pts.emplace_back(5.0f + 0.2f * std::cos(2.4f + 0.05f * k), 0.2f * std::sin(2.4f + 0.05f * k),
                       -1.2f + 0.4f * ring);
  for (int k = 0; k < 30; ++k)
    pts.emplace_back(5.0f + 0.2f * std::cos(2.4f + 0.05f * k), 0.9f + 0.2f * std::sin(2.4f + 0.05f * k), -0.8f);
  for (int i = 0; i < 5; ++i)
    pts.emplace_back(-3.0f + 0.05f * i, -4.0f, -1.0f);
  const auto clusters = clusterHorizontal(pts, 0.25);
  ASSERT_EQ(clusters.size(), 3u);
  // Largest first, indices ascending, every point once.
  EXPECT_GE(clusters[0].size(), clusters[1].size());
  EXPECT_GE(clusters[1].size(), clusters[2].size());
  std::size_t total = 0;
  for (const auto& c : clusters)
  {
    EXPECT_TRUE(std::is_sorted(c.begin(), c.end()));
    total += c.size();
  }
  EXPECT_EQ(total, pts.size());
  const auto label = labels(clusters, pts.size());
  EXPECT_EQ(label[0], label[5 * 30 - 1]);  // lowest and highest ring of the first trunk
  EXPECT_NE(label[0], label[pts.size() - 6]);
  EXPECT_NE(label[pts.size() - 1], label[pts.size() - 6]);
}

TEST(TrunkClustering, ClustersAreTheConnectedComponentsOfTheCells)
{
  // Random stands of blobs and scattered points (negative coordinates too): the clusters are exactly the
  // components of the brute-force definition.
  for (int trial = 0; trial < 5; ++trial)
  {
    Random rnd(static_cast<std::uint64_t>(40 + trial));
    std::vector<Eigen::Vector3f> pts;
    for (int b = 0; b < 30; ++b)
    {
      const double cx = rnd.uniform(-12.0, 12.0), cy = rnd.uniform(-12.0, 12.0), s = rnd.uniform(0.05, 0.6);
      const int n = 5 + static_cast<int>(rnd.uniformIndex(60));
      for (int i = 0; i < n; ++i)
        pts.emplace_back(static_cast<float>(cx + rnd.gaussian(s)), static_cast<float>(cy + rnd.gaussian(s)),
                         static_cast<float>(rnd.uniform(-1.5, 0.5)));
    }
    for (int i = 0; i < 300; ++i)
      pts.emplace_back(static_cast<float>(rnd.uniform(-15, 15)), static_cast<float>(rnd.uniform(-15, 15)), 0.0f);
    const auto clusters = clusterHorizontal(pts, 0.25);
    const auto label = labels(clusters, pts.size());
    ASSERT_TRUE(std::none_of(label.begin(), label.end(), [](int l) { return l < 0; }));
    EXPECT_TRUE(samePartition(label, bruteForceComponents(pts, 0.25))) << "trial " << trial;
  }
}

TEST(TrunkClustering, CandidatesNeedEnoughPointsAndHeight)
{
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 10; ++i)
    pts.emplace_back(1.0f, 0.0f, -1.2f + 0.1f * i);  // 10 points over 0.9 m: a candidate
  for (int i = 0; i < 10; ++i)
    pts.emplace_back(2.0f, 0.0f, -1.2f + 0.01f * i);  // 10 points over 0.09 m: too flat
  for (int i = 0; i < 3; ++i)
    pts.emplace_back(3.0f, 0.0f, -1.2f + 0.4f * i);  // 3 points: too few
  std::vector<std::vector<int>> clusters(3);
  for (int i = 0; i < 23; ++i)
    clusters[static_cast<std::size_t>(i < 10 ? 0 : i < 20 ? 1 : 2)].push_back(i);
  TrunkDetectorConfig cfg;
  TrunkDetectorStats st;
  const auto candidates = selectTrunkCandidates(pts, clusters, cfg, &st);
  ASSERT_EQ(candidates.size(), 1u);
  EXPECT_EQ(candidates[0].points.size(), 10u);
  EXPECT_NEAR(candidates[0].z_lo, -1.2, 1e-6);
  EXPECT_NEAR(candidates[0].z_hi, -0.3, 1e-6);
  EXPECT_NEAR(candidates[0].zMid(), -0.75, 1e-6);
  EXPECT_EQ(st.rejected_shape, 1);
  EXPECT_EQ(st.rejected_size, 1);
}

TEST(TrunkClustering, VoxelsKeepOneCentroidEach)
{
  std::vector<Eigen::Vector3f> pts{ { 0.01f, 0.01f, 0.01f }, { 0.03f, 0.03f, 0.03f }, { 0.51f, 0.0f, 0.0f } };
  downsampleVoxels(&pts, 0.1);
  ASSERT_EQ(pts.size(), 2u);
  const auto& a = pts[0].x() < pts[1].x() ? pts[0] : pts[1];
  EXPECT_NEAR(a.x(), 0.02f, 1e-6);
  EXPECT_NEAR(a.z(), 0.02f, 1e-6);
}

TEST(TrunkClustering, ScanArcsBreakAtJumpsAndNoReturnButNotAtDropouts)
{
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  // Beams 0.01 rad apart: at 5 m neighbours are 5 cm apart.
  std::vector<float> r{ 5.0f, 5.0f, nan, 5.0f, 5.0f, 8.0f, 8.0f, 8.0f, inf, 8.0f, 8.0f, 0.0f, -inf, 8.0f };
  int valid = 0;
  const auto arcs = splitScanIntoArcs(scanOf(r), 0.25, 0.1, &valid);
  EXPECT_EQ(valid, 10);
  ASSERT_EQ(arcs.size(), 3u);
  EXPECT_EQ(arcs[0].points.size(), 4u);  // the NaN does not split it
  EXPECT_EQ(arcs[0].first_beam, 0);
  EXPECT_EQ(arcs[0].last_beam, 4);
  EXPECT_EQ(arcs[1].first_beam, 5);  // the jump to 8 m splits
  EXPECT_EQ(arcs[1].last_beam, 7);   // +Inf (no return) ends it
  EXPECT_EQ(arcs[2].points.size(), 3u);  // 0 and -Inf tell nothing
  EXPECT_NEAR(arcs[0].points[0].norm(), 5.1, 1e-6);  // range offset applied
  EXPECT_NEAR(std::atan2(arcs[0].points[0].y(), arcs[0].points[0].x()), -0.5, 1e-9);
}

TEST(TrunkClustering, AnArcBehindANearerObjectIsOccluded)
{
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const PlanarScan s = scanOf({ 3.0f, nan, 6.0f, 6.0f, 6.0f, 9.0f, inf, 6.0f, 6.0f, 6.0f, inf });
  const auto arcs = splitScanIntoArcs(s, 0.25, 0.0);
  ASSERT_EQ(arcs.size(), 4u);
  EXPECT_TRUE(isArcOccluded(s, arcs[1], 0.25));   // 3 m before it (past the NaN)
  EXPECT_FALSE(isArcOccluded(s, arcs[3], 0.25));  // no return on either side
  EXPECT_TRUE(isArcOccluded(s, arcs[2], 0.25));   // the 9 m beam has a 6 m one beside it

}
