// Odometry from TF at a scan's stamp (TfOdometry, the grid node's odometry source): found and interpolated, not
// yet there, or never there (older than what TF keeps).
#include <string>

#include <gtest/gtest.h>
#include <tf2_ros/buffer.h>

#include "rbpf_slam/ros/tf_odometry.h"

namespace
{
geometry_msgs::TransformStamped odomAt(double stamp, double x)
{
  geometry_msgs::TransformStamped t;
  t.header.stamp = ros::Time(stamp);
  t.header.frame_id = "odom";
  t.child_frame_id = "base_link";
  t.transform.translation.x = x;
  t.transform.rotation.w = 1.0;
  return t;
}
}  // namespace

TEST(TfOdometry, FoundNotYetAndNever)
{
  tf2_ros::Buffer buffer(ros::Duration(10.0));
  buffer.setTransform(odomAt(100.0, 1.0), "test");
  buffer.setTransform(odomAt(101.0, 3.0), "test");
  const rbpf_slam::TfOdometry odometry(&buffer, "odom", "base_link");
  rbpf_slam::core::Pose2 pose;
  std::string error;
  ASSERT_EQ(odometry.at(ros::Time(100.5), &pose, &error), rbpf_slam::TfOdometry::Answer::kFound) << error;
  EXPECT_NEAR(pose.x, 2.0, 1e-9);
  EXPECT_NEAR(pose.theta, 0.0, 1e-9);
  EXPECT_EQ(odometry.at(ros::Time(101.5), &pose, &error), rbpf_slam::TfOdometry::Answer::kNotYet);
  EXPECT_FALSE(error.empty());
  EXPECT_EQ(odometry.at(ros::Time(99.0), &pose, &error), rbpf_slam::TfOdometry::Answer::kNever);
  buffer.setTransform(odomAt(102.0, 4.0), "test");
  EXPECT_EQ(odometry.at(ros::Time(101.5), &pose, &error), rbpf_slam::TfOdometry::Answer::kFound);
  EXPECT_NEAR(pose.x, 3.5, 1e-9);
}
