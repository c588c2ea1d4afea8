// Writes a raw recording (recording_format.hpp): group after group, appended to STEM.raw (and
// STEM.truth), with STEM.json describing them.
//
// STEM.json is written when the recording is created (without a group count, "complete": false)
// and again, atomically, by close() ("complete": true, "group_count"). A recording whose writer
// died keeps every group it had appended: readers take the whole records present and say the
// recording is incomplete. Existing files are never overwritten unless asked.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>

#include "ioct/recording/recording_format.hpp"

namespace ioct::recording {

class RecordingWriter {
 public:
  struct Options {
    bool overwrite = false;  // replace an existing recording of the same name
  };

  // `stem`: path without extension ("run1" makes run1.json, run1.raw, run1.truth); a trailing
  // ".json" is dropped. Throws RecordingError naming the file that cannot be created.
  RecordingWriter(const std::filesystem::path& stem, RecordingMetadata metadata);
  RecordingWriter(const std::filesystem::path& stem, RecordingMetadata metadata, Options options);
  RecordingWriter(const RecordingWriter&) = delete;
  RecordingWriter& operator=(const RecordingWriter&) = delete;
  // Closes (as close()) if still open; errors are swallowed here, call close() to see them.
  ~RecordingWriter();

  // Appends one group: exactly geometry.samples_per_group() samples. `info.group_index` is
  // replaced by the group's position in the file. `truth` is required when the metadata says
  // has_truth (and must match its geometry), ignored otherwise. Throws RecordingError on a write
  // error, std::invalid_argument for a wrong size.
  void append(std::span<const std::uint16_t> group, RecordedGroupInfo info,
              const GroupTruth* truth = nullptr);
  // Finishes STEM.json. Idempotent.
  void close();

  std::uint64_t groups_written() const noexcept { return groups_; }
  const RecordingMetadata& metadata() const noexcept { return metadata_; }
  const std::filesystem::path& json_path() const noexcept { return json_path_; }
  const std::filesystem::path& raw_path() const noexcept { return raw_path_; }
  const std::filesystem::path& truth_path() const noexcept { return truth_path_; }

 private:
  void write_json(bool complete);

  RecordingMetadata metadata_;
  std::filesystem::path json_path_;
  std::filesystem::path raw_path_;
  std::filesystem::path truth_path_;
  int raw_fd_ = -1;
  int truth_fd_ = -1;
  std::uint64_t groups_ = 0;
  std::vector<unsigned char> truth_buffer_;
};

// STEM.json, STEM.raw and STEM.truth for a stem (a trailing .json, .raw or .truth dropped).
struct RecordingPaths {
  std::filesystem::path json;
  std::filesystem::path raw;
  std::filesystem::path truth;
};
RecordingPaths recording_paths(const std::filesystem::path& stem_or_json);

}  // namespace ioct::recording
