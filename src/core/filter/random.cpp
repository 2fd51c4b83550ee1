#include "rbpf_slam/core/filter/random.h"

#include <cmath>

namespace rbpf_slam
{
namespace core
{
double Random::gaussian()
{
  if (has_spare_)
  {
    has_spare_ = false;
    return spare_;
  }
  double u = 0.0;
  double v = 0.0;
  double s = 0.0;
  do
  {
    u = 2.0 * uniform() - 1.0;
    v = 2.0 * uniform() - 1.0;
    s = u * u + v * v;
  } while (s >= 1.0 || s == 0.0);
  const double factor = std::sqrt(-2.0 * std::log(s) / s);
  spare_ = v * factor;
  has_spare_ = true;
  return u * factor;
}

}  // namespace core
}  // namespace rbpf_slam
