#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "rbpf_slam/ros/trunk_conversions.h"

using rbpf_slam::fromMsg;
using rbpf_slam::toMsg;

TEST(TrunkConversions, TrunkMessageToObservation)
{
  rbpf_slam::Trunk m;
  m.center.x = 3.0;
  m.center.y = 4.0;
  m.center.z = 1.3;
  m.radius = 0.2;
  m.radius_variance = 0.0004;
  m.covariance = { 0.01, 0.002, 0.002, 0.03 };  // row-major (xx, xy, yx, yy)
  m.method = rbpf_slam::Trunk::METHOD_CIRCLE;
  const auto t = fromMsg(m);
  EXPECT_DOUBLE_EQ(t.center.x(), 3.0);
  EXPECT_DOUBLE_EQ(t.center.y(), 4.0);
  EXPECT_DOUBLE_EQ(t.range, 5.0);
  EXPECT_NEAR(t.bearing, std::atan2(4.0, 3.0), 1e-12);
  EXPECT_DOUBLE_EQ(t.covariance(0, 0), 0.01);
  EXPECT_DOUBLE_EQ(t.covariance(0, 1), 0.002);
  EXPECT_DOUBLE_EQ(t.covariance(1, 1), 0.03);
  EXPECT_DOUBLE_EQ(t.radius, 0.2);
  EXPECT_EQ(t.method, rbpf_slam::core::TrunkMethod::kCircle);
  const auto o = rbpf_slam::core::toLandmarkObservation(t);
  EXPECT_NEAR(o.range, 5.0, 1e-12);
  EXPECT_DOUBLE_EQ(o.radius_variance, 0.0004);  // circle: the radius is used
}

TEST(TrunkConversions, MethodsMap)
{
  rbpf_slam::Trunk m;
  m.center.x = 1.0;
  m.method = rbpf_slam::Trunk::METHOD_CENTROID;
  EXPECT_EQ(fromMsg(m).method, rbpf_slam::core::TrunkMethod::kCentroid);
  m.method = rbpf_slam::Trunk::METHOD_ARC;
  EXPECT_EQ(fromMsg(m).method, rbpf_slam::core::TrunkMethod::kArc);
  m.method = rbpf_slam::Trunk::METHOD_GIVEN;  // given data: radius used like a fitted circle's
  EXPECT_EQ(fromMsg(m).method, rbpf_slam::core::TrunkMethod::kCircle);
}

TEST(TrunkConversions, UnreadableTrunksAreLeftOutAndTheArrayIsNoEvidenceOfAbsence)
{
  rbpf_slam::TrunkArray msg;
  msg.header.stamp = ros::Time(100.0);
  rbpf_slam::Trunk good;
  good.center.x = 4.0;
  good.radius = 0.2;
  good.covariance = { 1e-4, 0.0, 0.0, 1e-4 };
  rbpf_slam::Trunk nan_centre = good, nan_covariance = good;
  nan_centre.center.y = std::nan("");
  nan_covariance.covariance[3] = std::nan("");
  msg.trunks = { good, nan_centre, nan_covariance };
  rbpf_slam::core::TrunkSweep sweep;
  EXPECT_EQ(rbpf_slam::toTrunkSweep(msg, rbpf_slam::core::Pose2(), 0.0, &sweep), 2u);
  EXPECT_EQ(sweep.trunks.size(), 1u);
  EXPECT_FALSE(sweep.scope.complete) << "what was left out may have been a tree";
  msg.trunks = { good };
  EXPECT_EQ(rbpf_slam::toTrunkSweep(msg, rbpf_slam::core::Pose2(), 0.0, &sweep), 0u);
  EXPECT_TRUE(sweep.scope.complete);
}

