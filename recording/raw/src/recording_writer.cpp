#include "ioct/recording/recording_writer.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <system_error>

#include "ioct/common/atomic_file.hpp"

namespace ioct::recording {
namespace {

std::string errno_text(int error) {
  return std::system_category().message(error);
}

void write_all(int fd, const void* data, std::size_t bytes, const std::filesystem::path& path) {
  const auto* p = static_cast<const unsigned char*>(data);
  while (bytes > 0) {
    const ssize_t n = ::write(fd, p, bytes);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw RecordingError(path.string() + ": write failed: " + errno_text(errno));
    }
    p += n;
    bytes -= static_cast<std::size_t>(n);
  }
}

int create_file(const std::filesystem::path& path, bool overwrite) {
  const int flags = O_WRONLY | O_CREAT | O_CLOEXEC | (overwrite ? O_TRUNC : O_EXCL);
  const int fd = ::open(path.c_str(), flags, 0644);
  if (fd < 0) {
    const int error = errno;
    if (error == EEXIST) {
      throw RecordingError(path.string() +
                           ": already exists; choose another name or allow overwriting");
    }
    throw RecordingError(path.string() + ": cannot create: " + errno_text(error));
  }
  return fd;
}

template <typename T>
void put(unsigned char* at, T value) {
  std::memcpy(at, &value, sizeof(T));
}

}  // namespace

RecordingPaths recording_paths(const std::filesystem::path& stem_or_json) {
  std::filesystem::path stem = stem_or_json;
  const std::filesystem::path extension = stem.extension();
  if (extension == ".json" || extension == ".raw" || extension == ".truth") {
    stem.replace_extension();
  }
  const std::string base = stem.string();
  return {base + ".json", base + ".raw", base + ".truth"};
}

RecordingWriter::RecordingWriter(const std::filesystem::path& stem, RecordingMetadata metadata)
    : RecordingWriter(stem, std::move(metadata), Options{}) {}

RecordingWriter::RecordingWriter(const std::filesystem::path& stem, RecordingMetadata metadata,
                                 Options options)
    : metadata_(std::move(metadata)) {
  const RecordingPaths paths = recording_paths(stem);
  json_path_ = paths.json;
  raw_path_ = paths.raw;
  truth_path_ = paths.truth;
  if (metadata_.created_utc.empty()) metadata_.created_utc = utc_now();
  // The metadata must read back: validate it the way a reader will.
  metadata_from_json(to_json(metadata_), json_path_.string() + " (to be written)");
  if (!options.overwrite && std::filesystem::exists(json_path_)) {
    throw RecordingError(json_path_.string() +
                         ": already exists; choose another name or allow overwriting");
  }
  raw_fd_ = create_file(raw_path_, options.overwrite);
  try {
    if (metadata_.has_truth) {
      truth_fd_ = create_file(truth_path_, options.overwrite);
      const RecordingGeometry& g = metadata_.geometry;
      truth_buffer_.resize(
          GroupTruth::record_bytes(g.ascans_per_bscan, g.bscans_per_group, metadata_.truth_tools));
    } else if (options.overwrite) {
      std::error_code ignored;
      std::filesystem::remove(truth_path_, ignored);
    }
    write_json(false);
  } catch (...) {
    ::close(raw_fd_);
    if (truth_fd_ >= 0) ::close(truth_fd_);
    raw_fd_ = truth_fd_ = -1;
    throw;
  }
}

RecordingWriter::~RecordingWriter() {
  try {
    close();
  } catch (...) {  // NOLINT: a destructor must not throw; close() reports errors
  }
}

