#include "ioct/shm/reader_status.hpp"

#include <algorithm>
#include <atomic>
#include <cstring>
#include <filesystem>

#include "ioct/shm/atomic_word.hpp"
#include "ioct/shm/monotonic_clock.hpp"
#include "ioct/shm/ring_error.hpp"
#include "ioct/shm/ring_layout.hpp"

namespace ioct::shm {
namespace {

std::string status_prefix(const std::string& ring_name) {
  return ring_name + ".reader.";
}

std::string next_status_name(const std::string& ring_name) {
  static std::atomic<std::uint64_t> counter{0};
  return status_prefix(ring_name) + std::to_string(ProcessIdentity::self().pid) + "." +
         std::to_string(counter.fetch_add(1, std::memory_order_relaxed));
}

ReaderStatusBlock& block_of(const ShmObject& object) {
  return *reinterpret_cast<ReaderStatusBlock*>(object.data());
}

ShmObject create_status_object(const std::string& ring_name, unsigned mode, unsigned group_id) {
  const std::string name = next_status_name(ring_name);
  // Our pid and counter make the name ours; an object already there is a dead reader's debris
  // from a process whose pid the kernel has since given to us.
  ShmObject::remove(name);
  ShmObject object = ShmObject::create(name, kPageBytes, mode, "");
  try {
    object.set_access(mode, group_id);
  } catch (...) {
    ShmObject::remove(name);
    throw;
  }
  return object;
}

}  // namespace

ReaderStatusPublisher::ReaderStatusPublisher(const std::string& ring_name, const std::string& label,
                                             unsigned mode, unsigned group_id)
    : object_(create_status_object(ring_name, mode, group_id)) {
  ReaderStatusBlock& b = block_of(object_);
  const ProcessIdentity self = ProcessIdentity::self();
  b.layout_version = kReaderStatusVersion;
  b.pid = self.pid;
  b.start_ticks = self.start_ticks;
  const std::size_t n = std::min(label.size(), kReaderLabelBytes - 1);
  std::memcpy(b.label, label.data(), n);
  b.label[n] = '\0';
  store_word(b.heartbeat_ns, monotonic_ns(), std::memory_order_relaxed);
  store_word(b.magic, kReaderStatusMagic, std::memory_order_release);
}

ReaderStatusPublisher& ReaderStatusPublisher::operator=(ReaderStatusPublisher&& other) noexcept {
  if (this != &other) {
    if (object_.data() != nullptr) ShmObject::remove(object_.name());
    object_ = std::move(other.object_);
  }
  return *this;
}

ReaderStatusPublisher::~ReaderStatusPublisher() {
  if (object_.data() != nullptr) ShmObject::remove(object_.name());
}

void ReaderStatusPublisher::update(std::uint64_t now_ns, std::uint64_t epoch,
                                   std::uint64_t position,
                                   const ReaderCounters& counters) noexcept {
  ReaderStatusBlock& b = block_of(object_);
  constexpr auto relaxed = std::memory_order_relaxed;
  store_word(b.epoch, epoch, relaxed);
  store_word(b.position, position, relaxed);
  store_word(b.consumed, counters.consumed, relaxed);
  store_word(b.dropped_lapped, counters.dropped_lapped, relaxed);
  store_word(b.dropped_behind, counters.dropped_behind, relaxed);
  store_word(b.resyncs, counters.resyncs, relaxed);
  store_word(b.epoch_changes, counters.epoch_changes, relaxed);
  store_word(b.heartbeat_ns, now_ns, std::memory_order_release);
}

std::vector<ReaderReport> scan_reader_status(const std::string& ring_name,
                                             std::vector<std::string>* skipped) {
  std::vector<ReaderReport> reports;
  const std::string prefix = status_prefix(ring_name);
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/dev/shm", ec)) {
    const std::string name = entry.path().filename().string();
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    try {
      const ShmObject object = ShmObject::open(name, Access::read_only);
      const auto& b = *reinterpret_cast<const ReaderStatusBlock*>(object.data());
      if (object.size() < sizeof(ReaderStatusBlock) ||
          load_word(b.magic, std::memory_order_acquire) != kReaderStatusMagic ||
          b.layout_version != kReaderStatusVersion) {
        if (skipped != nullptr) skipped->push_back(name);
        continue;
      }
      constexpr auto relaxed = std::memory_order_relaxed;
      ReaderReport r;
      r.object_name = name;
      r.label.assign(b.label, strnlen(b.label, kReaderLabelBytes));
      r.pid = b.pid;
      r.alive = ProcessIdentity{b.pid, b.start_ticks}.alive();
      const std::uint64_t beat = load_word(b.heartbeat_ns, std::memory_order_acquire);
      const std::uint64_t now = monotonic_ns();
      r.heartbeat_age_ns = now > beat ? now - beat : 0;
      r.epoch = load_word(b.epoch, relaxed);
      r.position = load_word(b.position, relaxed);
      r.counters.consumed = load_word(b.consumed, relaxed);
      r.counters.dropped_lapped = load_word(b.dropped_lapped, relaxed);
      r.counters.dropped_behind = load_word(b.dropped_behind, relaxed);
      r.counters.resyncs = load_word(b.resyncs, relaxed);
      r.counters.epoch_changes = load_word(b.epoch_changes, relaxed);
      reports.push_back(std::move(r));
    } catch (const RingError&) {
      if (skipped != nullptr) skipped->push_back(name);
    }
  }
  std::sort(reports.begin(), reports.end(), [](const ReaderReport& a, const ReaderReport& b) {
    return a.object_name < b.object_name;
  });
  return reports;
}

}  // namespace ioct::shm
