#ifndef RBPF_SLAM_SIM_PATH_FOLLOWER_H
#define RBPF_SLAM_SIM_PATH_FOLLOWER_H

#include <cstdint>
#include <string>
#include <map>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "rbpf_slam/core/filter/pose2.h"
#include "rbpf_slam/sim/velocity_noise.h"

namespace rbpf_slam
{
namespace sim
{
struct PathFollowerConfig
{
  double speed = 1.0;           ///< [m/s]
  double lookahead = 2.0;       ///< [m] pure-pursuit look-ahead distance
  double max_angular = 0.8;     ///< [rad/s]
  double goal_tolerance = 0.3;  ///< [m] done within this of the last waypoint (on the last segment)

  // The local planner on the lidar (PathFollower::addObstacles): a round robot (the diff drive's footprint).
  bool avoid_obstacles = true;        ///< steer around the obstacle points the lidar sees
  double robot_radius = 0.6;          ///< [m] the footprint: a circle around base_link
  double clearance = 0.3;             ///< [m] kept between the footprint and any obstacle point
  double min_clearance = 0.1;         ///< [m] never given up, even at a third of the speed (the trunk a lidar sees
                                      ///< above the ground is thinner than at its foot; odometry and motor noise)
  double max_departure = 3.0;         ///< [m] no arc ends farther than this from the path (0: no bound)
  double horizon = 2.5;               ///< [m] arc length ahead along which each candidate arc must stay clear
  double max_curvature = 2.0;         ///< [1/m] the sharpest candidate arc (driven slower: |angular| <= max_angular)
  double obstacle_memory = 0.5;       ///< [s] an obstacle point is remembered this long after it was last seen
                                      ///< (placed by the odometry, which drifts most while turning in place)
  double obstacle_range = 5.0;        ///< [m] points farther than this from the robot are dropped
  double obstacle_min_height = 0.3;   ///< [m] above base_link: 3D points lower than this are ground
  double obstacle_max_height = 2.5;   ///< [m] above base_link: 3D points higher than this pass over the robot
  double obstacle_min_extent = 0.2;   ///< [m] 3D points count where those in their 0.2 m cell span this much height
                                      ///< (ground returns lie flat, trunks and boxes stand)

  /** @brief False (and why in @p error) for a planner parameter out of range. */
  bool validate(std::string* error) const;
};

/**
 * @brief The obstacle points (x, y in base_link) of one 3D lidar sweep given in base_link (x forward, z up): those
 * within obstacle_range, between obstacle_min_height and obstacle_max_height, in a 0.2 m cell whose points span
 * at least obstacle_min_extent of height (rising ground ahead is not an obstacle). Deterministic (keeps the order).
 */
std::vector<Eigen::Vector2d> obstaclesFromCloud(const std::vector<Eigen::Vector3d>& points,
                                                const PathFollowerConfig& config);

/**
 * @brief Roll and pitch of base_link from an accelerometer, as an IMU levels a robot (gravity gives them without
 * drift): the specific force averaged over @p time_constant seconds (the robot's own accelerations, brief, average
 * out). levelling() turns points of base_link into the level frame with base_link's heading, as the simulated
 * follower's are.
 */
class GravityLevel
{
public:
  explicit GravityLevel(double time_constant = 1.0) : time_constant_(time_constant) {}
  /** @brief One accelerometer sample (specific force in base_link [m/s^2]) at @p stamp [s]; non-finite ones, and
   * those far from 1 g (more than half a g off), are left out. False when left out. */
  bool add(double stamp, const Eigen::Vector3d& specific_force);
  /** @brief Whether a sample has come. */
  bool ready() const { return have_; }
  /** @brief The rotation that levels base_link's points (identity before any sample). */
  Eigen::Matrix3d levelling() const;

private:
  double time_constant_;
  bool have_ = false;
  double last_stamp_ = 0.0;
  Eigen::Vector3d mean_ = Eigen::Vector3d::UnitZ();
};

/**
 * @brief The obstacle points (x, y in base_link) of one planar scan: the finite ranges within the scanner's limits
 * and obstacle_range, from a scanner at @p mount (x, y, yaw on base_link).
 */
std::vector<Eigen::Vector2d> obstaclesFromScan(const std::vector<float>& ranges, double angle_min,
                                               double angle_increment, double range_min, double range_max,
                                               const core::Pose2& mount, const PathFollowerConfig& config);

/**
 * @brief Pure pursuit along a polyline, steering on the robot's own odometry (as a robot without
 * SLAM does): path and pose are both in the odom frame, which starts at the robot's start pose.
 *
 * With avoid_obstacles, a local planner steers around the obstacle points the lidar sees (addObstacles; they are
 * remembered in the odom frame for obstacle_memory seconds, so a low obstacle the lidar no longer sees up close
 * stays avoided). Among candidate arcs (the pure-pursuit arc and curvatures evenly spread over +-max_curvature)
 * it takes the one closest to the pure-pursuit arc that keeps robot_radius + clearance from every point over the
 * horizon (or, nearer than that already, comes no nearer than robot_radius + min_clearance); failing that, one that
 * keeps robot_radius + min_clearance (or, nearer than that already, comes no nearer at all), at a third of the
 * speed; failing that, it turns in place (a round footprint turning in place touches nothing new). With
 * max_departure, an arc that would end (or pass its middle) farther than that from the path is no candidate, unless
 * it brings the robot nearer the path than it is. A sharp arc is driven slower so that |angular| <= max_angular.
 * When the pure-pursuit arc is clear the command is pure pursuit's, exactly. Deterministic.
 */
class PathFollower
{
public:
  PathFollower(std::vector<Eigen::Vector2d> path, const PathFollowerConfig& config);

