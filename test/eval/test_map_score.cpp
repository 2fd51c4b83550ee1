// The C++ map scorer gives the numbers of the shared cases (test/data/map_score_cases.txt), which
// test/python/test_map_score.py asserts for the Python scorer: the package's two scorers agree.
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "rbpf_slam/eval/evaluation.h"

namespace
{
using rbpf_slam::eval::MapPoint;

struct Case
{
  std::vector<MapPoint> trees, features;
  int matched = 0, duplicates = 0, spurious = 0;
  double recall = 0.0, mean_error = 0.0, radius_rms = 0.0;
};

std::vector<Case> readCases(const std::string& path)
{
  std::vector<Case> cases;
  std::ifstream in(path);
  std::string line;
  Case c;
  while (std::getline(in, line))
  {
    std::istringstream s(line);
    std::string word;
    if (!(s >> word) || word[0] == '#')
      continue;
    if (word == "case")
      c = Case();
    else if (word == "tree" || word == "feature")
    {
      MapPoint p;
      s >> p.position.x() >> p.position.y() >> p.radius;
      (word == "tree" ? c.trees : c.features).push_back(p);
    }
    else if (word == "expect")
    {
      s >> c.matched >> c.duplicates >> c.spurious >> c.recall >> c.mean_error >> c.radius_rms;
      cases.push_back(c);
    }
  }
  return cases;
}
}  // namespace

TEST(MapScore, TheCppScorerGivesTheNumbersOfThePythonScorer)
{
  const std::vector<Case> cases = readCases(std::string(RBPF_SLAM_SOURCE_DIR) + "/test/data/map_score_cases.txt");
  ASSERT_EQ(cases.size(), 8u);
  for (std::size_t k = 0; k < cases.size(); ++k)
  {
    const Case& c = cases[k];
    const rbpf_slam::eval::MapScore s =
        rbpf_slam::eval::scoreMap(c.trees, std::vector<bool>(c.trees.size(), true), c.features, 0.5, 1.0);
    SCOPED_TRACE("case " + std::to_string(k));
    EXPECT_EQ(s.trees_seen, static_cast<int>(c.trees.size()));
    EXPECT_EQ(s.matched, c.matched);
    EXPECT_EQ(s.duplicates, c.duplicates);
    EXPECT_EQ(s.spurious, c.spurious);
    EXPECT_NEAR(s.recall, c.recall, 1e-8);
    EXPECT_NEAR(s.mean_distance, c.mean_error, 1e-6);
    EXPECT_NEAR(s.radius_rms, c.radius_rms, 1e-6);
  }
}
