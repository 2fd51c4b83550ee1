#ifndef RBPF_SLAM_ROS_TRUNK_CONVERSIONS_H
#define RBPF_SLAM_ROS_TRUNK_CONVERSIONS_H

#include <cstddef>
#include <string>
#include <vector>

#include <ros/time.h>
#include <std_msgs/Header.h>
#include <visualization_msgs/Marker.h>
#include <visualization_msgs/MarkerArray.h>

#include "rbpf_slam/Trunk.h"
#include "rbpf_slam/TrunkArray.h"
#include "rbpf_slam/core/extraction/trunk_detector.h"
#include "rbpf_slam/core/fastslam/landmark_map.h"
#include "rbpf_slam/core/trunk_slam/trunk_slam_pipeline.h"
#include "rbpf_slam/core/fastslam/visibility_scope.h"
#include "rbpf_slam/core/forest_map/forest_changes.h"

/**
 * @file
 * @brief Every conversion between the trunk messages (rbpf_slam/Trunk, rbpf_slam/TrunkArray) and the core, and the
 * markers drawn from them: detections, the sensor's scope, the map's landmarks and the changes since a saved map.
 * The trunk extraction, the FastSLAM node and slam_bag use these and no other.
 */
namespace rbpf_slam
{
/** @brief A detection (sensor frame) as a Trunk message; id -1 (not a known tree). */
rbpf_slam::Trunk toMsg(const core::TrunkObservation& trunk);
/** @brief A Trunk message (sensor frame) as the core's observation: centre, covariance, radius, method. */
core::TrunkObservation fromMsg(const rbpf_slam::Trunk& trunk);

/**
 * @brief One sweep's detections as a TrunkArray: @p header (sensor frame and stamp), what the sensor could see
 * (@p scope; 0 for each field it does not know), its timing (@p sweep_period, @p geometry or none) and the tilt
 * the extractor removed.
 */
rbpf_slam::TrunkArray::Ptr toSweepMsg(const std_msgs::Header& header, const std::vector<core::TrunkObservation>& trunks,
                                      const core::SensorScope& scope, double sweep_period,
                                      const core::SweepGeometry* geometry, double tilt_roll, double tilt_pitch);
/** @brief The sensor's scope a TrunkArray states (NaN for each field it leaves 0). */
core::SensorScope scopeFromMsg(const rbpf_slam::TrunkArray& msg);
/** @brief False for a trunk no filter may use: a centre, radius or covariance not finite, a negative radius or
 * radius variance, a covariance that is no covariance (asymmetric, a negative variance or determinant). */
bool trunkIsReadable(const core::TrunkObservation& trunk);
/**
 * @brief A TrunkArray (sensor frame) as the pipeline's sweep, the sensor at @p sensor on base_link, @p sensor_height
 * above it: timing, tilt, scope and the trunks; trunks that are not readable (trunkIsReadable) are left out and
 * counted (the return value). The node and the bag runner share it.
 */
std::size_t toTrunkSweep(const rbpf_slam::TrunkArray& msg, const core::Pose2& sensor, double sensor_height,
                         core::TrunkSweep* sweep);

/** @brief A map's landmarks as a TrunkArray in @p frame: METHOD_GIVEN, id, score 0.5 while provisional. */
rbpf_slam::TrunkArray::Ptr toLandmarkArray(const ros::Time& stamp, const std::string& frame,
                                           const core::LandmarkMap& map);

/** @brief A DELETEALL, then per trunk a cylinder (diameter, @p band_height high, coloured by method) and a label. */
visualization_msgs::MarkerArray::Ptr trunkMarkers(const rbpf_slam::TrunkArray& trunks, double band_height);
/**
 * @brief The visibility scope around the sensor at @p sensor on @p base_frame: arcs at the near and far range and,
 * for a field of view under a full turn, its two sides (a LINE_LIST).
 */
visualization_msgs::Marker::Ptr scopeMarker(const ros::Time& stamp, const std::string& base_frame,
                                            const core::VisibilityScope& scope, const core::Pose2& sensor);
/** @brief A DELETEALL, then per landmark a cylinder (yellow while provisional) and its centre's 2-sigma ellipse. */
visualization_msgs::MarkerArray::Ptr landmarkMarkers(const ros::Time& stamp, const std::string& frame,
                                                     const core::LandmarkMap& map);
/** @brief A DELETEALL, then a cylinder per felled (red, where it stood) and new (blue) tree; changed ones not. */
/** @brief A loop the filter found (LoopEvent, closed or refused): a line from each recent tree to the old tree it
 * was matched with (green when closed, red when refused), at the height @p z, in namespace "loops" with id @p id. */
visualization_msgs::Marker loopMarker(const ros::Time& stamp, const std::string& frame, const core::LoopEvent& loop,
                                      int id, double z = 1.0);
visualization_msgs::MarkerArray::Ptr changeMarkers(const ros::Time& stamp, const std::string& frame,
                                                   const std::vector<core::TreeChange>& changes);

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_TRUNK_CONVERSIONS_H
