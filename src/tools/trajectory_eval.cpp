// The evaluator of trajectories against a bag's reference path (the one place besides the simulator's
// evaluator that reads the truth): RPE over pose pairs 1 m of travel apart (m, deg) and ATE RMS after a
// least-squares SE(2) fit, for each TUM file given, matched to the reference by stamp.
//
//   rosrun rbpf_slam trajectory_eval --bag intel.bag [--truth /ground_truth/odom] [--travel 1.0]
//       [--write-reference FILE.tum] [--tolerance 0.001] RUN/estimate.tum RUN/odometry.tum ...
//
// Prints one line per file: name, poses matched, RPE mean translation [m] and rotation [deg], their RMS, ATE
// RMS after the fit [m].
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>

#include "rbpf_slam/core/evaluation.h"
#include "rbpf_slam/io/run_output.h"

using namespace rbpf_slam;

int main(int argc, char** argv)
{
  std::string bag_path, truth_topic = "/ground_truth/odom", write_ref;
  double travel = 1.0, tolerance = 1e-3;
  std::vector<std::string> files;
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    if (a == "--bag" && has)
      bag_path = argv[++i];
    else if (a == "--truth" && has)
      truth_topic = argv[++i];
    else if (a == "--travel" && has)
      travel = std::atof(argv[++i]);
    else if (a == "--tolerance" && has)
      tolerance = std::atof(argv[++i]);
    else if (a == "--write-reference" && has)
      write_ref = argv[++i];
    else if (!a.empty() && a[0] != '-')
      files.push_back(a);
    else
    {
      std::fprintf(stderr,
                   "usage: %s --bag FILE [--truth TOPIC] [--travel M] [--tolerance S] [--write-reference FILE.tum] "
                   "TUM...\n",
                   argv[0]);
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  if (bag_path.empty())
  {
    std::fprintf(stderr, "trajectory_eval: --bag is required\n");
    return 2;
  }
  try
  {
    std::vector<double> ref_t;
    std::vector<core::Pose2> ref_p;
    {
      rosbag::Bag bag(bag_path, rosbag::bagmode::Read);
      rosbag::View view(bag, rosbag::TopicQuery(truth_topic));
      for (const auto& m : view)
        if (const auto od = m.instantiate<nav_msgs::Odometry>())
        {
          const auto& q = od->pose.pose.orientation;
          ref_t.push_back(od->header.stamp.toSec());
          ref_p.emplace_back(od->pose.pose.position.x, od->pose.pose.position.y,
                             std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z)));
        }
    }
    if (ref_t.empty())
      throw std::runtime_error(bag_path + ": no nav_msgs/Odometry on " + truth_topic);
    if (!write_ref.empty())
      io::writeTum(write_ref, ref_t, ref_p);
    std::printf("%-40s %7s %9s %9s %9s %9s %9s\n", "trajectory", "poses", "RPE m", "RPE deg", "RPErms m", "RPErms deg",
                "ATE m");
    for (const auto& f : files)
    {
      std::vector<double> t;
      std::vector<core::Pose2> p;
      io::readTum(f, &t, &p);
      // Match by stamp (both sorted): the reference pose with the nearest stamp within the tolerance.
      std::vector<core::Pose2> est, ref;
      std::size_t j = 0;
      for (std::size_t i = 0; i < t.size(); ++i)
      {
        while (j + 1 < ref_t.size() && std::abs(ref_t[j + 1] - t[i]) <= std::abs(ref_t[j] - t[i]))
          ++j;
        if (std::abs(ref_t[j] - t[i]) <= tolerance)
        {
          est.push_back(p[i]);
          ref.push_back(ref_p[j]);
        }
      }
      const core::RelativePoseError r = core::relativePoseError(est, ref, travel);
      const double ate = core::alignedTrajectoryRmse(est, ref);
      std::printf("%-40s %7zu %9.4f %9.3f %9.4f %9.3f %9.4f\n", f.c_str(), est.size(), r.translation_mean,
                  r.rotation_mean * 180.0 / M_PI, r.translation_rms, r.rotation_rms * 180.0 / M_PI, ate);
    }
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "trajectory_eval: %s\n", e.what());
    return 1;
  }
  return 0;
}
