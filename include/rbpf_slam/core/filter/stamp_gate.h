#ifndef RBPF_SLAM_CORE_FILTER_STAMP_GATE_H
#define RBPF_SLAM_CORE_FILTER_STAMP_GATE_H

#include <cmath>

namespace rbpf_slam
{
namespace core
{
/** @brief What StampGate::check() makes of a message's stamp. */
enum class StampVerdict
{
  kAccept,     ///< after the previous one: use it
  kInvalid,    ///< not finite: drop it
  kDuplicate,  ///< the previous one's stamp again: drop it
  kLate,       ///< before the previous one by less than the threshold (out of order): drop it
  kFuture,     ///< after the clock by more than the threshold (a wrong stamp): drop it
  kBack,       ///< before the previous one by more than the threshold while the clock went on: one message alone
               ///< does not make a new timeline; dropped until more agree (TimelineGate)
  kOverLimit,  ///< more than a configured bound holds (e.g. trunks per sweep): dropped (not a stamp verdict; the
               ///< pipelines' add functions give it)
  kReset       ///< time itself jumped back (the clock, or several messages that agree): a new timeline (looped bag,
               ///< restarted simulation); start over from this message
};

inline const char* stampVerdictName(StampVerdict v)
{
  switch (v)
  {
    case StampVerdict::kAccept:
      return "accepted";
    case StampVerdict::kInvalid:
      return "not finite";
    case StampVerdict::kDuplicate:
      return "the previous stamp again";
    case StampVerdict::kLate:
      return "before the previous stamp";
    case StampVerdict::kFuture:
      return "ahead of the clock";
    case StampVerdict::kBack:
      return "before the previous stamp by more than the time jump threshold (the clock went on)";
    case StampVerdict::kOverLimit:
      return "more detections than the sensor can see (max_trunks_per_sweep)";
    case StampVerdict::kReset:
      return "a jump back in time";
  }
  return "?";
}

/**
 * @brief The one rule for message stamps in every node and the bag runner: a stream's stamps must increase. A stamp
 * before the previous one is dropped: as late when it is back by less than @p threshold [s]; when it is back by more,
 * it is a jump of time itself (kReset: a looped bag, a restarted simulation) only if the clock went back with it,
 * else kBack (TimelineGate then asks for several messages that agree). A stamp more than @p threshold after the
 * clock (the node's ros::Time::now(), the bag's record time offline) is dropped as wrongly stamped. So a single
 * wrong stamp can neither reset a filter nor make every later message look late.
 */
class StampGate
{
public:
  explicit StampGate(double threshold = 1.0) : threshold_(threshold) {}

  /**
   * @param stamp the message's stamp [s]
   * @param clock the current time of the data's clock [s]; NaN when there is none (the future test is skipped, and
   * a jump back is never confirmed by the clock)
   */
  StampVerdict check(double stamp, double clock = NAN)
  {
    if (!std::isfinite(stamp))
      return StampVerdict::kInvalid;
    if (std::isfinite(clock) && stamp > clock + threshold_)
      return StampVerdict::kFuture;
    if (have_last_)
    {
      if (stamp == last_)
        return StampVerdict::kDuplicate;
      if (stamp < last_)
      {
        if (last_ - stamp <= threshold_)
          return StampVerdict::kLate;
        if (!(std::isfinite(clock) && clock < last_ - threshold_))
          return StampVerdict::kBack;  // the clock went on: this message alone is no new timeline
        last_ = stamp;
        return StampVerdict::kReset;
      }
    }
    last_ = stamp;
    have_last_ = true;
    return StampVerdict::kAccept;
  }

  /** @brief Forgets the previous stamp: the next one is accepted whatever it is. */
  void reset() { have_last_ = false; }
  bool hasLast() const { return have_last_; }
  double last() const { return last_; }
  double threshold() const { return threshold_; }

private:
  double threshold_;
  double last_ = 0.0;
  bool have_last_ = false;
};

/**
 * @brief The stamp rule for a pipeline's two streams (odometry and its sensor): each stream's stamps must
 * increase; time jumping back on either one starts a new timeline for both, so that the other stream's next
 * message does not look like a second jump. Time has jumped back when the clock went back with the stamps, or when
 * kJumpConfirmations messages in a row (either stream) are back by more than the threshold and agree with each other
 * (within the threshold of the first), with no message of the old timeline between them. Those before the last
 * are dropped; a message that continues the old timeline forgets them. A stream's first message in a timeline is
 * held against the other stream: back by more than the threshold with the clock, it starts a new timeline too (a bag
 * of odometry alone, then one with the sensor).
 */
class TimelineGate
{
public:
  enum Stream
  {
    kOdometry = 0,
    kSensor = 1
  };
  /// Messages back in time, in a row and agreeing, that make a new timeline when the clock does not say so.
  static constexpr int kJumpConfirmations = 3;

  explicit TimelineGate(double threshold = 1.0) : gates_{ StampGate(threshold), StampGate(threshold) } {}
  /** @brief StampGate::check() on @p stream; on kReset both streams restart here and restarts() counts it. */
  StampVerdict check(Stream stream, double stamp, double clock = NAN)
  {
    const bool first = !gates_[stream].hasLast();
    StampVerdict v = gates_[stream].check(stamp, clock);
    const StampGate& other = gates_[1 - stream];
    if (v == StampVerdict::kAccept && first && other.hasLast() && stamp < other.last() - threshold() &&
        std::isfinite(clock) && clock < other.last() - threshold())
      v = StampVerdict::kReset;  // the stream's first message, and time went back before it came (the clock too)
    else if (v == StampVerdict::kAccept)
      back_count_ = 0;  // the old timeline goes on
    else if (v == StampVerdict::kBack)
    {
      if (back_count_ == 0 || std::abs(stamp - back_first_) > threshold())
      {
        back_first_ = stamp;
        back_count_ = 0;
      }
      if (++back_count_ >= kJumpConfirmations)
        v = StampVerdict::kReset;
    }
    if (v == StampVerdict::kReset)
    {
      gates_[0].reset();
      gates_[1].reset();
      gates_[stream].check(stamp);
      back_count_ = 0;
      ++restarts_;
    }
    return v;
  }
  /** @brief The stream's previous accepted stamp (0 before any). */
  double last(Stream stream) const { return gates_[stream].last(); }
  double threshold() const { return gates_[0].threshold(); }
  int restarts() const { return restarts_; }

private:
  StampGate gates_[2];
  int restarts_ = 0;
  int back_count_ = 0;       ///< messages back in time in a row, agreeing with the first of them
  double back_first_ = 0.0;  ///< [s] that first one's stamp
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FILTER_STAMP_GATE_H