void RecordingWriter::write_json(bool complete) {
  nlohmann::json json = to_json(metadata_);
  const RecordingGeometry& g = metadata_.geometry;
  json["complete"] = complete;
  if (complete) json["group_count"] = groups_;
  json["raw"] = {{"file", raw_path_.filename().string()},
                 {"group_header_bytes", kGroupHeaderBytes},
                 {"group_stride_bytes", group_stride_bytes(g)}};
  if (metadata_.has_truth) {
    json["truth"] = {
        {"file", truth_path_.filename().string()},
        {"header_bytes", kTruthHeaderBytes},
        {"record_bytes",
         GroupTruth::record_bytes(g.ascans_per_bscan, g.bscans_per_group, metadata_.truth_tools)},
        {"tools", metadata_.truth_tools}};
  } else {
    json["truth"] = nullptr;
  }
  ioct::write_text_file_atomically(json_path_, json.dump(2) + "\n");
}

void RecordingWriter::append(std::span<const std::uint16_t> group, RecordedGroupInfo info,
                             const GroupTruth* truth) {
  if (raw_fd_ < 0) throw std::logic_error("recording writer: append() after close()");
  const RecordingGeometry& g = metadata_.geometry;
  if (group.size() != g.samples_per_group()) {
    throw std::invalid_argument("recording writer: a group of " + std::to_string(group.size()) +
                                " samples; the geometry has " +
                                std::to_string(g.samples_per_group()));
  }
  if (metadata_.has_truth) {
    if (truth == nullptr) {
      throw std::invalid_argument("recording writer: this recording has ground truth; pass it");
    }
    if (truth->ascans_per_bscan != g.ascans_per_bscan || truth->bscans != g.bscans_per_group ||
        truth->tools != metadata_.truth_tools || truth->ilm_px.size() != truth->ascans() ||
        truth->tool_states.size() != std::size_t{truth->bscans} * truth->tools) {
      throw std::invalid_argument("recording writer: ground truth of the wrong shape");
    }
  }
  info.group_index = groups_;
  unsigned char header[kGroupHeaderBytes] = {};
  std::memcpy(header, kGroupMagic.data(), kGroupMagic.size());
  put(header + 8, info.group_index);
  put(header + 16, info.first_sweep_counter);
  put(header + 24, info.missed_sweeps);
  put(header + 28, info.status);
  put(header + 32, info.first_sweep_ns);
  put(header + 40, info.last_sweep_ns);
  put(header + 48, std::uint64_t{2} * group.size());
  write_all(raw_fd_, header, sizeof(header), raw_path_);
  write_all(raw_fd_, group.data(), group.size_bytes(), raw_path_);

  if (metadata_.has_truth) {
    unsigned char* out = truth_buffer_.data();
    std::memset(out, 0, kTruthHeaderBytes);
    std::memcpy(out, kTruthMagic.data(), kTruthMagic.size());
    put(out + 8, info.group_index);
    put(out + 16, truth->first_sweep_counter);
    put(out + 24, truth->ascans_per_bscan);
    put(out + 28, truth->bscans);
    put(out + 32, truth->tools);
    std::size_t at = kTruthHeaderBytes;
    for (const std::vector<float>* v :
         {&truth->ilm_px, &truth->rpe_px, &truth->tool_px, &truth->beam_x, &truth->beam_y}) {
      std::memcpy(out + at, v->data(), v->size() * sizeof(float));
      at += v->size() * sizeof(float);
    }
    for (const ToolState& s : truth->tool_states) {
      const float values[kToolStateFloats] = {s.tip_x,   s.tip_y,     s.tip_depth_px,
                                              s.yaw_deg, s.pitch_deg, s.jaw_opening_deg};
      std::memcpy(out + at, values, sizeof(values));
      at += sizeof(values);
    }
    write_all(truth_fd_, out, at, truth_path_);
  }
  ++groups_;
}

void RecordingWriter::close() {
  if (raw_fd_ < 0) return;
  const bool raw_ok = ::fsync(raw_fd_) == 0 || errno == EINVAL;
  ::close(raw_fd_);
  raw_fd_ = -1;
  if (truth_fd_ >= 0) {
    ::fsync(truth_fd_);
    ::close(truth_fd_);
    truth_fd_ = -1;
  }
  if (!raw_ok) throw RecordingError(raw_path_.string() + ": fsync failed: " + errno_text(errno));
  write_json(true);
}

}  // namespace ioct::recording
