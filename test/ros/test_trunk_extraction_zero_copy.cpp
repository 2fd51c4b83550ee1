// Zero-copy transport into the trunk extraction nodelet.
//
// Design: this test executable is the nodelet manager. It loads rbpf_slam/TrunkExtractionNodelet into
// itself with nodelet::Loader (what `nodelet manager` does), with ~debug_report_address true, so the
// nodelet publishes on ~input_address the address of every cloud its callback receives. The test then
// publishes clouds as ConstPtr from the same process and requires each reported address to equal the
// address of the object it published: the nodelet got that very object, not a copy or a deserialised
// message. A publisher in another nodelet of the same manager (e.g. a lidar driver) is in the same
// position as this test's publisher: one process, one roscpp, intra-process delivery.
#include <atomic>
#include <cmath>
#include <cstdint>
#include <mutex>
#include <vector>

#include <boost/make_shared.hpp>
#include <gtest/gtest.h>
#include <nodelet/loader.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <std_msgs/UInt64.h>

#include "rbpf_slam/TrunkArray.h"

namespace
{
const char* const kNodelet = "/zero_copy_extraction";

sensor_msgs::PointCloud2::Ptr makeCloud(int index)
{
  auto cloud = boost::make_shared<sensor_msgs::PointCloud2>();
  cloud->header.stamp = ros::Time(3000 + index);
  cloud->header.frame_id = "velodyne";
  sensor_msgs::PointCloud2Modifier modifier(*cloud);
  modifier.setPointCloud2FieldsByString(1, "xyz");
  modifier.resize(200);
  sensor_msgs::PointCloud2Iterator<float> x(*cloud, "x"), y(*cloud, "y"), z(*cloud, "z");
  for (int i = 0; i < 200; ++i, ++x, ++y, ++z)
  {
    const double phi = 2.0 + 0.01 * (i % 20);
    *x = static_cast<float>(4.0 + 0.2 * std::cos(phi));
    *y = static_cast<float>(0.2 * std::sin(phi));
    *z = static_cast<float>(-1.0 + 0.1 * (i / 20));
  }
  return cloud;
}

template <typename Predicate>
bool waitFor(Predicate done, double seconds)
{
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(seconds);
  while (!done() && ros::WallTime::now() < deadline && ros::ok())
    ros::WallDuration(0.01).sleep();
  return done();
}
}  // namespace

TEST(TrunkExtractionZeroCopy, NodeletInTheSameManagerReceivesThePublishedObject)
{
  ros::NodeHandle nh;
  ros::AsyncSpinner spinner(2);
  spinner.start();

  nodelet::Loader manager;  // this process is the manager
  ASSERT_TRUE(manager.load(kNodelet, "rbpf_slam/TrunkExtractionNodelet", nodelet::M_string(), nodelet::V_string()));

  std::mutex mutex;
  std::vector<std::uint64_t> received;
  std::atomic<int> answers{ 0 };
  ros::Subscriber address_sub = nh.subscribe<std_msgs::UInt64>(
      std::string(kNodelet) + "/input_address", 10, [&](const std_msgs::UInt64::ConstPtr& msg) {
        std::lock_guard<std::mutex> lock(mutex);
        received.push_back(msg->data);
      });
  ros::Subscriber trunks_sub =
      nh.subscribe<rbpf_slam::TrunkArray>("trunks", 10, [&](const rbpf_slam::TrunkArray::ConstPtr&) { ++answers; });
  ros::Publisher cloud_pub = nh.advertise<sensor_msgs::PointCloud2>("points", 10);
  ASSERT_TRUE(waitFor([&] { return cloud_pub.getNumSubscribers() > 0 && address_sub.getNumPublishers() > 0 &&
                                   trunks_sub.getNumPublishers() > 0; },
                      20.0))
      << "the nodelet did not connect";
  ros::WallDuration(0.5).sleep();

  std::vector<sensor_msgs::PointCloud2::ConstPtr> published;  // kept alive: no address is reused
  for (int i = 0; i < 5; ++i)
  {
    const sensor_msgs::PointCloud2::ConstPtr cloud = makeCloud(i);
    published.push_back(cloud);
    cloud_pub.publish(cloud);
    ASSERT_TRUE(waitFor([&] {
      std::lock_guard<std::mutex> lock(mutex);
      return received.size() == published.size();
    }, 10.0)) << "no address reported for cloud " << i;
  }
  for (std::size_t i = 0; i < published.size(); ++i)
    EXPECT_EQ(received[i], static_cast<std::uint64_t>(reinterpret_cast<std::uintptr_t>(published[i].get())))
        << "cloud " << i << " reached the nodelet as a different object (copied)";
  EXPECT_TRUE(waitFor([&] { return answers.load() == 5; }, 10.0)) << "trunks answered " << answers.load() << " of 5";

  manager.unload(kNodelet);
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "trunk_extraction_zero_copy");
  return RUN_ALL_TESTS();
}
