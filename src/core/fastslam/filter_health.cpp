#include "rbpf_slam/core/fastslam/filter_health.h"

#include <algorithm>
#include <cstdio>

namespace rbpf_slam
{
namespace core
{
FilterHealth::FilterHealth(const HealthConfig& config) : config_(config)
{
}

const char* toString(HealthLevel level)
{
  return level == HealthLevel::kWarn ? "warn" : "ok";
}

const char* toString(HealthCause cause)
{
  switch (cause)
  {
    case HealthCause::kRecreated:
      return "recreated";
    case HealthCause::kUnmatched:
      return "unmatched";
    case HealthCause::kInconsistent:
      return "inconsistent";
    case HealthCause::kOverconfident:
      return "overconfident";
    case HealthCause::kSavedMapUnobserved:
      return "saved_map_unobserved";
    default:
      return "none";
  }
}

void FilterHealth::revisit(bool consistent, const std::string& why)
{
  inconsistent_ = !consistent;
  inconsistent_why_ = consistent ? std::string() : why;
}

const HealthStatus& FilterHealth::add(const FastSlamUpdateStats& s, int particles)
{
  window_.push_back({ particles > 0 ? s.neff / particles : 1.0, s.resampled, s.relocalizing, s.observations,
                      s.matched, s.matched_confirmed, s.matched_prior, s.created, s.recreated, s.deleted, s.innovation_nis, s.claimed_nis,
                      s.claimed_matches });
  while (static_cast<int>(window_.size()) > std::max(1, config_.window))
    window_.pop_front();
  HealthStatus h;
  h.updates = static_cast<int>(window_.size());
  h.pose_spread = s.pose_spread;
  double neff = 0.0;
  int resampled = 0, relocalizing = 0, matched_confirmed = 0, matched = 0, matched_prior = 0;
  double nis = 0.0, claimed = 0.0;
  int claimed_matches = 0;
  for (const Entry& e : window_)
  {
    claimed += e.claimed_nis;
    claimed_matches += e.claimed_matches;
    neff += e.neff_ratio;
    resampled += e.resampled ? 1 : 0;
    relocalizing += e.relocalizing ? 1 : 0;
    h.observations += e.observations;
    matched_confirmed += e.matched_confirmed;
    matched_prior += e.matched_prior;
    h.created += e.created;
    h.recreated += e.recreated;
    h.deleted += e.deleted;
    matched += e.matched;
    nis += e.nis;
  }
  h.mean_nis = matched > 0 ? nis / matched : 0.0;
  h.claimed_nis = claimed_matches > 0 ? claimed / claimed_matches : 0.0;
  h.overconfident = claimed_matches >= config_.min_observations && h.claimed_nis > config_.claimed_nis_warn;
  int recent_updates = 0, recent_observations = 0, recent_prior = 0;
  for (auto it = window_.rbegin(); it != window_.rend() && recent_updates < config_.prior_window; ++it)
  {
    ++recent_updates;
    recent_observations += it->observations;
    recent_prior += it->matched_prior;
  }
  h.neff_ratio = neff / h.updates;
  h.resampled_share = static_cast<double>(resampled) / h.updates;
  h.relocalizing_share = static_cast<double>(relocalizing) / h.updates;
  h.matched_confirmed_share = h.observations > 0 ? static_cast<double>(matched_confirmed) / h.observations : 0.0;
  h.matched_prior_share = h.observations > 0 ? static_cast<double>(matched_prior) / h.observations : 0.0;
  char why[512];
  h.saved_map_unobserved = config_.matched_prior_warn >= 0.0 && recent_updates >= config_.prior_window &&
                           recent_observations >= config_.min_observations &&
                           recent_prior < config_.matched_prior_warn * recent_observations;
  h.map_inconsistent = inconsistent_;
  if (config_.recreated_warn > 0 && h.recreated >= config_.recreated_warn)
  {
    h.level = HealthLevel::kWarn;
    h.cause = HealthCause::kRecreated;
    std::snprintf(why, sizeof(why),
                  "map being rebuilt: %d new landmarks where confirmed ones were deleted in the last %d updates "
                  "(the pose is likely lost)",
                  h.recreated, h.updates);
  }
  else if (h.updates >= config_.window && h.observations >= config_.min_observations &&
           h.matched_confirmed_share < config_.matched_confirmed_warn &&
           h.created > matched_confirmed)
  {
    h.level = HealthLevel::kWarn;
    h.cause = HealthCause::kUnmatched;
    std::snprintf(why, sizeof(why),
                  "map being rebuilt: %.0f %% of %d observations matched confirmed landmarks, %d new landmarks in the "
                  "last %d updates",
                  100.0 * h.matched_confirmed_share, h.observations, h.created, h.updates);
  }
  else if (h.map_inconsistent)
  {
    h.level = HealthLevel::kWarn;
    h.cause = HealthCause::kInconsistent;
    std::snprintf(why, sizeof(why),
                  "map inconsistent: the smoother could not bring a revisit's trees together with the map (%s); the "
                  "map is bent where the robot came back, until a loop closes",
                  inconsistent_why_.c_str());
  }
  else if (h.overconfident)
  {
    h.level = HealthLevel::kWarn;
    h.cause = HealthCause::kOverconfident;
    std::snprintf(why, sizeof(why),
                  "overconfident: the innovations average %.1f per match (2 expected) against the uncertainty the "
                  "filter claims, over %d matches in the last %d updates: the pose is further off than the particles' "
                  "spread says",
                  h.claimed_nis, claimed_matches, h.updates);
  }
  else if (h.saved_map_unobserved)
  {
    h.level = HealthLevel::kWarn;
    h.cause = HealthCause::kSavedMapUnobserved;
    std::snprintf(why, sizeof(why),
                  "saved map not re-observed: %d of %d observations matched its trees in the last %d updates (the "
                  "pose is likely lost, or the robot is outside the saved map)",
                  recent_prior, recent_observations, recent_updates);
  }
  else
    std::snprintf(why, sizeof(why), "ok: %.0f %% of %d observations matched confirmed landmarks, mean Neff %.0f %%",
                  100.0 * h.matched_confirmed_share, h.observations, 100.0 * h.neff_ratio);
  h.message = why;
  if (h.level == HealthLevel::kWarn)
    ++warnings_;
  status_ = h;
  return status_;
}

}  // namespace core
}  // namespace rbpf_slam