TEST(TrunkConversions, TrunksOutOfRangeAreLeftOutLikeUnreadableOnes)
{
  rbpf_slam::TrunkArray msg;
  msg.header.stamp = ros::Time(100.0);
  rbpf_slam::Trunk good;
  good.center.x = 4.0;
  good.radius = 0.2;
  good.radius_variance = 1e-4;
  good.covariance = { 1e-4, 2e-5, 2e-5, 1e-4 };
  rbpf_slam::Trunk negative_radius = good, negative_radius_variance = good, negative_variance = good,
                   asymmetric = good, indefinite = good, unknown_radius = good;
  negative_radius.radius = -0.2;
  negative_radius_variance.radius_variance = -1e-4;
  negative_variance.covariance = { -1e-4, 0.0, 0.0, 1e-4 };
  asymmetric.covariance = { 1e-4, 5e-5, -5e-5, 1e-4 };
  indefinite.covariance = { 1e-4, 2e-4, 2e-4, 1e-4 };  // variances fine, the determinant negative
  unknown_radius.radius = 0.0;                          // a centroid: no radius, still a trunk
  unknown_radius.radius_variance = 0.0;
  msg.trunks = { good, negative_radius, negative_radius_variance, negative_variance, asymmetric, indefinite,
                 unknown_radius };
  rbpf_slam::core::TrunkSweep sweep;
  EXPECT_EQ(rbpf_slam::toTrunkSweep(msg, rbpf_slam::core::Pose2(), 0.0, &sweep), 5u);
  EXPECT_EQ(sweep.trunks.size(), 2u);
  EXPECT_FALSE(sweep.scope.complete);
  for (const auto& t : { good, unknown_radius })
    EXPECT_TRUE(rbpf_slam::trunkIsReadable(rbpf_slam::fromMsg(t)));
}

TEST(TrunkConversions, ADetectionSurvivesTheMessageBothWays)
{
  rbpf_slam::core::TrunkObservation t;
  t.center = Eigen::Vector2d(-2.0, 5.0);
  t.height = 1.2;
  t.radius = 0.17;
  t.radius_variance = 2e-4;
  t.covariance << 0.02, 0.004, 0.004, 0.05;
  t.num_points = 40;
  t.num_inliers = 33;
  t.score = 0.75;
  t.method = rbpf_slam::core::TrunkMethod::kArc;
  const rbpf_slam::Trunk m = toMsg(t);
  EXPECT_EQ(m.id, -1);
  EXPECT_EQ(m.method, rbpf_slam::Trunk::METHOD_ARC);
  const auto back = fromMsg(m);
  EXPECT_DOUBLE_EQ(back.center.x(), -2.0);
  EXPECT_DOUBLE_EQ(back.center.y(), 5.0);
  EXPECT_DOUBLE_EQ(back.height, 1.2);
  EXPECT_DOUBLE_EQ(back.radius, 0.17);
  EXPECT_DOUBLE_EQ(back.radius_variance, 2e-4);
  EXPECT_TRUE(back.covariance.isApprox(t.covariance, 0.0));
  EXPECT_EQ(back.num_points, 40);
  EXPECT_EQ(back.num_inliers, 33);
  EXPECT_FLOAT_EQ(static_cast<float>(back.score), 0.75f);
  EXPECT_EQ(back.method, rbpf_slam::core::TrunkMethod::kArc);
  EXPECT_EQ(back.id, -1);
}

