// Reads a raw recording (recording_format.hpp). Everything in the files is checked before it is
// used: the metadata's keys, types and ranges, the sizes of STEM.raw and STEM.truth against the
// geometry, and each record's header (magic, index, size). A problem throws RecordingError
// naming the file and what is wrong.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>

#include "ioct/recording/recording_format.hpp"

namespace ioct::recording {

// The most bytes a recording's metadata (STEM.json) may have; docs/recording-format.md.
inline constexpr std::uint64_t kMaxMetadataBytes = 1 << 20;

class RecordingReader {
 public:
  // `path`: STEM, STEM.json or any of the recording's files' stem.
  explicit RecordingReader(const std::filesystem::path& path);
  RecordingReader(const RecordingReader&) = delete;
  RecordingReader& operator=(const RecordingReader&) = delete;
  RecordingReader(RecordingReader&& other) noexcept;
  RecordingReader& operator=(RecordingReader&&) = delete;
  ~RecordingReader();

  const RecordingMetadata& metadata() const noexcept { return metadata_; }
  const RecordingGeometry& geometry() const noexcept { return metadata_.geometry; }
  std::uint64_t group_count() const noexcept { return groups_; }
  // False when the writer never closed the recording (it died): group_count() is then the
  // number of whole records present, and a partial last record is ignored.
  bool complete() const noexcept { return complete_; }
  bool has_truth() const noexcept { return metadata_.has_truth; }
  const std::filesystem::path& json_path() const noexcept { return json_path_; }
  const std::filesystem::path& raw_path() const noexcept { return raw_path_; }

  // Reads group `index` into the first samples_per_group() words of `payload`. Throws
  // std::out_of_range for an index past the end, std::invalid_argument for a short payload,
  // RecordingError for a bad record.
  void read_group(std::uint64_t index, std::span<std::uint16_t> payload,
                  RecordedGroupInfo& info) const;
  // Reads only group `index`'s header.
  void read_info(std::uint64_t index, RecordedGroupInfo& info) const;
  // Reads group `index`'s ground truth (resizing `truth` as needed). Throws std::logic_error
  // without truth, otherwise as read_group().
  void read_truth(std::uint64_t index, GroupTruth& truth) const;

 private:
  void read_at(int fd, const std::filesystem::path& path, std::uint64_t offset, void* out,
               std::size_t bytes) const;

  RecordingMetadata metadata_;
  std::filesystem::path json_path_;
  std::filesystem::path raw_path_;
  std::filesystem::path truth_path_;
  int raw_fd_ = -1;
  int truth_fd_ = -1;
  std::uint64_t groups_ = 0;
  bool complete_ = false;
  std::uint64_t stride_ = 0;
  std::uint64_t truth_stride_ = 0;
};

}  // namespace ioct::recording
