#include "ioct/scan/quintic_transition.hpp"

#include <algorithm>
#include <cmath>

namespace ioct::scan {
namespace {

// Real roots of a + b x + c x^2 inside [0, 1], passed to `visit`.
template <typename Visit>
void roots_in_unit_interval(double a, double b, double c, Visit visit) {
  const auto consider = [&](double x) {
    if (x >= 0.0 && x <= 1.0) visit(x);
  };
  if (std::fabs(c) < 1e-300) {
    if (std::fabs(b) > 1e-300) consider(-a / b);
    return;
  }
  const double disc = b * b - 4.0 * c * a;
  if (disc < 0.0) return;
  const double s = std::sqrt(disc);
  consider((-b + s) / (2.0 * c));
  consider((-b - s) / (2.0 * c));
}

}  // namespace

QuinticTransition::QuinticTransition(double p0, double v0, double p1, double v1,
                                     double duration) noexcept
    : duration_(duration) {
  const double delta = p1 - p0;
  const double w0 = v0 * duration;  // velocities in position per unit tau
  const double w1 = v1 * duration;
  c_[0] = p0;
  c_[1] = w0;
  c_[2] = 0.0;  // zero acceleration at the start
  c_[3] = 10.0 * delta - 6.0 * w0 - 4.0 * w1;
  c_[4] = -15.0 * delta + 8.0 * w0 + 7.0 * w1;
  c_[5] = 6.0 * delta - 3.0 * w0 - 3.0 * w1;
}

double QuinticTransition::position(double t) const noexcept {
  const double x = t / duration_;
  return c_[0] + x * (c_[1] + x * (c_[2] + x * (c_[3] + x * (c_[4] + x * c_[5]))));
}

double QuinticTransition::velocity(double t) const noexcept {
  const double x = t / duration_;
  return (c_[1] + x * (2 * c_[2] + x * (3 * c_[3] + x * (4 * c_[4] + x * 5 * c_[5])))) / duration_;
}

double QuinticTransition::acceleration(double t) const noexcept {
  const double x = t / duration_;
  return (2 * c_[2] + x * (6 * c_[3] + x * (12 * c_[4] + x * 20 * c_[5]))) /
         (duration_ * duration_);
}

double QuinticTransition::peak_velocity() const noexcept {
  // |v| peaks at an end or where the acceleration, tau (6 c3 + 12 c4 tau + 20 c5 tau^2), is 0.
  double peak = std::max(std::fabs(velocity(0.0)), std::fabs(velocity(duration_)));
  roots_in_unit_interval(6 * c_[3], 12 * c_[4], 20 * c_[5], [&](double x) {
    peak = std::max(peak, std::fabs(velocity(x * duration_)));
  });
  return peak;
}

double QuinticTransition::peak_acceleration() const noexcept {
  // |a| peaks at an end or where the jerk, 6 c3 + 24 c4 tau + 60 c5 tau^2, is 0.
  double peak = std::max(std::fabs(acceleration(0.0)), std::fabs(acceleration(duration_)));
  roots_in_unit_interval(6 * c_[3], 24 * c_[4], 60 * c_[5], [&](double x) {
    peak = std::max(peak, std::fabs(acceleration(x * duration_)));
  });
  return peak;
}

}  // namespace ioct::scan
