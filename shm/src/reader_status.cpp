#include "ioct/shm/reader_status.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <filesystem>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/shm/atomic_word.hpp"
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

namespace {

// Reads one status object without mapping it: the object belongs to a reader (another user), who
// could truncate a mapping under us; a read of a shortened file is only short. Non-blocking and
// no link followed: a FIFO or a link under the name is skipped, never waited on.
std::optional<ReaderStatusBlock> read_status_block(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) return std::nullopt;
  std::optional<ReaderStatusBlock> block;
  struct stat st {};
  if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && (st.st_mode & 0002u) == 0 &&
      st.st_size >= static_cast<off_t>(sizeof(ReaderStatusBlock))) {
    ReaderStatusBlock b{};
    if (::pread(fd, &b, sizeof b, 0) == static_cast<ssize_t>(sizeof b)) block = b;
  }
  ::close(fd);
  return block;
}

}  // namespace

std::vector<ReaderReport> scan_reader_status(const std::string& ring_name,
                                             std::vector<std::string>* skipped) {
  std::vector<ReaderReport> reports;
  // Status objects sit beside the ring: "<ring>.reader.<pid>.<n>" in the ring's directory.
  const std::string prefix_path = object_path(status_prefix(ring_name));
  const auto slash = prefix_path.rfind('/');
  const std::string directory = prefix_path.substr(0, slash == 0 ? 1 : slash);
  const std::string prefix = prefix_path.substr(slash + 1);
  const auto ring_slash = ring_name.rfind('/');
  const std::string name_base =
      ring_slash == std::string::npos ? std::string() : ring_name.substr(0, ring_slash + 1);
  std::error_code ec;
  std::size_t examined = 0;
  for (const auto& entry : std::filesystem::directory_iterator(directory, ec)) {
    // Bounded: a directory stuffed with entries cannot hold the housekeeping thread for long.
    if (++examined > kMaxDirectoryEntries) break;
    const std::string file = entry.path().filename().string();
    if (file.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string name = name_base + file;
    const std::optional<ReaderStatusBlock> block = read_status_block(directory + "/" + file);
    if (!block || block->magic != kReaderStatusMagic ||
        block->layout_version != kReaderStatusVersion) {
      if (skipped != nullptr) skipped->push_back(name);
      continue;
    }
    const ReaderStatusBlock& b = *block;
    ReaderReport r;
    r.object_name = name;
    r.label.assign(b.label, strnlen(b.label, kReaderLabelBytes));
    r.pid = b.pid;
    r.alive = ProcessIdentity{b.pid, b.start_ticks}.alive();
    const std::uint64_t now = monotonic_ns();
    r.heartbeat_age_ns = now > b.heartbeat_ns ? now - b.heartbeat_ns : 0;
    r.epoch = b.epoch;
    r.position = b.position;
    r.counters.consumed = b.consumed;
    r.counters.dropped_lapped = b.dropped_lapped;
    r.counters.dropped_behind = b.dropped_behind;
    r.counters.resyncs = b.resyncs;
    r.counters.epoch_changes = b.epoch_changes;
    reports.push_back(std::move(r));
  }
  std::sort(reports.begin(), reports.end(), [](const ReaderReport& a, const ReaderReport& b) {
    return a.object_name < b.object_name;
  });
  return reports;
}

}  // namespace ioct::shm
