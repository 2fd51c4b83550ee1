#ifndef RBPF_SLAM_CORE_FILTER_RANDOM_H
#define RBPF_SLAM_CORE_FILTER_RANDOM_H

#include <cstdint>
#include <random>

namespace rbpf_slam
{
namespace core
{
/**
 * @brief The seeded random source owned by every filter and simulator.
 *
 * std::mt19937_64 is fully specified by the standard, but the std distributions are not: the same
 * seed gives other numbers with another standard library. The draws are therefore made here from the
 * raw 64-bit output, so a seed reproduces a run on any compiler.
 */
class Random
{
public:
  explicit Random(std::uint64_t seed = 0) : engine_(seed) {}

  /** @brief Restarts the sequence from @p seed. */
  void seed(std::uint64_t seed)
  {
    engine_.seed(seed);
    has_spare_ = false;
  }

  /** @brief Uniform in [0, 1), 53 random bits. */
  double uniform()
  {
    return static_cast<double>(engine_() >> 11) * (1.0 / 9007199254740992.0);
  }

  /** @brief Uniform in [lo, hi). */
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

  /** @brief Uniform integer in [0, n); n must be > 0. */
  std::uint64_t uniformIndex(std::uint64_t n) { return static_cast<std::uint64_t>(uniform() * n) % n; }

  /** @brief Standard normal N(0, 1) (Marsaglia polar method). */
  double gaussian();

  /** @brief N(0, sigma^2); exactly 0 and no draw when sigma == 0. */
  double gaussian(double sigma) { return sigma == 0.0 ? 0.0 : sigma * gaussian(); }

  /** @brief The raw engine, for code that needs 64-bit words (e.g. deriving child seeds). */
  std::mt19937_64& engine() { return engine_; }

private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

}  // namespace core
}  // namespace rbpf_slam

#endif  // RBPF_SLAM_CORE_FILTER_RANDOM_H
