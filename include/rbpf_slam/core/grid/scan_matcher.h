#ifndef RBPF_SLAM_CORE_GRID_SCAN_MATCHER_H
#define RBPF_SLAM_CORE_GRID_SCAN_MATCHER_H

#include <limits>
#include <string>

#include <Eigen/Core>
#include <utility>
#include <vector>

#include "rbpf_slam/core/grid/occupancy_grid.h"
#include "rbpf_slam/core/filter/pose2.h"

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
/// Largest window half-size of the likelihood field [cells].
constexpr int kMaxKernel = 10;
/// Largest window half-size of the coarse level [coarse cells].
constexpr int kMaxCoarseKernel = 4;

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
  /// The fine climb moves on every n-th of those end points; the pose it ends at is scored on all of them (the
  /// match's score, likelihood and matched count). 1 = the climb uses them all.
  int climb_beam_step = 1;
  /// Coarse-to-fine: before the fine climb above, a climb on the map's coarse level (cells of 4 x 4 cells,
  /// OccupancyGrid::coarseCount): each end point looks for the nearest occupied coarse cell in a
  /// (2 coarse_kernel + 1)^2 window of coarse cells and scores exp(-d^2 / 2 coarse_sigma^2) with d to its centre;
  /// every coarse_beam_step-th end point, the same first steps, coarse_refinements halvings. It brings a start
  /// whose far end points miss the fine window by decimetres into its reach. 0 = off.
  int coarse_kernel = 0;
  double coarse_sigma = 0.15;      ///< [m]
  int coarse_beam_step = 2;
  int coarse_refinements = 2;

  /// Lower bounds of the motion model's standard deviations of one scan's increment (position, heading) in the
  /// weight's motion factor (GridSlamConfig::proposal_motion_weight); read by RbpfGridSlam, not by the matcher.
  double prior_floor_xy = 0.05;     ///< [m]
  double prior_floor_theta = 0.05;  ///< [rad]

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
   * and repeats; when none improves, halves the steps (refinements times). @p widen (0..kMaxWiden) doubles the
   * first level's (the coarse one's, else the fine one's) first steps that many times and adds as many halvings,
   * so the last step is unchanged: a wider reach for a start whose error is larger than one scan's. @p turn_only:
   * the climb only turns, the position stays @p start's.
   */
  ScanMatch match(const OccupancyGrid& map, const Pose2& start, const Pose2& sensor,
                  const std::vector<std::pair<double, double>>& end_points, int widen = 0,
                  bool turn_only = false) const;
  /**
   * @brief The information of a match at @p pose: the curvature of the likelihood-field log-likelihood there,
   * from the matcher's score (whose curvature at a hit is 1 / match_sigma^2 per end point, the likelihood's
   * 1 / likelihood_sigma^2) by central differences of one cell in x and y and of the turn that moves the end points
   * at their median range by one cell. Positive semi-definite (negative curvatures clamped to 0), in the map's axes
   * (x, y, heading). Along a corridor it is near 0: the scan does not fix the position there. 18 evaluations,
   * added to @p evaluations.
   */
  Eigen::Matrix3d information(const OccupancyGrid& map, const Pose2& pose, const Pose2& sensor,
                              const std::vector<std::pair<double, double>>& end_points, int* evaluations) const;
  /** @brief [rad] the heading step the climb ends with (the fine level's, after the coarse level's halvings). */
  double lastAngularStep() const
  {
    return std::ldexp(config_.angular_step,
                      -(config_.refinements + (config_.coarse_kernel > 0 ? config_.coarse_refinements : 0)));
  }
  /// Largest @p widen of match().
  static constexpr int kMaxWiden = 3;

private:
  /** @brief The window, score sigma and beam stride of one level of the climb. */
  struct Level
  {
    bool coarse;  // on the map's coarse level
    int kernel;
    double sigma;
    int beam_step;
    int refinements;
    double linear_step, angular_step;
    bool turn_only = false;  // the climb only turns (the position stays the start's)
  };
  /**
   * @brief The end points a level uses, rotated into the map's axes for one sensor heading: the climb's four
   * translating moves keep the heading, so they reuse them.
   */
  struct Rotated
  {
    struct Slot
    {
      double theta = std::numeric_limits<double>::quiet_NaN();
      long used = -1;  // when last read: the least recently used slot takes a new heading
      std::vector<std::pair<double, double>> points;
    };
    Slot slots[3];  // a climb step's own heading and its two turning moves
    long clock = 0;
  };
  const std::vector<std::pair<double, double>>& rotate(const Level& level, double theta,
                                                       const std::vector<std::pair<double, double>>& end_points,
                                                       Rotated* cache) const;
  ScanMatch evaluateAt(const Level& level, const OccupancyGrid& map, const Pose2& pose, const Pose2& sensor,
                       const std::vector<std::pair<double, double>>& end_points, Rotated* cache) const;
  ScanMatch evaluateCoarse(const Level& level, const OccupancyGrid& map, const Pose2& pose, const Pose2& sensor,
                           const std::vector<std::pair<double, double>>& end_points, Rotated* cache) const;
  ScanMatch climb(const Level& level, const OccupancyGrid& map, const Pose2& start, const Pose2& sensor,
                  const std::vector<std::pair<double, double>>& end_points, int* evaluations) const;
  Level fineLevel() const;

  /** @brief exp(-x) for x = d^2 / (2 sigma^2) >= 0 by linear interpolation in a table (inline: it runs once per
   * end point and pose). */
  double matchKernel(double x) const
  {
    if (x >= kExpTableMax)
      return 0.0;
    const double f = x * kExpTableScale;
    const std::size_t i = static_cast<std::size_t>(f);
    const double t = f - static_cast<double>(i);
    return exp_table_[i] + t * (exp_table_[i + 1] - exp_table_[i]);
  }

  ScanMatcherConfig config_;
  std::vector<double> exp_table_;  // exp(-x) at x = i / kExpTableScale
  static constexpr double kExpTableScale = 256.0;
  static constexpr double kExpTableMax = 16.0;  // exp(-16) ~ 1e-7: beyond, 0
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_GRID_SCAN_MATCHER_H
