// Reads an HDF5 ring recording (ring_recording_format.hpp), while it is being written too (SWMR)
// or after its writer was killed. Everything is checked before it is used or allocated for:
// format and version, the geometry (valid, and agreeing with every dataset's shape), the slot
// header size, and, per group, that its chunk is in the file with the size the geometry makes
// and that its checksum matches. Errors are RingRecordingError naming the file, the group and
// its byte offset in the file.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <stdexcept>
#include <string>

#include "ioct/common/error.hpp"
#include "ioct/ringrec/h5_handle.hpp"
#include "ioct/ringrec/ring_recording_format.hpp"
#include "ioct/shm/ring_geometry.hpp"
#include "ioct/shm/ring_layout.hpp"

namespace ioct::ringrec {

class RingRecordingError : public std::runtime_error, public Error {
 public:
  explicit RingRecordingError(const std::string& what)
      : std::runtime_error(what), Error(ErrorCategory::data) {}
};

class RingRecordingReader {
 public:
  // Opens (read-only, SWMR read) and validates. Throws RingRecordingError.
  explicit RingRecordingReader(const std::filesystem::path& path);
  RingRecordingReader(RingRecordingReader&&) noexcept = default;
  RingRecordingReader& operator=(RingRecordingReader&&) noexcept = default;

  const shm::RingGeometry& geometry() const noexcept { return geometry_; }
  std::uint64_t group_bytes() const noexcept { return group_bytes_; }
  // Complete groups: a group's slot header, checksum and samples are all in the file. A group
  // the writer was killed in the middle of is not counted.
  std::uint64_t group_count() const noexcept { return group_count_; }
  // The recorder's counters as last flushed; `finished` is 1 when it closed the file in order.
  const CounterValues& counters() const noexcept { return counters_; }
  bool finished() const noexcept {
    return counters_[static_cast<std::size_t>(Counter::finished)] == 1;
  }
  const std::string& run_metadata() const noexcept { return run_metadata_; }
  const std::string& ring_name() const noexcept { return ring_name_; }
  // The process that produced the ring when the recording started (0: not known).
  std::uint64_t ring_producer_pid() const noexcept { return ring_producer_pid_; }
  const std::filesystem::path& path() const noexcept { return path_; }

  // Reads group `index` into `payload` (exactly group_bytes()) and its slot header, and checks
  // the checksum. Throws RingRecordingError (index out of range, chunk missing or of the wrong
  // size, checksum mismatch: corrupt) or std::invalid_argument for a wrong buffer size.
  void read_group(std::uint64_t index, std::span<std::byte> payload, shm::SlotHeader& header) const;

  // Reads only group `index`'s slot header (for an index of the file's groups and volumes).
  // Throws RingRecordingError.
  void read_header(std::uint64_t index, shm::SlotHeader& header) const;

  // Sees groups the writer appended since (SWMR); returns the new group_count().
  std::uint64_t refresh();

 private:
  std::uint64_t count_complete_groups() const;
  [[noreturn]] void fail(const std::string& what) const;

  std::filesystem::path path_;
  std::uint64_t file_bytes_ = 0;
  shm::RingGeometry geometry_;
  std::uint64_t group_bytes_ = 0;
  std::uint64_t group_count_ = 0;
  CounterValues counters_{};
  std::string run_metadata_;
  std::string ring_name_;
  std::uint64_t ring_producer_pid_ = 0;
  H5Handle file_;
  H5Handle groups_set_;
  H5Handle headers_set_;
  H5Handle checksums_set_;
  H5Handle counters_set_;
};

}  // namespace ioct::ringrec