  /** @brief The command for odometry pose @p pose; zero once done. */
  VelocityCommand command(const core::Pose2& pose);
  /**
   * @brief Remembers obstacle points @p points (x, y in base_link) seen at time @p stamp [s] from odometry pose
   * @p pose; forgets those older than obstacle_memory or farther than obstacle_range. Nothing without
   * avoid_obstacles.
   */
  void addObstacles(double stamp, const core::Pose2& pose, const std::vector<Eigen::Vector2d>& points);
  /** @brief The remembered obstacle points, in the odom frame. */
  std::vector<Eigen::Vector2d> obstacles() const;
  /** @brief Whether the last command was the planner's rather than pure pursuit's. */
  bool avoiding() const { return avoiding_; }
  bool done() const { return done_; }
  double length() const { return cumulative_.back(); }
  /** @brief Arc length reached along the path [m]. */
  double progress() const { return progress_; }

private:
  Eigen::Vector2d pointAt(double s) const;
  /** @brief Distance from @p p (odom frame) to the path from the current segment a few look-aheads on; once a segment
   * lies within @p enough, that segment's distance (the search stops: the caller asks only whether p is that near). */
  double distanceToPath(const Eigen::Vector2d& p, double enough = -1.0) const;
  /**
   * @brief Plans way_ (odom frame) from @p pose to the farthest point of the path ahead that a grid search over the
   * remembered obstacles reaches (cells within robot_radius + min_clearance of a point, or beyond max_departure from
   * the path, are closed; those within the clearance cost more). False, and way_ empty, when none is reached.
   */
  bool planWay(const core::Pose2& pose);
  /** @brief The point of way_ to steer to from @p pose (way_ not empty). */
  Eigen::Vector2d carrot(const core::Pose2& pose) const;
  /** @brief Whether the arc of curvature @p kappa from @p pose ends within max_departure (or @p departure). */
  bool arcStays(const core::Pose2& pose, double kappa, double departure) const;
  /** @brief The planner's command, given pure pursuit's @p pursuit at @p pose. */
  VelocityCommand avoid(const core::Pose2& pose, const VelocityCommand& pursuit);

  struct Remembered
  {
    Eigen::Vector2d point;  ///< odom frame
    double stamp;
  };

  std::vector<Eigen::Vector2d> path_;
  std::vector<double> cumulative_;
  PathFollowerConfig config_;
  std::size_t segment_ = 0;
  double progress_ = 0.0;
  bool done_ = false;
  std::map<std::int64_t, Remembered> obstacles_;  ///< by 0.1 m cell of the odom frame
  bool avoiding_ = false;
  int turn_ = 0;  ///< turning in place: +1 left, -1 right, 0 not
  std::vector<Eigen::Vector2d> way_;  ///< the planned way round (odom frame), empty when pure pursuit is clear
  unsigned plan_count_ = 0;           ///< commands since the way was last planned
};

/** @brief The fraction u in [0, 1] of the way from @p a to @p b where the point of segment [a, b] nearest @p p lies
 * (0 for a segment of no length). */
double segmentFraction(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& p);

/** @brief The straight drive: straight ahead for @p length metres (start frame). */
std::vector<Eigen::Vector2d> straightDrive(double length = 30.0);

/**
 * @brief A loop that revisits trees, in the start frame: ahead 6.5 m, then 1.5 turns of a circle of
 * radius 8.5 m (counter-clockwise, centre 15 m ahead), then straight out to 30 m ahead. Started at
 * (0, 15) heading +x in the paper world, the circle (centre (15, 15)) keeps >= 1.2 m from every trunk.
 */
std::vector<Eigen::Vector2d> loopDrive();

}  // namespace sim
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_SIM_PATH_FOLLOWER_H
