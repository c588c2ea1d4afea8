// The galvo scanner's analog output: x/y samples clocked out one per sweep trigger.
//
// The acquisition thread keeps the output's FIFO fed ahead of the beam (write() never blocks) and
// watches its fill; a backend reports underruns and faults in status(). park() is the safety
// path: it stops the stream and drives both mirrors to the park position at once.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

namespace ioct::hal {

// A commanded mirror position in scan units: [-1, 1] on each axis spans the full field.
struct GalvoSample {
  float x = 0.0f;
  float y = 0.0f;
  friend bool operator==(const GalvoSample&, const GalvoSample&) = default;
};

struct GalvoOutputConfig {
  double sample_rate_hz = 100'000.0;     // one sample per sweep trigger: the A-scan rate
  std::uint32_t fifo_capacity = 65'536;  // samples the output holds ahead of the beam
  // The waveform is shifted earlier by this many samples so that the mirror, which lags its
  // command, is where the beam should be when the sweep is recorded (galvo lead compensation).
  std::uint32_t lead_samples = 0;
  GalvoSample park{-1.0f, -1.0f};  // where the beam rests when not scanning: a corner of the field

  // Throws ConfigError naming the first bad key ("galvo.<key>").
  void validate() const;
  friend bool operator==(const GalvoOutputConfig&, const GalvoOutputConfig&) = default;
};

// GalvoStatus::faults
inline constexpr std::uint32_t kGalvoUnderrun = 1u << 0;     // the FIFO ran dry while streaming
inline constexpr std::uint32_t kGalvoDriverFault = 1u << 1;  // the servo driver reports a fault
inline constexpr std::uint32_t kGalvoDeviceLost = 1u << 2;   // the output device went away

struct GalvoStatus {
  std::uint64_t samples_written = 0;  // accepted by write() since start()
  std::uint64_t samples_output = 0;   // clocked out to the mirrors since start()
  std::uint32_t fifo_fill = 0;        // samples queued, not yet output
  std::uint64_t underruns = 0;        // times the FIFO ran dry while streaming
  std::uint32_t faults = 0;           // kGalvo* flags, sticky until the next start()
  bool parked = true;
};

class GalvoOutput {
 public:
  enum class State { idle, prepared, running };

  GalvoOutput() = default;
  GalvoOutput(const GalvoOutput&) = delete;
  GalvoOutput& operator=(const GalvoOutput&) = delete;
  virtual ~GalvoOutput() = default;

  // Validates and allocates; only while not running (std::logic_error otherwise).
  void prepare(const GalvoOutputConfig& config);
  // Starts clocking samples out on the sweep trigger; queue samples with write() first.
  void start();
  // Stops the stream and parks the mirrors.
  void stop() noexcept;
  // Queues as many of `samples` as the FIFO has room for; returns how many. Never blocks,
  // allocates or locks: it runs on the real-time thread.
  std::size_t write(std::span<const GalvoSample> samples) noexcept;
  GalvoStatus status() const noexcept;
  // The safety path: stops the stream, drops what is queued and drives the mirrors to the park
  // position now. Callable from any state and from the fault path; never throws.
  void park() noexcept;

  const GalvoOutputConfig& config() const noexcept { return config_; }
  State state() const noexcept { return state_; }
  virtual std::string_view backend() const noexcept = 0;

 protected:
  virtual void do_prepare(const GalvoOutputConfig& config) = 0;
  virtual void do_start() = 0;
  virtual std::size_t do_write(std::span<const GalvoSample> samples) noexcept = 0;
  virtual GalvoStatus do_status() const noexcept = 0;
  virtual void do_park() noexcept = 0;

 private:
  GalvoOutputConfig config_;
  State state_ = State::idle;
};

}  // namespace ioct::hal
