// Odometry from TF at a scan's stamp (TfOdometry, the grid node's odometry source): found and interpolated, not
// yet there, or never there (older than what TF keeps).
#include <string>

#include <gtest/gtest.h>
#include <tf2_ros/buffer.h>

#include "rbpf_slam/ros/drop_count.h"
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

TEST(DropCount, EachCauseIsCountedOnItsOwnAndTheTotalBesideThem)
{
  rbpf_slam::DropCount d;
  EXPECT_EQ(d.summary(), "0 dropped so far");
  d.add("before the previous stamp");
  d.add("no transform base_link -> laser");
  EXPECT_EQ(d.add("before the previous stamp"),
            "3 dropped so far: 2 before the previous stamp, 1 no transform base_link -> laser");
  EXPECT_EQ(d.total(), 3u);
  EXPECT_EQ(d.count("before the previous stamp"), 2u);
  // Causes beyond the first kMaxCauses count together: the text stays short.
  for (std::size_t i = 0; i < 20; ++i)
    d.add("cause " + std::to_string(i));
  EXPECT_EQ(d.total(), 23u);
  EXPECT_EQ(d.count("other causes"), 23u - 3u - (rbpf_slam::DropCount::kMaxCauses - 2));
  EXPECT_EQ(d.count("cause 19"), 0u);
}
