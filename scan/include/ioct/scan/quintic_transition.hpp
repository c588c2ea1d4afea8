// The move between two lines: a quintic in time that matches position and velocity at both ends
// with zero acceleration there, so position, velocity and acceleration are continuous across the
// whole trajectory and the jerk stays finite (a minimum-jerk profile when both velocities are 0).
// Its duration is fixed (the flyback sweeps); whether the galvo can follow is checked against
// the peak velocity and acceleration, which are found exactly (roots of quadratics).
#pragma once

namespace ioct::scan {

class QuinticTransition {
 public:
  // From p0 moving at v0 to p1 moving at v1 in `duration` (any unit of time; velocities in
  // position per that unit).
  QuinticTransition(double p0, double v0, double p1, double v1, double duration) noexcept;

  // Position at time t in [0, duration].
  double position(double t) const noexcept;
  double velocity(double t) const noexcept;
  double acceleration(double t) const noexcept;
  // Largest |velocity| and |acceleration| over [0, duration].
  double peak_velocity() const noexcept;
  double peak_acceleration() const noexcept;

 private:
  double duration_;
  double c_[6];  // p(tau) = sum c_i tau^i, tau = t / duration
};

}  // namespace ioct::scan
