#include <memory>

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include "rbpf_slam/ros/trunk_extraction.h"

namespace rbpf_slam
{
/** @brief Nodelet shell around TrunkExtraction. */
class TrunkExtractionNodelet : public nodelet::Nodelet
{
private:
  void onInit() override { extraction_.reset(new TrunkExtraction(getNodeHandle(), getPrivateNodeHandle())); }

  std::unique_ptr<TrunkExtraction> extraction_;
};

}  // namespace rbpf_slam

PLUGINLIB_EXPORT_CLASS(rbpf_slam::TrunkExtractionNodelet, nodelet::Nodelet)