TEST(TrunkConversions, TheSweepsScopeAndTimingSurviveTheMessageAndUnknownFieldsStayUnknown)
{
  std_msgs::Header header;
  header.stamp = ros::Time(50.0);
  header.frame_id = "velodyne";
  rbpf_slam::core::SensorScope scope;
  scope.min_range = 1.0;
  scope.max_range = 12.0;
  scope.fov_min = -M_PI / 2;
  scope.fov_max = M_PI / 2;
  // detection_probability left unknown (NaN): 0 in the message, unknown again after it.
  rbpf_slam::core::SweepGeometry geometry;
  geometry.start_angle = 0.3;
  geometry.span = 2.0 * M_PI;
  rbpf_slam::core::TrunkObservation t;
  t.center = Eigen::Vector2d(4.0, 0.0);
  t.radius = 0.2;
  t.covariance = Eigen::Matrix2d::Identity() * 1e-3;
  const auto msg = rbpf_slam::toSweepMsg(header, { t, t }, scope, 0.1, &geometry, 0.02, -0.01);
  EXPECT_EQ(msg->header.frame_id, "velodyne");
  EXPECT_EQ(msg->trunks.size(), 2u);
  EXPECT_EQ(msg->detection_probability, 0.0);
  rbpf_slam::core::TrunkSweep sweep;
  EXPECT_EQ(rbpf_slam::toTrunkSweep(*msg, rbpf_slam::core::Pose2(0.5, 0.0, 0.0), 1.8, &sweep), 0u);
  EXPECT_DOUBLE_EQ(sweep.stamp, 50.0);
  EXPECT_DOUBLE_EQ(sweep.period, 0.1);
  EXPECT_DOUBLE_EQ(sweep.geometry.start_angle, 0.3);
  EXPECT_DOUBLE_EQ(sweep.tilt_roll, 0.02);
  EXPECT_DOUBLE_EQ(sweep.tilt_pitch, -0.01);
  EXPECT_DOUBLE_EQ(sweep.mount.x, 0.5);
  EXPECT_DOUBLE_EQ(sweep.mount.z, 1.8);
  EXPECT_DOUBLE_EQ(sweep.scope.min_range, 1.0);
  EXPECT_DOUBLE_EQ(sweep.scope.max_range, 12.0);
  EXPECT_DOUBLE_EQ(sweep.scope.fov_max, M_PI / 2);
  EXPECT_TRUE(std::isnan(sweep.scope.detection_probability));
  EXPECT_EQ(sweep.trunks.size(), 2u);
}

TEST(TrunkConversions, TheMapsLandmarksAsAnArrayAndAsMarkers)
{
  rbpf_slam::core::LandmarkMap map;
  for (int i = 0; i < 3; ++i)
  {
    rbpf_slam::core::Landmark l;
    l.mean = Eigen::Vector2d(3.0 * i, 4.0);
    l.covariance = Eigen::Matrix2d::Identity() * 0.04;  // 2-sigma ellipse: a circle of 0.4 m
    l.radius = 0.1 * (i + 1);
    l.observations = 5 * i;
    l.provisional = i == 2;
    l.id = 10 + i;
    map.add(l);
  }
  const auto array = rbpf_slam::toLandmarkArray(ros::Time(7.0), "map", map);
  ASSERT_EQ(array->trunks.size(), 3u);
  EXPECT_EQ(array->header.frame_id, "map");
  EXPECT_EQ(array->trunks[1].id, 11);
  EXPECT_EQ(array->trunks[1].method, rbpf_slam::Trunk::METHOD_GIVEN);
  EXPECT_DOUBLE_EQ(array->trunks[1].range, 5.0);
  EXPECT_FLOAT_EQ(array->trunks[2].score, 0.5f);  // provisional
  EXPECT_FLOAT_EQ(array->trunks[0].score, 1.0f);
  EXPECT_EQ(array->trunks[2].num_points, 10u);

  const auto markers = rbpf_slam::landmarkMarkers(ros::Time(7.0), "map", map);
  ASSERT_EQ(markers->markers.size(), 1u + 2u * 3u);  // DELETEALL, then a cylinder and an ellipse each
  EXPECT_EQ(markers->markers[0].action, visualization_msgs::Marker::DELETEALL);
  const auto& cylinder = markers->markers[5];
  EXPECT_EQ(cylinder.ns, "landmarks");
  EXPECT_EQ(cylinder.id, 12);
  EXPECT_DOUBLE_EQ(cylinder.scale.x, 0.6);
  EXPECT_FLOAT_EQ(cylinder.color.g, 0.85f);  // provisional: yellow
  const auto& ellipse = markers->markers[6];
  EXPECT_EQ(ellipse.ns, "landmark_covariance");
  ASSERT_EQ(ellipse.points.size(), 37u);
  for (const auto& p : ellipse.points)
    EXPECT_NEAR(std::hypot(p.x - 6.0, p.y - 4.0), 0.4, 1e-9);
}

