// One mirror's move between two lines, planned to stay within the galvo's limits and the field.
//
// The first choice is a single quintic that matches position and velocity at both ends (see
// QuinticTransition). Its excursion grows with the line speed times the duration, so for a long
// or fast turn it can overshoot the field where a gentler profile would not; then the move is
// planned as brake – move – accelerate: a quintic from the line's speed to rest, a rest-to-rest
// minimum-jerk move, and a quintic from rest up to the next line's speed. All pieces meet with
// equal position, velocity and zero acceleration, so the trajectory stays C2. The first profile
// that keeps within every limit is taken; when none does, the one closest to feasible is kept
// and the planner's checks refuse it.
#pragma once

#include <array>
#include <cstddef>

#include "ioct/scan/quintic_transition.hpp"

namespace ioct::scan {

class AxisMove {
 public:
  // From p0 at velocity v0 to p1 at v1 in `duration` sweeps (velocities per sweep), for limits
  // given per sweep and per sweep squared. Positions are judged at the whole sweeps in between.
  static AxisMove plan(double p0, double v0, double p1, double v1, double duration,
                       double max_velocity, double max_acceleration);

  double position(double t) const noexcept;
  double peak_velocity() const noexcept;
  double peak_acceleration() const noexcept;
  // Largest |position| at the whole sweeps 1 .. duration - 1.
  double peak_position() const noexcept;
  std::size_t pieces() const noexcept { return count_; }

 private:
  struct Piece {
    double start = 0.0;  // time the piece begins
    QuinticTransition curve{0, 0, 0, 0, 1};
  };
  AxisMove() = default;
  void add(double start, const QuinticTransition& curve) noexcept;

  std::array<Piece, 3> pieces_{};
  std::size_t count_ = 0;
  double duration_ = 0.0;
};

}  // namespace ioct::scan
