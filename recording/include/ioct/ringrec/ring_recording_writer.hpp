// Writes an HDF5 ring recording: one chunk per group (direct chunk write), its slot header and
// checksum, and the recorder's counters, flushed after every group. The file is opened for SWMR
// writing, so a viewer may read it while it grows, and a process killed at any point leaves a
// file that opens (SWMR read, or after `h5clear -s`) with every group completed before.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>

#include "ioct/ringrec/h5_handle.hpp"
#include "ioct/ringrec/ring_recording_format.hpp"
#include "ioct/shm/ring_geometry.hpp"
#include "ioct/shm/ring_layout.hpp"

namespace ioct::ringrec {

// What the file says about the run, besides the groups (root attributes).
struct RecordingDescription {
  shm::RingGeometry geometry;
  std::string ring_name;
  std::string producer;            // what wrote the file, "ioct-record 0.1.0"
  std::uint64_t producer_pid = 0;  // the ring's producer when the recording started
  std::string run_metadata;        // free text from the operator (e.g. ioct-rt's effective config)
};

class RingRecordingWriter {
 public:
  // Creates `path` (refuses an existing file unless `overwrite`). Throws H5Error or
  // std::runtime_error naming the file.
  RingRecordingWriter(const std::filesystem::path& path, const RecordingDescription& description,
                      bool overwrite);
  RingRecordingWriter(RingRecordingWriter&&) noexcept = default;
  RingRecordingWriter& operator=(RingRecordingWriter&&) noexcept = default;
  ~RingRecordingWriter();

  // Appends one group and flushes the file. `payload` must be one group of the geometry.
  // Throws H5Error (the file keeps every group appended before).
  void append(const shm::SlotHeader& header, std::span<const std::byte> payload);
  // Writes the counters dataset in place and flushes.
  void write_counters(const CounterValues& values);
  // Final counters (with `finished` = 1 and `groups_written` = the groups appended) and close.
  // Throws H5Error.
  void close(CounterValues values);

  std::uint64_t groups() const noexcept { return groups_; }
  std::uint64_t group_bytes() const noexcept { return group_bytes_; }
  const std::filesystem::path& path() const noexcept { return path_; }

 private:
  std::filesystem::path path_;
  std::uint64_t group_bytes_ = 0;
  std::uint64_t groups_ = 0;
  std::uint32_t ascans_ = 0, bscans_ = 0, samples_ = 0;
  H5Handle file_;
  H5Handle groups_set_;
  H5Handle headers_set_;
  H5Handle checksums_set_;
  H5Handle counters_set_;
};

// The HDF5 element type of a sample of `bytes_per_sample` bytes (little-endian unsigned).
hid_t sample_type(std::uint32_t bytes_per_sample);

}  // namespace ioct::ringrec