TEST(TrunkConversions, DetectionMarkersAndTheScopeMarker)
{
  rbpf_slam::TrunkArray array;
  array.header.frame_id = "velodyne";
  array.trunks.resize(2);
  array.trunks[0].radius = 0.15;
  array.trunks[0].method = rbpf_slam::Trunk::METHOD_CIRCLE;
  array.trunks[1].radius = 0.3;
  array.trunks[1].method = rbpf_slam::Trunk::METHOD_CENTROID;
  const auto markers = rbpf_slam::trunkMarkers(array, 1.5);
  ASSERT_EQ(markers->markers.size(), 5u);  // DELETEALL, then a cylinder and a label each
  EXPECT_EQ(markers->markers[0].action, visualization_msgs::Marker::DELETEALL);
  EXPECT_DOUBLE_EQ(markers->markers[1].scale.x, 0.3);
  EXPECT_DOUBLE_EQ(markers->markers[1].scale.z, 1.5);
  EXPECT_EQ(markers->markers[2].text, "15.0 cm");
  EXPECT_FLOAT_EQ(markers->markers[3].color.r, 1.0f);  // centroid: orange

  rbpf_slam::core::VisibilityScope scope;
  scope.min_range = 1.0;
  scope.max_range = 12.0;
  scope.fov_min = -M_PI / 4;
  scope.fov_max = M_PI / 4;
  const auto m = rbpf_slam::scopeMarker(ros::Time(1.0), "base_link", scope, rbpf_slam::core::Pose2(0.5, 0.0, 0.0));
  EXPECT_EQ(m->header.frame_id, "base_link");
  ASSERT_EQ(m->points.size(), 2u * 2u * 120u + 4u);  // two arcs of 120 segments and the two sides
  for (const auto& p : m->points)
  {
    const double r = std::hypot(p.x - 0.5, p.y);
    EXPECT_TRUE(std::abs(r - 1.0) < 1e-9 || std::abs(r - 12.0) < 1e-9 ||
                std::abs(std::abs(std::atan2(p.y, p.x - 0.5)) - M_PI / 4) < 1e-9);
  }
}

TEST(TrunkConversions, ChangeMarkersDrawFelledAndNewTreesOnly)
{
  std::vector<rbpf_slam::core::TreeChange> changes(3);
  changes[0].kind = rbpf_slam::core::ChangeKind::kFelled;
  changes[0].id = 1;
  changes[0].dbh_before = 0.4;
  changes[1].kind = rbpf_slam::core::ChangeKind::kNew;
  changes[1].id = 2;
  changes[1].dbh_after = std::numeric_limits<double>::quiet_NaN();
  changes[2].kind = rbpf_slam::core::ChangeKind::kChanged;
  changes[2].id = 3;
  const auto markers = rbpf_slam::changeMarkers(ros::Time(2.0), "map", changes);
  ASSERT_EQ(markers->markers.size(), 3u);
  EXPECT_EQ(markers->markers[1].ns, rbpf_slam::core::toString(rbpf_slam::core::ChangeKind::kFelled));
  EXPECT_FLOAT_EQ(markers->markers[1].color.r, 1.0f);
  EXPECT_DOUBLE_EQ(markers->markers[1].scale.x, 0.6);
  EXPECT_DOUBLE_EQ(markers->markers[2].scale.x, 0.3);  // unknown diameter: the smallest marker
  EXPECT_FLOAT_EQ(markers->markers[2].color.b, 1.0f);
}
