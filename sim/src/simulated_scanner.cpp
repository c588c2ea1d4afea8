#include "ioct/sim/simulated_scanner.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace ioct::sim {
namespace {

static_assert(std::atomic<float>::is_always_lock_free);

using Matrix3 = std::array<std::array<double, 3>, 3>;

Matrix3 multiply(const Matrix3& a, const Matrix3& b) {
  Matrix3 c{};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      for (int k = 0; k < 3; ++k) c[i][j] += a[i][k] * b[k][j];
    }
  }
  return c;
}

// exp(m) by scaling and squaring of a Taylor series: deterministic and exact enough in double.
Matrix3 exponential(Matrix3 m) {
  double norm = 0.0;
  for (const auto& row : m) {
    for (double v : row) norm = std::max(norm, std::abs(v));
  }
  int squarings = 0;
  while (norm > 0.25) {
    norm *= 0.5;
    ++squarings;
  }
  const double scale = std::ldexp(1.0, -squarings);
  for (auto& row : m) {
    for (double& v : row) v *= scale;
  }
  Matrix3 result{};
  Matrix3 term{};
  for (int i = 0; i < 3; ++i) result[i][i] = term[i][i] = 1.0;
  for (int n = 1; n <= 18; ++n) {
    term = multiply(term, m);
    for (auto& row : term) {
      for (double& v : row) v /= n;
    }
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) result[i][j] += term[i][j];
    }
  }
  for (int s = 0; s < squarings; ++s) result = multiply(result, result);
  return result;
}

}  // namespace

