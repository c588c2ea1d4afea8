#include "ioct/scan/axis_move.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ioct::scan {

void AxisMove::add(double start, const QuinticTransition& curve) noexcept {
  pieces_[count_++] = {start, curve};
}

double AxisMove::position(double t) const noexcept {
  std::size_t i = count_ - 1;
  while (i > 0 && t < pieces_[i].start) --i;
  return pieces_[i].curve.position(t - pieces_[i].start);
}

double AxisMove::peak_velocity() const noexcept {
  double peak = 0.0;
  for (std::size_t i = 0; i < count_; ++i) peak = std::max(peak, pieces_[i].curve.peak_velocity());
  return peak;
}

double AxisMove::peak_acceleration() const noexcept {
  double peak = 0.0;
  for (std::size_t i = 0; i < count_; ++i) {
    peak = std::max(peak, pieces_[i].curve.peak_acceleration());
  }
  return peak;
}

double AxisMove::peak_position() const noexcept {
  double peak = 0.0;
  for (double t = 1.0; t < duration_; t += 1.0) peak = std::max(peak, std::fabs(position(t)));
  return peak;
}

AxisMove AxisMove::plan(double p0, double v0, double p1, double v1, double duration,
                        double max_velocity, double max_acceleration) {
  const auto worst_ratio = [&](const AxisMove& m) {
    return std::max({m.peak_velocity() / max_velocity, m.peak_acceleration() / max_acceleration,
                     m.peak_position()});
  };
  AxisMove single;
  single.duration_ = duration;
  single.add(0.0, QuinticTransition(p0, v0, p1, v1, duration));
  double best_ratio = worst_ratio(single);
  if (best_ratio <= 1.0) return single;
  AxisMove best = single;

  // Brake – move – accelerate. Each end takes at least the time that keeps its own peak
  // acceleration (1.5 v / T for a quintic to rest) 5% under the limit, or a fraction of the move.
  const double brake_min = 1.575 * std::fabs(v0) / max_acceleration;
  const double speed_up_min = 1.575 * std::fabs(v1) / max_acceleration;
  for (const double fraction : {0.0, 1.0 / 16, 1.0 / 8, 1.0 / 4, 1.0 / 3}) {
    const double brake = v0 == 0.0 ? 0.0 : std::max(brake_min, fraction * duration);
    const double speed_up = v1 == 0.0 ? 0.0 : std::max(speed_up_min, fraction * duration);
    const double middle = duration - brake - speed_up;
    if (middle <= 0.1 * duration) continue;
    const double stop = p0 + v0 * brake / 2.0;   // where a quintic from v0 to rest ends
    const double go = p1 - v1 * speed_up / 2.0;  // where one from rest to v1 starts
    AxisMove m;
    m.duration_ = duration;
    if (brake > 0.0) m.add(0.0, QuinticTransition(p0, v0, stop, 0.0, brake));
    m.add(brake, QuinticTransition(stop, 0.0, go, 0.0, middle));
    if (speed_up > 0.0) m.add(brake + middle, QuinticTransition(go, 0.0, p1, v1, speed_up));
    const double ratio = worst_ratio(m);
    if (ratio <= 1.0) return m;
    if (ratio < best_ratio) {
      best_ratio = ratio;
      best = m;
    }
  }
  return best;
}

}  // namespace ioct::scan
