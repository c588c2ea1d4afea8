#include "bench_ring_fixture.hpp"

#include <signal.h>
#include <sys/mman.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <csignal>
#include <cstring>

#include "slot_pattern.hpp"

namespace ioct::bench {
namespace {

// Names to unlink from a signal handler: fixed storage, filled before the handler can see them.
constexpr std::size_t kMaxCleanupNames = 32;
constexpr std::size_t kMaxNameBytes = 256;
std::array<std::array<char, kMaxNameBytes>, kMaxCleanupNames> cleanup_names{};
std::atomic<std::size_t> cleanup_count{0};

extern "C" void unlink_and_reraise(int signal_number) {
  const std::size_t n = cleanup_count.load(std::memory_order_acquire);
  for (std::size_t i = 0; i < n; ++i) {
    // shm_unlink is async-signal-safe; a name already gone just fails.
    std::array<char, kMaxNameBytes + 1> path{};
    path[0] = '/';
    std::memcpy(path.data() + 1, cleanup_names[i].data(), kMaxNameBytes - 1);
    ::shm_unlink(path.data());
  }
  ::signal(signal_number, SIG_DFL);
  ::raise(signal_number);
}

void unlink_on_signal(const std::string& name) {
  static const bool installed = [] {
    ::signal(SIGINT, unlink_and_reraise);
    ::signal(SIGTERM, unlink_and_reraise);
    return true;
  }();
  (void)installed;
  const std::size_t i = cleanup_count.load(std::memory_order_relaxed);
  if (name.size() >= kMaxNameBytes - 1) return;
  // A name tried again (a ring retried with fewer slots) keeps its one entry.
  for (std::size_t k = 0; k < i; ++k) {
    if (name == cleanup_names[k].data()) return;
  }
  if (i >= kMaxCleanupNames) return;
  std::memcpy(cleanup_names[i].data(), name.c_str(), name.size() + 1);
  cleanup_count.store(i + 1, std::memory_order_release);
}

shm::RingWriter create_writer(const std::string& tag, const shm::RingGeometry& geometry,
                              std::uint64_t slot_count) {
  shm::RingConfig config;
  config.name = "ioct-bench-" + std::to_string(::getpid()) + "-" + tag;
  config.geometry = geometry;
  config.slot_count = slot_count;
  config.mode = 0600;
  config.memory_lock = shm::MemoryLock::best_effort;
  unlink_on_signal(config.name);
  return shm::RingWriter::create(config);
}

}  // namespace

BenchRing::BenchRing(const std::string& tag, const shm::RingGeometry& geometry,
                     std::uint64_t slot_count, SlotFill fill)
    : writer_(create_writer(tag, geometry, slot_count)) {
  if (fill == SlotFill::none) return;
  for (std::uint64_t i = 0; i < slot_count; ++i) {
    const auto claim = writer_.claim();
    const std::uint64_t slot = claim.group % slot_count;
    auto* words = reinterpret_cast<std::uint64_t*>(claim.payload.data());
    const std::size_t n = claim.payload.size() / sizeof(std::uint64_t);
    for (std::size_t w = 0; w < n; ++w) words[w] = slot_pattern_word(slot, w);
    writer_.publish(claim);
  }
}

shm::RingReader BenchRing::attach_reader(const std::string& label, bool publish_status) const {
  shm::ReaderOptions options;
  options.label = label;
  options.publish_status = publish_status;
  options.status_mode = 0600;
  shm::RingReader reader = shm::RingReader::attach(name(), options);
  if (const auto status = reader.status_object_name()) unlink_on_signal(*status);
  return reader;
}

void BenchRing::publish(std::uint64_t groups) noexcept {
  for (std::uint64_t i = 0; i < groups; ++i) writer_.publish(writer_.claim());
}

std::span<const std::byte> slot_payload(const shm::RingReader& reader, std::uint64_t slot) {
  const shm::RingLayout& l = reader.layout();
  const std::byte* start =
      reader.mapping() + l.first_slot_offset + slot * l.slot_stride + l.slot_payload_offset;
  return {start, l.group_payload_bytes};
}

bool spot_check_pattern(std::span<const std::byte> payload, std::uint64_t slot) {
  const std::size_t n = payload.size() / sizeof(std::uint64_t);
  if (n == 0) return true;
  for (const std::size_t w : {std::size_t{0}, n / 2, n - 1}) {
    std::uint64_t word = 0;
    std::memcpy(&word, payload.data() + w * sizeof(word), sizeof(word));
    if (word != slot_pattern_word(slot, w)) return false;
  }
  return true;
}

std::uint64_t shm_free_bytes() {
  struct statvfs fs {};
  if (::statvfs("/dev/shm", &fs) != 0) return 0;
  return static_cast<std::uint64_t>(fs.f_bavail) * fs.f_frsize;
}

}  // namespace ioct::bench