SimulatedScanner::SimulatedScanner(const FaultInjector& faults) : faults_(faults) {
  set_dynamics(MirrorDynamics{}, 100'000.0);
}

SimulatedScanner::Step SimulatedScanner::discretize(double omega, double zeta, double dt) {
  // d/dt [p, v] = [[0, 1], [-w^2, -2 zeta w]] [p, v] + [0, w^2] u, u held over dt: the
  // exponential of the augmented matrix [[F, G], [0, 0]] dt is [[A, B], [0, 1]].
  Matrix3 m{};
  m[0][1] = dt;
  m[1][0] = -omega * omega * dt;
  m[1][1] = -2.0 * zeta * omega * dt;
  m[1][2] = omega * omega * dt;
  const Matrix3 e = exponential(m);
  return {e[0][0], e[0][1], e[1][0], e[1][1], e[0][2], e[1][2]};
}

void SimulatedScanner::apply(const Step& step, Axis& axis, double command) noexcept {
  const double p = step.a00 * axis.position + step.a01 * axis.velocity + step.b0 * command;
  const double v = step.a10 * axis.position + step.a11 * axis.velocity + step.b1 * command;
  axis.position = p;
  axis.velocity = v;
}

void SimulatedScanner::set_dynamics(const MirrorDynamics& dynamics, double sweep_rate_hz) {
  ideal_ = dynamics.natural_hz <= 0.0;
  if (ideal_) return;
  const double omega = 2.0 * std::numbers::pi * dynamics.natural_hz;
  const double dt = 1.0 / sweep_rate_hz;
  full_ = discretize(omega, dynamics.damping, dt);
  half_ = discretize(omega, dynamics.damping, 0.5 * dt);
}

void SimulatedScanner::configure(const hal::GalvoOutputConfig& config) {
  buffer_.assign(config.fifo_capacity, hal::GalvoSample{});
  capacity_ = config.fifo_capacity;
  head_.store(0, std::memory_order_relaxed);
  tail_.store(0, std::memory_order_relaxed);
  drop_until_.store(0, std::memory_order_relaxed);
  park_x_.store(config.park.x, std::memory_order_relaxed);
  park_y_.store(config.park.y, std::memory_order_relaxed);
  lead_samples_.store(config.lead_samples, std::memory_order_relaxed);
  lead_pending_.store(0, std::memory_order_relaxed);
  samples_written_.store(0, std::memory_order_relaxed);
  output_base_.store(samples_output_.load(std::memory_order_relaxed), std::memory_order_relaxed);
  underrun_base_.store(underruns_.load(std::memory_order_relaxed), std::memory_order_relaxed);
  faults_seen_.store(0, std::memory_order_relaxed);
  streaming_.store(false, std::memory_order_relaxed);
  x_ = {config.park.x, 0.0};
  y_ = {config.park.y, 0.0};
  command_ = config.park;
  dry_ = false;
  skipping_ = 0;
  parked_.store(true, std::memory_order_release);
}

void SimulatedScanner::start_stream() noexcept {
  output_base_.store(samples_output_.load(std::memory_order_acquire), std::memory_order_relaxed);
  underrun_base_.store(underruns_.load(std::memory_order_acquire), std::memory_order_relaxed);
  faults_seen_.store(0, std::memory_order_relaxed);
  lead_pending_.store(lead_samples_.load(std::memory_order_relaxed), std::memory_order_relaxed);
  parked_.store(false, std::memory_order_release);
  streaming_.store(true, std::memory_order_release);
}

std::size_t SimulatedScanner::push(std::span<const hal::GalvoSample> samples) noexcept {
  if (capacity_ == 0) return 0;
  const std::uint32_t mask = faults_.active_mask();
  if ((mask & FaultInjector::bit(Fault::usb_disconnect)) != 0) {
    faults_seen_.fetch_or(hal::kGalvoDeviceLost, std::memory_order_acq_rel);
    return 0;
  }
  if ((mask & FaultInjector::bit(Fault::galvo_stream_stall)) != 0) return 0;
  const std::uint64_t head = head_.load(std::memory_order_relaxed);
  const std::uint64_t tail = tail_.load(std::memory_order_acquire);
  const std::uint64_t room = capacity_ - (head - tail);
  const std::size_t count = static_cast<std::size_t>(std::min<std::uint64_t>(room, samples.size()));
  for (std::size_t i = 0; i < count; ++i) buffer_[(head + i) % capacity_] = samples[i];
  head_.store(head + count, std::memory_order_release);
  samples_written_.fetch_add(count, std::memory_order_relaxed);
  return count;
}

void SimulatedScanner::park() noexcept {
  streaming_.store(false, std::memory_order_release);
  drop_until_.store(head_.load(std::memory_order_acquire), std::memory_order_release);
  parked_.store(true, std::memory_order_release);
}

hal::GalvoStatus SimulatedScanner::status() const noexcept {
  hal::GalvoStatus status;
  const std::uint64_t head = head_.load(std::memory_order_acquire);
  const std::uint64_t tail =
      std::max(tail_.load(std::memory_order_acquire), drop_until_.load(std::memory_order_acquire));
  status.fifo_fill = static_cast<std::uint32_t>(head > tail ? head - tail : 0);
  status.samples_written = samples_written_.load(std::memory_order_relaxed);
  status.samples_output = samples_output_.load(std::memory_order_acquire) -
                          output_base_.load(std::memory_order_relaxed);
  status.underruns =
      underruns_.load(std::memory_order_acquire) - underrun_base_.load(std::memory_order_relaxed);
  // A fault seen by anyone (here, the stream, the clock) stays until the next start().
  std::uint32_t live = 0;
  const std::uint32_t mask = faults_.active_mask();
  if ((mask & FaultInjector::bit(Fault::usb_disconnect)) != 0) live |= hal::kGalvoDeviceLost;
  if ((mask & FaultInjector::bit(Fault::galvo_driver_fault)) != 0) live |= hal::kGalvoDriverFault;
  status.faults = live == 0 ? faults_seen_.load(std::memory_order_acquire)
                            : faults_seen_.fetch_or(live, std::memory_order_acq_rel) | live;
  status.parked = parked_.load(std::memory_order_acquire);
  return status;
}

hal::GalvoSample SimulatedScanner::next_command(bool triggers) noexcept {
  const std::uint32_t mask = faults_.active_mask();
  if ((mask & FaultInjector::bit(Fault::usb_disconnect)) != 0) {
    // No DAC signal: the servo drives the mirrors to their electrical zero.
    faults_seen_.fetch_or(hal::kGalvoDeviceLost, std::memory_order_acq_rel);
    return {0.0f, 0.0f};
  }
  const bool driver_fault = (mask & FaultInjector::bit(Fault::galvo_driver_fault)) != 0;
  if (driver_fault) faults_seen_.fetch_or(hal::kGalvoDriverFault, std::memory_order_acq_rel);
  if (capacity_ == 0) return command_;
  std::uint64_t tail = tail_.load(std::memory_order_relaxed);
  const std::uint64_t drop = drop_until_.load(std::memory_order_acquire);
  if (tail < drop) tail = drop;
  if (parked_.load(std::memory_order_acquire)) {
    tail_.store(tail, std::memory_order_release);
    command_ = {park_x_.load(std::memory_order_relaxed), park_y_.load(std::memory_order_relaxed)};
    dry_ = false;
    skipping_ = 0;
  } else if (streaming_.load(std::memory_order_acquire) && triggers) {
    const std::uint64_t head = head_.load(std::memory_order_acquire);
    // Lead compensation: the first lead_samples samples belong to the sweeps before the first.
    skipping_ += lead_pending_.exchange(0, std::memory_order_acq_rel);
    while (skipping_ > 0 && tail < head) {
      ++tail;
      --skipping_;
      samples_output_.fetch_add(1, std::memory_order_relaxed);
    }
    if (tail < head) {
      command_ = buffer_[tail % capacity_];
      ++tail;
      samples_output_.fetch_add(1, std::memory_order_release);
      dry_ = false;
    } else if (!dry_) {
      // The FIFO ran dry while streaming: the output holds its last sample.
      dry_ = true;
      underruns_.fetch_add(1, std::memory_order_release);
      faults_seen_.fetch_or(hal::kGalvoUnderrun, std::memory_order_acq_rel);
    }
    tail_.store(tail, std::memory_order_release);
  }
  // A faulted driver stops driving: the mirrors return to their rest position.
  return driver_fault ? hal::GalvoSample{0.0f, 0.0f} : command_;
}

void SimulatedScanner::advance(std::uint64_t sweeps, bool triggers,
                               hal::BeamPosition* positions) noexcept {
  for (std::uint64_t s = 0; s < sweeps; ++s) {
    const hal::GalvoSample command = next_command(triggers);
    if (ideal_) {
      x_ = {command.x, 0.0};
      y_ = {command.y, 0.0};
      if (positions != nullptr) positions[s] = {command.x, command.y};
      continue;
    }
    if (positions != nullptr) {
      Axis mid_x = x_;
      Axis mid_y = y_;
      apply(half_, mid_x, command.x);
      apply(half_, mid_y, command.y);
      positions[s] = {static_cast<float>(mid_x.position), static_cast<float>(mid_y.position)};
    }
    apply(full_, x_, command.x);
    apply(full_, y_, command.y);
  }
}

}  // namespace ioct::sim
