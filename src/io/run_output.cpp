#include "rbpf_slam/io/run_output.h"

#include "rbpf_slam/io/files.h"
#include "rbpf_slam/io/forest_map_file.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace rbpf_slam
{
namespace io
{
const char* const kLandmarksCsvHeader = kForestMapHeader;

std::string landmarksCsv(const std::vector<core::Landmark>& landmarks)
{
  ForestMap map;
  map.trees = landmarks;
  return forestMapCsv(map);
}

void writeLandmarksCsv(const std::string& path, const std::vector<core::Landmark>& landmarks)
{
  writeFileAtomic(path, landmarksCsv(landmarks));
}

FastSlamRunRecord::FastSlamRunRecord(bool keep_tables) : keep_tables_(keep_tables)
{
  for (std::ostringstream* s : { &estimate_, &odometry_, &table_, &loops_ })
    s->precision(12);
  table_ << "stamp,neff,resampled,landmarks,observations,matched,new,deleted,ignored,matched_confirmed,recreated,"
            "pose_spread,relocalizing,health,cloud_x,cloud_y,cloud_xx,cloud_xy,cloud_yy,loop,estimate_x,estimate_y,"
            "estimate_xx,estimate_xy,estimate_yy,health_cause\n";
  loops_ << "stamp,found,kind,matched,shift,seconds,covariance_seconds,keyframes,chi2,chi2_bound,dropped,reason\n";
}

void FastSlamRunRecord::addUpdate(const core::PipelineUpdate& u)
{
  if (u.relocalization.lost)
  {
    // A search while tracking (the health warned): counted apart from the search for the start.
    if (!lost_searching_)
      ++lost_searches_;
    lost_searching_ = !(u.relocalization.recovered || u.relocalization.confirmed || u.relocalization.gave_up);
    if (u.relocalization.gave_up)
      ++lost_gave_up_;
    if (u.relocalization.recovered)
      recoveries_.push_back(u.stamp);
    if (u.relocalization.confirmed)
      ++confirmations_;
  }
  else if (u.relocalization.active)
  {
    search_seconds_ += u.relocalization.seconds;
    max_search_seconds_ = std::max(max_search_seconds_, u.relocalization.seconds);
    last_reason_ = u.relocalization.reason;
    if (u.relocalization.found)
    {
      found_ = true;
      found_stamp_ = u.stamp;
      found_travel_ = u.relocalization.travel;
      found_hypotheses_ = u.relocalization.hypotheses;
      found_inliers_ = u.relocalization.best_inliers;
      found_trunks_ = u.relocalization.trunks;
    }
  }
  if (!u.localized)
  {
    ++searching_;
    return;
  }
  addUpdate(u.stamp, u.timeline, u.estimate, u.odometry, u.stats, u.health, u.loop, &u.covariance);
}

std::string FastSlamRunRecord::loopSummary() const
{
  if (loops_closed_ == 0 && loops_rejected_ == 0)
    return "";
  char buf[256];
  std::snprintf(buf, sizeof(buf), "loops: %d closed, %d refused by the smoother; the longest solve %.3f s",
                loops_closed_, loops_rejected_, max_loop_seconds_);
  return buf;
}

std::string FastSlamRunRecord::lostSummary() const
{
  if (lost_searches_ == 0)
    return "";
  std::string out = "the health warned and the saved map was searched again " + std::to_string(lost_searches_) +
                    " times while tracking: " + std::to_string(recoveries_.size()) +
                    " found the robot elsewhere and moved the particles there";
  char buf[64];
  for (std::size_t i = 0; i < recoveries_.size() && i < 5; ++i)
  {
    std::snprintf(buf, sizeof(buf), "%s%.3f s", i == 0 ? " (at " : ", ", recoveries_[i]);
    out += buf;
  }
  if (!recoveries_.empty())
    out += recoveries_.size() > 5 ? ", ...)" : ")";
  return out + ", " + std::to_string(confirmations_) + " found it where the estimate was, " +
         std::to_string(lost_gave_up_) + " found nothing within a window of travel";
}

std::string FastSlamRunRecord::relocalizationSummary() const
{
  if (!found_ && searching_ == 0)
    return "";
  char buf[512];
  if (found_)
    std::snprintf(buf, sizeof(buf),
                  "relocalized in the saved map at %.3f s after %.1f m of travel and %d sweeps of search: %d of %d "
                  "trunks explained, particles over %d hypotheses; search time %.3f s in all, %.3f s at most per sweep",
                  found_stamp_, found_travel_, searching_ + 1, found_inliers_, found_trunks_, found_hypotheses_,
                  search_seconds_, max_search_seconds_);
  else
    std::snprintf(buf, sizeof(buf), "not relocalized in the saved map after %d sweeps of search (%s)", searching_,
                  last_reason_.c_str());
  return buf;
}

void FastSlamRunRecord::addUpdate(double stamp, int timeline, const core::Pose2& estimate,
                                  const core::Pose2& odometry, const core::FastSlamUpdateStats& st,
                                  const core::HealthStatus& health, const core::LoopEvent& loop,
                                  const Eigen::Matrix3d* covariance)
{
  if (loop.kind != core::LoopEvent::Kind::kNone)
  {
    (loop.kind == core::LoopEvent::Kind::kClosed ? loops_closed_ : loops_rejected_) += 1;
    max_loop_seconds_ = std::max(max_loop_seconds_, loop.seconds);
    std::string reason = loop.reason;
    std::replace(reason.begin(), reason.end(), ',', ';');
    loops_ << stampText(stamp) << ',' << stampText(loop.found) << ',' << core::toString(loop.kind) << ','
           << loop.matched << ',' << loop.shift << ',' << loop.seconds << ',' << loop.seconds_covariance << ','
           << loop.keyframes << ',' << loop.identity_chi2 << ',' << loop.identity_bound << ',' << loop.dropped << ','
           << reason << '\n';
  }
  if (timeline != timeline_)
  {
    stamps_.clear();
    timeline_ = timeline;
  }
  ++updates_;
  if (keep_tables_)
  {
    if (st.has_cloud)
      stamps_.push_back(stamp);  // the filter's updates: the best particle's history has one pose for each
    writeTumLine(estimate_, stamp, estimate);
    writeTumLine(odometry_, stamp, odometry);
    table_ << stampText(stamp) << ',' << st.neff << ',' << (st.resampled ? 1 : 0) << ',' << st.landmarks << ','
           << st.observations << ',' << st.matched << ',' << st.created << ',' << st.deleted << ',' << st.ignored
           << ',' << st.matched_confirmed << ',' << st.recreated << ',' << st.pose_spread << ','
           << (st.relocalizing ? 1 : 0) << ',' << core::toString(health.level);
    if (st.has_cloud)
      table_ << ',' << st.cloud_mean.x() << ',' << st.cloud_mean.y() << ',' << st.cloud_covariance(0, 0) << ','
             << st.cloud_covariance(0, 1) << ',' << st.cloud_covariance(1, 1);
    else
      table_ << ",,,,,";
    table_ << ',' << core::toString(loop.kind) << ',' << estimate.x << ',' << estimate.y;
    if (covariance && covariance->allFinite() && (*covariance)(0, 0) > 0.0)
      table_ << ',' << (*covariance)(0, 0) << ',' << (*covariance)(0, 1) << ',' << (*covariance)(1, 1);
    else
      table_ << ",,,";
    table_ << ',' << core::toString(health.cause) << '\n';
  }
  if (health.level == core::HealthLevel::kWarn)
  {
    if (warnings_ == 0)
      first_warning_ = stamp;
    ++warnings_;
    ++warnings_by_cause_[core::toString(health.cause)];
    last_warning_ = stamp;
    last_warning_message_ = health.message;
  }
}

std::string FastSlamRunRecord::healthSummary() const
{
  std::ostringstream s;
  s.precision(12);
  if (warnings_ == 0)
  {
    s << "health ok: no update of " << updates_ << " warned";
    return s.str();
  }
  s << "health WARNING: " << warnings_ << " of " << updates_ << " updates warned (";
  const char* sep = "";
  for (const auto& c : warnings_by_cause_)
  {
    s << sep << c.first << ": " << c.second;
    sep = ", ";
  }
  s << "; from " << first_warning_ << " to " << last_warning_ << "); last: " << last_warning_message_;
  return s.str();
}

std::vector<FileContent> FastSlamRunRecord::files(const std::string& dir, const core::FastSlam& filter,
                                                  const core::SmoothedRun* smoothed) const
{
  std::vector<FileContent> out;
  out.emplace_back(dir + "/estimate.tum", estimate_.str());
  out.emplace_back(dir + "/odometry.tum", odometry_.str());
  // The best particle's own trajectory: one pose per update of the last timeline.
  const std::vector<core::Pose2> history = filter.bestHistory();
  const std::size_t n = std::min(history.size(), stamps_.size());
  std::ostringstream h;
  h.precision(12);
  for (std::size_t i = 0; i < n; ++i)
    writeTumLine(h, stamps_[stamps_.size() - n + i], history[history.size() - n + i]);
  out.emplace_back(dir + "/estimate_best_history.tum", h.str());
  out.emplace_back(dir + "/updates.csv", table_.str());
  out.emplace_back(dir + "/health.txt", healthSummary() + "\n");
  const core::Particle& best = filter.best();
  std::vector<core::Landmark> landmarks;
  for (std::size_t i = 0; i < best.map.size(); ++i)
    landmarks.push_back(best.map[i]);
  out.emplace_back(dir + "/map.csv", landmarksCsv(landmarks));
  out.emplace_back(dir + "/loops.csv", loops_.str());
  if (smoothed && smoothed->ok)
  {
    std::ostringstream t;
    t.precision(12);
    for (std::size_t i = 0; i < smoothed->poses.size(); ++i)
      writeTumLine(t, smoothed->stamps[i], smoothed->poses[i]);
    out.emplace_back(dir + "/estimate_smoothed.tum", t.str());
    out.emplace_back(dir + "/map_smoothed.csv", landmarksCsv(smoothed->trees));
  }
  return out;
}

std::vector<FileContent> FastSlamRunRecord::folder(const std::string& dir, const core::TrunkSlamPipeline& pipeline,
                                                   int sweeps, int updates, const core::SmoothedRun* smoothed) const
{
  const core::SmoothedRun run = smoothed ? *smoothed : pipeline.smoothed();
  std::vector<FileContent> out = files(dir, pipeline.filter(), &run);
  const core::FastSlamConfig& fc = pipeline.filter().config();
  out.emplace_back(dir + "/timing.json", timingJson(sweeps, updates, pipeline.secondsExtraction(),
                                                    pipeline.secondsFilter(), fc.particles, fc.seed));
  return out;
}

}  // namespace io
}  // namespace rbpf_slam
