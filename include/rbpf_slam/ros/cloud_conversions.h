#ifndef RBPF_SLAM_ROS_CLOUD_CONVERSIONS_H
#define RBPF_SLAM_ROS_CLOUD_CONVERSIONS_H

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <sensor_msgs/PointCloud2.h>

namespace rbpf_slam
{
/** @brief What readCloud() takes from a PointCloud2. */
struct CloudPoints
{
  std::vector<Eigen::Vector3f> points;  ///< the finite points (x, y, z in the cloud's frame)
  std::uint64_t total = 0;              ///< width * height
  bool has_time = false;                ///< a per-point "time" field [s after the stamp] was read
  double sweep_period = 0.0;            ///< the largest finite per-point time (0 without the field)
};

/// Per-point times beyond this [s] are not relative to the stamp (a driver's absolute stamps): such a cloud is
/// refused rather than deskewed by hours.
constexpr double kMaxPointTime = 1.0;

namespace detail
{
/** @brief Where one numeric field lies in a point, and how wide it is. */
struct CloudField
{
  std::uint32_t offset = 0;
  std::uint8_t datatype = 0;
  bool present = false;
};

/** @brief Finds field @p name; empty when it is absent (present = false) or usable, else why it is not. */
inline std::string findField(const sensor_msgs::PointCloud2& cloud, const std::string& name, CloudField* field)
{
  for (const auto& f : cloud.fields)
  {
    if (f.name != name)
      continue;
    std::uint32_t size = 0;
    if (f.datatype == sensor_msgs::PointField::FLOAT32)
      size = 4;
    else if (f.datatype == sensor_msgs::PointField::FLOAT64)
      size = 8;
    else
      return "field " + name + " is not float32 or float64 (datatype " + std::to_string(f.datatype) + ")";
    if (f.count < 1)
      return "field " + name + " has count 0";
    if (static_cast<std::uint64_t>(f.offset) + size > cloud.point_step)
      return "field " + name + " (offset " + std::to_string(f.offset) + ", " + std::to_string(size) +
             " bytes) lies outside point_step " + std::to_string(cloud.point_step);
    field->offset = f.offset;
    field->datatype = f.datatype;
    field->present = true;
    return "";
  }
  field->present = false;
  return "";
}

inline double readField(const std::uint8_t* point, const CloudField& f)
{
  if (f.datatype == sensor_msgs::PointField::FLOAT64)
  {
    double v;
    std::memcpy(&v, point + f.offset, sizeof(v));
    return v;
  }
  float v;
  std::memcpy(&v, point + f.offset, sizeof(v));
  return static_cast<double>(v);
}
}  // namespace detail

/**
 * @brief The one validated access to a PointCloud2, shared by the trunk extraction nodelet and the bag runner.
 * Checks once, before reading anything, every field it uses against point_step and the layout against the data
 * size: x, y, z (float32 or float64) must be there; "time" (float32 or float64, seconds after the stamp, as
 * Velodyne drivers and the simulator give it) is read when present and must then be well formed too; row_step
 * >= width * point_step (padded rows are read row by row); data holds exactly height * row_step bytes; the byte
 * order is this machine's. Then copies the finite points.
 * @return empty when the cloud was read, else why it is unusable (the caller warns and drops it: a dropped cloud
 * is no observation). A cloud whose points are all non-finite is unusable too.
 */
inline std::string readCloud(const sensor_msgs::PointCloud2& cloud, CloudPoints* out)
{
  out->points.clear();
  out->has_time = false;
  out->sweep_period = 0.0;
  out->total = static_cast<std::uint64_t>(cloud.width) * cloud.height;
  if (out->total == 0)
    return "empty cloud (width * height = 0)";
  detail::CloudField x, y, z, t;
  for (const auto& named : { std::make_pair("x", &x), std::make_pair("y", &y), std::make_pair("z", &z) })
  {
    const std::string why = detail::findField(cloud, named.first, named.second);
    if (!why.empty())
      return why;
    if (!named.second->present)
      return std::string("no field ") + named.first;
  }
  const std::string time_why = detail::findField(cloud, "time", &t);
  if (!time_why.empty())
    return time_why;
  const std::uint16_t one = 1;
  std::uint8_t first_byte;
  std::memcpy(&first_byte, &one, 1);
  const bool host_big_endian = first_byte == 0;
  if (static_cast<bool>(cloud.is_bigendian) != host_big_endian)
    return "byte order differs from this machine's";
  const std::uint64_t point_bytes = static_cast<std::uint64_t>(cloud.width) * cloud.point_step;
  if (cloud.row_step < point_bytes)
    return "row_step " + std::to_string(cloud.row_step) + " < width * point_step " + std::to_string(point_bytes);
  const std::uint64_t expected = static_cast<std::uint64_t>(cloud.height) * cloud.row_step;
  if (cloud.data.size() != expected)
    return "data holds " + std::to_string(cloud.data.size()) + " bytes, height * row_step is " +
           std::to_string(expected);

  out->has_time = t.present;
  out->points.reserve(static_cast<std::size_t>(out->total));
  double latest = 0.0;
  for (std::uint32_t row = 0; row < cloud.height; ++row)
  {
    const std::uint8_t* p = cloud.data.data() + static_cast<std::uint64_t>(row) * cloud.row_step;
    for (std::uint32_t col = 0; col < cloud.width; ++col, p += cloud.point_step)
    {
      if (t.present)  // the sweep's timing is the sensor's: every point's time counts, with a return or not
      {
        const double pt = detail::readField(p, t);
        if (std::isfinite(pt))
          latest = std::max(latest, pt);
      }
      const double px = detail::readField(p, x), py = detail::readField(p, y), pz = detail::readField(p, z);
      if (std::isfinite(px) && std::isfinite(py) && std::isfinite(pz))
        out->points.emplace_back(static_cast<float>(px), static_cast<float>(py), static_cast<float>(pz));
    }
  }
  if (out->points.empty())
    return "no finite point among " + std::to_string(out->total);
  if (latest > kMaxPointTime)
  {
    out->points.clear();
    return "per-point time reaches " + std::to_string(latest) + " s after the stamp (more than " +
           std::to_string(kMaxPointTime) + " s: not relative to the stamp)";
  }
  out->sweep_period = latest;
  return "";
}

}  // namespace rbpf_slam

#endif  // RBPF_SLAM_ROS_CLOUD_CONVERSIONS_H
