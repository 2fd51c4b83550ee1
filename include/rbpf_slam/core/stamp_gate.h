#ifndef RBPF_SLAM_CORE_STAMP_GATE_H
#define RBPF_SLAM_CORE_STAMP_GATE_H

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
  kReset       ///< before the previous one by more than the threshold: a new timeline (looped bag, restarted
               ///< simulation); start over from this message
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
    case StampVerdict::kReset:
      return "a jump back in time";
  }
  return "?";
}

/**
 * @brief The one rule for message stamps in every node and the bag runner: a stream's stamps must increase; one
 * that goes back by more than @p threshold [s] is a real jump (a looped bag, a restarted simulation) and starts a
 * new timeline; one that goes back less is a late message and is dropped, as is one stamped more than
 * @p threshold after the clock (the node's ros::Time::now(), the bag's record time offline), so that a single
 * wrong stamp can neither reset a filter nor make every later message look late.
 */
class StampGate
{
public:
  explicit StampGate(double threshold = 1.0) : threshold_(threshold) {}

  /**
   * @param stamp the message's stamp [s]
   * @param clock the current time of the data's clock [s]; NaN when there is none (the future test is skipped)
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
 * increase; a real jump back on either one starts a new timeline for both, so that the other stream's next
 * message does not look like a second jump.
 */
class TimelineGate
{
public:
  enum Stream
  {
    kOdometry = 0,
    kSensor = 1
  };
  explicit TimelineGate(double threshold = 1.0) : gates_{ StampGate(threshold), StampGate(threshold) } {}
  /** @brief StampGate::check() on @p stream; on kReset both streams restart here and restarts() counts it. */
  StampVerdict check(Stream stream, double stamp, double clock = NAN)
  {
    const StampVerdict v = gates_[stream].check(stamp, clock);
    if (v == StampVerdict::kReset)
    {
      gates_[0].reset();
      gates_[1].reset();
      gates_[stream].check(stamp);
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
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_STAMP_GATE_H
