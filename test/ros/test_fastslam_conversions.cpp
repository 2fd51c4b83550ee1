#include <cmath>

#include <gtest/gtest.h>

#include "rbpf_slam/ros/fastslam_node.h"

using rbpf_slam::fromMsg;

TEST(FastSlamConversions, TrunkMessageToObservation)
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

TEST(FastSlamConversions, MethodsMap)
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

TEST(FastSlamConversions, UnreadableTrunksAreLeftOutAndTheArrayIsNoEvidenceOfAbsence)
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
