#ifndef RBPF_SLAM_CORE_GRID_RBPF_GRID_SLAM_H
#define RBPF_SLAM_CORE_GRID_RBPF_GRID_SLAM_H

#include <memory>
#include <vector>

#include "rbpf_slam/core/grid/grid_slam.h"
#include "rbpf_slam/core/filter/history_chain.h"

namespace rbpf_slam
{
namespace core
{
/**
 * @brief Grid SLAM as GMapping does it: every particle owns its map (copy-on-write by tiles: copying a particle
 * copies tile pointers, a scan clones only the tiles it writes); each particle's pose is sampled from the odometry
 * motion model, refined by hill-climbing scan matching against its own map, then drawn from a small Gaussian
 * around the match; its log-weight grows by likelihood_gain times the likelihood-field log-likelihood at the match
 * (GMapping's approximation of the proposal's normaliser), optionally with the motion model's factor; every
 * particle inserts the scan in its own map; the best particle (largest weight) is the estimate.
 */
class RbpfGridSlam : public GridSlam
{
public:
  /** @throws std::invalid_argument when config.validate() reports a problem. */
  explicit RbpfGridSlam(const GridSlamConfig& config);
  const OccupancyGrid& map() const override { return maps_[best_index_]; }
  const OccupancyGrid& particleMap(std::size_t i) const override { return maps_.at(i); }
  std::vector<Pose2> bestTrajectory() const override;

private:
  /** @brief A pose of a particle's history; ancestors shared between particles, released iteratively. */
  using TrajectoryNode = HistoryNode<Pose2>;

  void resetMaps() override;
  int startMaps(const Pose2& odometry, const ScanData& scan, const Pose2& sensor) override;
  GridSlamStep step(const OdometryIncrement& u, const ScanData& scan, const Pose2& sensor) override;
  void carry(const OdometryIncrement& u) override;

  /** @brief Variances of one scan's increment @p u: along and across the motion [m^2], heading [rad^2]. */
  struct Spread
  {
    double along = 0.0, across = 0.0, theta = 0.0;
    void add(const Spread& o)
    {
      along += o.along;
      across += o.across;
      theta += o.theta;
    }
  };
  Spread spreadOf(const OdometryIncrement& u) const;

  /** @brief The odometry's spread over one step and what follows from it (defined in the source). */
  struct StepSpread;
  StepSpread stepSpread() const;
  /** @brief The motion noise of the whole increment @p u scaled to the step's @p spread. */
  OdometryMotionNoise scaledNoise(const OdometryIncrement& u, const Spread& spread) const;
  /** @brief The step's random draws, in particle order: odometry samples and jitters; the odometry's means. */
  void drawSamples(const OdometryIncrement& u, const OdometryMotionNoise& noise);
  /** @brief Scan-matches every particle's odometry sample against its map (on config_.threads threads). */
  void matchParticles(const Pose2& sensor, const StepSpread& spread, std::size_t used, double min_matched);
  void matchParticle(std::size_t i, const Pose2& sensor, const StepSpread& spread, std::size_t used,
                     double min_matched);
  /** @brief The squared Mahalanobis distance of particle @p i's match from its odometry, as the veto measures it. */
  double vetoDistance(std::size_t i, const Pose2& sensor, const StepSpread& spread);
  /** @brief veto_consensus: the refused matches that agree with the particles' common correction taken. */
  int vetoByConsensus(const StepSpread& spread);
  /** @brief Each particle's new pose and log-weight from its match; the end points each matched. */
  void takeProposals(const StepSpread& spread, std::vector<int>* matched, GridSlamStep* step);
  /** @brief Every particle maps the scan at its pose, then the weighting step resamples. */
  void mapAndResample(const ScanData& scan, const Pose2& sensor, const std::vector<int>& matched, GridSlamStep* step);

  ScanMatcher matcher_;
  std::vector<OccupancyGrid> maps_;  ///< one per particle
  std::vector<std::shared_ptr<const TrajectoryNode>> histories_;
  std::size_t best_index_ = 0;
  /** @brief What became of a particle's match in one step. */
  enum class MatchUse : char
  {
    kOdometry,  ///< not trusted (too few end points matched): the odometry sample, weighed there
    kMatch,     ///< taken
    kVetoed,    ///< beyond the odometry's veto, its heading too: the odometry sample, weighed there
    kHeading,   ///< beyond the veto: the odometry sample's position with the matched heading
  };
  // Per step, per particle: the odometry sample, the jitter around its match, the match, what became of it.
  std::vector<Pose2> predicted_, jitter_, means_;  // means_: the odometry's mean, the motion model's centre
  std::vector<ScanMatch> matches_;
  std::vector<MatchUse> use_;
  // Per particle: the match the veto refused (its pose), and whether it was refused (veto_consensus).
  std::vector<ScanMatch> refused_;
  std::vector<char> was_refused_;
  /** @brief What the scans below the travel thresholds added since the last processed scan. */
  struct Carried
  {
    Spread sum;                          ///< their variances
    double max_theta = 0.0, max_xy = 0.0;  ///< the largest one scan's increment had (heading, position)
  };
  Carried carried_;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_GRID_RBPF_GRID_SLAM_H
