#ifndef RBPF_SLAM_CORE_SCAN_MATCHER_H
#define RBPF_SLAM_CORE_SCAN_MATCHER_H

#include <string>
#include <utility>
#include <vector>

#include "rbpf_slam/core/occupancy_grid.h"
#include "rbpf_slam/core/pose2.h"

namespace rbpf_slam
{
namespace core
{
/**
 * @brief The likelihood-field model and the hill-climbing scan matcher of the `rbpf` grid SLAM mode, after
 * GMapping (Grisetti, Stachniss, Burgard 2007): each scan end point looks for the nearest occupied cell in a
 * (2 kernel + 1)^2 window around the cell it falls in; the distance d to that cell's centre scores
 * exp(-d^2 / (2 match_sigma^2)) for the matcher and -d^2 / (2 likelihood_sigma^2) for the weight; an end point
 * with no occupied cell in its window scores 0 and no_hit_distance for the weight.
 */
struct ScanMatcherConfig
{
  int kernel = 1;                  ///< [cells] search window half-size around each end point
  double match_sigma = 0.05;       ///< [m] of the matcher's score
  double likelihood_sigma = 0.075; ///< [m] of the weight's likelihood
  double no_hit_distance = 0.3;    ///< [m] distance charged to an end point with no occupied cell in its window
  double linear_step = 0.05;       ///< [m] first step of hill climbing
  double angular_step = 0.05;      ///< [rad] first step of hill climbing
  int refinements = 5;             ///< step halvings before hill climbing stops
  int max_iterations = 100;        ///< cap on the moves of one match
  int beam_step = 1;               ///< match and weigh with every n-th hit beam
  /// GMapping's test: a window cell counts only if the cell at the same offset from the point sqrt(2) cells back
  /// along the beam is not occupied.
  bool free_check = false;

  /** @brief Empty when valid, else a message naming the bad parameter. */
  std::string validate() const;
};

/** @brief What one match found. */
struct ScanMatch
{
  Pose2 pose;              ///< the robot pose of the best score
  double score = 0.0;      ///< matcher score there (sum over end points, each in [0, 1])
  double log_likelihood = 0.0;  ///< the likelihood-field log-likelihood there
  int matched = 0;         ///< end points with an occupied cell in their window there
  int evaluations = 0;     ///< poses scored
};

class ScanMatcher
{
public:
  explicit ScanMatcher(const ScanMatcherConfig& config = ScanMatcherConfig());
  const ScanMatcherConfig& config() const { return config_; }

  /**
   * @brief Scores robot pose @p pose for end points @p end_points (sensor frame; the sensor sits at @p sensor
   * on the robot) against @p map; fills score, log_likelihood and matched of the result.
   */
  ScanMatch evaluate(const OccupancyGrid& map, const Pose2& pose, const Pose2& sensor,
                     const std::vector<std::pair<double, double>>& end_points) const;

  /**
   * @brief Hill climbing from @p start: tries +-x, +-y (map frame) and +-theta; takes the best improving move
   * and repeats; when none improves, halves the steps (refinements times).
   */
  ScanMatch match(const OccupancyGrid& map, const Pose2& start, const Pose2& sensor,
                  const std::vector<std::pair<double, double>>& end_points) const;

private:
  /** @brief exp(-d2 / (2 match_sigma^2)) by linear interpolation in a table (the profile's second item). */
  double matchKernel(double d2) const;

  ScanMatcherConfig config_;
  std::vector<double> exp_table_;  // exp(-x) at x = i / kExpTableScale
  static constexpr double kExpTableScale = 256.0;
  static constexpr double kExpTableMax = 16.0;  // exp(-16) ~ 1e-7: beyond, 0
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_SCAN_MATCHER_H
