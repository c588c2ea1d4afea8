// A ring of a small geometry that the test itself publishes synthetic groups into, so the live
// loop (in a thread, or ioct-gpu in a child process) reads from a real producer's shared memory.
#pragma once

#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <thread>

#include "ioct/shm/ring_writer.hpp"
#include "synthetic_spectra.hpp"

namespace ioct::gpu::testing {

// 256 samples (depth 128), 24 records per B-scan of which [2, 22) are active, 4 B-scans per
// group, 8 per volume: two groups make a volume.
inline shm::RingGeometry live_geometry() {
  shm::RingGeometry g;
  g.samples_per_ascan = 256;
  g.ascans_per_bscan = 24;
  g.bscans_per_group = 4;
  g.bscans_per_volume = 8;
  return g;
}
inline constexpr std::uint32_t kActiveBegin = 2;
inline constexpr std::uint32_t kActiveEnd = 22;
inline constexpr std::uint32_t kActiveWidth = kActiveEnd - kActiveBegin;

// Where the reflector of volume v, B-scan b, image column a lies: every position differs, so a
// B-scan or A-scan placed wrongly shows.
inline double reflector_depth(std::uint64_t v, std::uint32_t b, std::uint32_t a) {
  return 10.0 + 2.0 * b + a + static_cast<double>(v % 4);
}

// Polls `done` every few milliseconds for up to `timeout`; true when it became true.
inline bool wait_until(const std::function<bool()>& done,
                       std::chrono::milliseconds timeout = std::chrono::seconds(20)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

class LiveRing {
 public:
  LiveRing() : name_(unique_name()) {}
  ~LiveRing() {
    writer_.reset();
    shm::ShmObject::remove(name_);
  }

  const std::string& name() const noexcept { return name_; }
  shm::RingWriter& writer() { return *writer_; }

  void create(std::uint64_t slots = 4) {
    shm::RingConfig config;
    config.name = name_;
    config.geometry = live_geometry();
    config.slot_count = slots;
    config.memory_lock = shm::MemoryLock::none;
    writer_.emplace(shm::RingWriter::create(config));
  }

  // Publishes B-scans [first_bscan, first_bscan + 4) of volume `volume`, bidirectional (odd
  // B-scans recorded right to left). `edit` may spoil the header afterwards.
  void publish(std::uint64_t volume, std::uint32_t first_bscan,
               const std::function<void(shm::SlotHeader&)>& edit = {}) {
    const shm::RingGeometry g = live_geometry();
    shm::RingWriter::Claim claim = writer_->claim();
    const std::span<std::uint16_t> payload(reinterpret_cast<std::uint16_t*>(claim.payload.data()),
                                           claim.payload.size() / 2);
    fill_group(
        g, synthesizer_,
        [&](std::uint32_t b, std::uint32_t r) -> std::vector<Reflector> {
          if (r < kActiveBegin || r >= kActiveEnd) return {};
          const std::uint32_t bscan = first_bscan + b;
          const std::uint32_t record = r - kActiveBegin;
          const std::uint32_t column = bscan % 2 == 1 ? kActiveWidth - 1 - record : record;
          return {{reflector_depth(volume, bscan, column), 40.0}};
        },
        payload);
    shm::SlotHeader& h = *claim.header;
    h = shm::SlotHeader{};
    h.bscan_count = g.bscans_per_group;
    h.active_ascan_begin = kActiveBegin;
    h.active_ascan_end = kActiveEnd;
    h.status_flags = shm::kStatusSimulated | shm::kStatusLaserOn;
    for (std::uint32_t b = 0; b < g.bscans_per_group; ++b) {
      h.bscans[b] = marker_for(volume, first_bscan + b, g.bscans_per_volume, true);
    }
    if (edit) edit(h);
    writer_->publish(claim);
  }

  void close() { writer_->close(); }

 private:
  static std::string unique_name() {
    static int counter = 0;
    return "ioct-gtest-gpu-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
  }

  std::string name_;
  std::optional<shm::RingWriter> writer_;
  SpectrumSynthesizer synthesizer_{SpectrumModel{live_geometry().samples_per_ascan}, 99};
};

}  // namespace ioct::gpu::testing
