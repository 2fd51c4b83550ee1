#include <cmath>

#include <gtest/gtest.h>

#include "rbpf_slam/core/filter/odometry_buffer.h"

using rbpf_slam::core::OdometryBuffer;
using rbpf_slam::core::Pose2;

TEST(OdometryBuffer, InterpolatesAndClamps)
{
  OdometryBuffer b;
  EXPECT_FALSE(b.covers(0.0));
  EXPECT_EQ(b.add(1.0, Pose2(0.0, 0.0, 0.0)), OdometryBuffer::AddResult::kAdded);
  EXPECT_EQ(b.add(2.0, Pose2(1.0, 2.0, 0.4)), OdometryBuffer::AddResult::kAdded);
  const Pose2 mid = b.at(1.25);
  EXPECT_NEAR(mid.x, 0.25, 1e-12);
  EXPECT_NEAR(mid.y, 0.5, 1e-12);
  EXPECT_NEAR(mid.theta, 0.1, 1e-12);
  EXPECT_NEAR(b.at(0.5).x, 0.0, 1e-12);  // before the first: the first
  EXPECT_NEAR(b.at(3.0).y, 2.0, 1e-12);  // after the last: the last
  EXPECT_TRUE(b.covers(2.0));
  EXPECT_FALSE(b.covers(2.1));
}

TEST(OdometryBuffer, HeadingTakesTheShortArc)
{
  OdometryBuffer b;
  b.add(0.0, Pose2(0.0, 0.0, M_PI - 0.1));
  b.add(1.0, Pose2(0.0, 0.0, -M_PI + 0.1));
  EXPECT_NEAR(std::abs(b.at(0.5).theta), M_PI, 1e-9);
}

TEST(OdometryBuffer, RefusesTimeGoingBackwardsAndRepeats)
{
  OdometryBuffer b;
  b.add(5.0, Pose2(1.0, 0.0, 0.0));
  EXPECT_EQ(b.add(4.0, Pose2(9.0, 0.0, 0.0)), OdometryBuffer::AddResult::kBackwards);
  EXPECT_EQ(b.add(5.0 + 1e-7, Pose2(9.0, 0.0, 0.0)), OdometryBuffer::AddResult::kRepeated);
  EXPECT_EQ(b.size(), 1u);
  EXPECT_NEAR(b.at(5.0).x, 1.0, 1e-12);
}

TEST(OdometryBuffer, DropBeforeKeepsWhatInterpolationNeeds)
{
  OdometryBuffer b;
  for (int i = 0; i < 10; ++i)
    b.add(i, Pose2(i, 0.0, 0.0));
  b.dropBefore(4.5);
  EXPECT_EQ(b.earliest(), 4.0);
  EXPECT_NEAR(b.at(4.5).x, 4.5, 1e-12);
  b.dropBefore(100.0);
  EXPECT_EQ(b.size(), 1u);
}

TEST(OdometryBuffer, ThePoseAtAStampDoesNotDependOnLaterSamples)
{
  // A scan at 2.000001 s, odometry at 2.0 s (the same instant, printed a microsecond apart) and later at 3.0 s:
  // the pose at the scan is the 2.0 s sample's, whether the 3.0 s one has come or not (a node behind its scans
  // sees it, a bag runner that processes at once does not).
  OdometryBuffer before, after;
  for (OdometryBuffer* b : { &before, &after })
  {
    b->add(1.0, Pose2(0.0, 0.0, 0.0));
    b->add(2.0, Pose2(1.0, 0.5, 0.1));
  }
  after.add(3.0, Pose2(2.0, 1.0, 0.2));
  const double t = 2.000001;
  ASSERT_TRUE(before.covers(t));
  EXPECT_EQ(before.at(t).x, 1.0);
  EXPECT_EQ(after.at(t).x, before.at(t).x);
  EXPECT_EQ(after.at(t).y, before.at(t).y);
  EXPECT_EQ(after.at(t).theta, before.at(t).theta);
  // A sample exactly at the stamp is the pose there, bit for bit, with or without one before or after it.
  EXPECT_EQ(after.at(2.0).x, 1.0);
  EXPECT_EQ(after.at(2.0).theta, 0.1);
  // Between samples, interpolated as before.
  EXPECT_NEAR(after.at(2.5).x, 1.5, 1e-12);
  EXPECT_EQ(after.at(0.5).x, 0.0);
  EXPECT_EQ(after.at(4.0).x, 2.0);
}
