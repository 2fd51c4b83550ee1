#ifndef RBPF_SLAM_ROS_ANY_STAMPED_H
#define RBPF_SLAM_ROS_ANY_STAMPED_H

#include <ros/message_traits.h>
#include <ros/serialization.h>
#include <std_msgs/Header.h>

namespace rbpf_slam
{
/**
 * @brief Subscribes to any message type that starts with a std_msgs/Header and reads only that
 * header (the md5 "*" wildcard is accepted by every publisher). Used by lockstep waiting, which only
 * needs to know that a consumer has produced its output for a stamp.
 */
struct AnyStamped
{
  std_msgs::Header header;
};

}  // namespace rbpf_slam

namespace ros
{
namespace message_traits
{
template <>
struct MD5Sum<rbpf_slam::AnyStamped>
{
  static const char* value() { return "*"; }
  static const char* value(const rbpf_slam::AnyStamped&) { return "*"; }
};
template <>
struct DataType<rbpf_slam::AnyStamped>
{
  static const char* value() { return "*"; }
  static const char* value(const rbpf_slam::AnyStamped&) { return "*"; }
};
template <>
struct Definition<rbpf_slam::AnyStamped>
{
  static const char* value() { return ""; }
  static const char* value(const rbpf_slam::AnyStamped&) { return ""; }
};
}  // namespace message_traits

namespace serialization
{
template <>
struct Serializer<rbpf_slam::AnyStamped>
{
  template <typename Stream>
  inline static void read(Stream& stream, rbpf_slam::AnyStamped& m)
  {
    stream.next(m.header);  // the rest of the message is not needed
  }
  template <typename Stream>
  inline static void write(Stream& stream, const rbpf_slam::AnyStamped& m)
  {
    stream.next(m.header);
  }
  inline static uint32_t serializedLength(const rbpf_slam::AnyStamped& m)
  {
    return serializationLength(m.header);
  }
};
}  // namespace serialization
}  // namespace ros

#endif  // RBPF_SLAM_ROS_ANY_STAMPED_H
