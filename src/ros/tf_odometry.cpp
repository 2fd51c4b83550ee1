#include "rbpf_slam/ros/tf_odometry.h"

#include <cmath>

#include <tf2/exceptions.h>

#include "rbpf_slam/ros/pose_msgs.h"

namespace rbpf_slam
{
TfOdometry::Answer TfOdometry::at(const ros::Time& stamp, core::Pose2* pose, std::string* error) const
{
  // The newest odometry, read before the lookup: TF's listener fills the buffer from its own thread, and a transform
  // arriving between a failed lookup and this test must not turn a stamp that only had to wait into a lost one.
  bool newer = false;
  try
  {
    newer = buffer_->lookupTransform(odom_frame_, base_frame_, ros::Time(0)).header.stamp > stamp;
  }
  catch (const tf2::TransformException&)
  {
  }
  try
  {
    const geometry_msgs::TransformStamped t = buffer_->lookupTransform(odom_frame_, base_frame_, stamp);
    *pose = core::Pose2(t.transform.translation.x, t.transform.translation.y, yawOf(t.transform.rotation));
    if (std::isfinite(pose->x) && std::isfinite(pose->y) && std::isfinite(pose->theta))
      return Answer::kFound;
    *error = "a non-finite transform";
    return Answer::kNever;
  }
  catch (const tf2::TransformException& e)
  {
    *error = e.what();
    return newer ? Answer::kNever : Answer::kNotYet;
  }
}

}  // namespace rbpf_slam
