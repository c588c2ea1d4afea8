#include "ioct/recording/recording_reader.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <system_error>

#include "ioct/common/input_file.hpp"
#include "ioct/recording/recording_writer.hpp"

namespace ioct::recording {
namespace {

std::string errno_text(int error) {
  return std::system_category().message(error);
}

[[noreturn]] void fail(const std::filesystem::path& path, const std::string& what) {
  throw RecordingError(path.string() + ": " + what);
}

int open_read(const std::filesystem::path& path, std::uint64_t& size) {
  // Non-blocking: a FIFO under the name is refused below instead of waiting for a writer.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) fail(path, "cannot open: " + errno_text(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    fail(path, "not a regular file (a FIFO, a device or a directory cannot be a recording)");
  }
  size = static_cast<std::uint64_t>(st.st_size);
  return fd;
}

// The data file named in the metadata, beside the JSON file; only a plain file name is allowed.
std::filesystem::path data_file(const nlohmann::json& section, const std::string& key,
                                const std::filesystem::path& json_path) {
  const auto it = section.find("file");
  if (it == section.end() || !it->is_string()) {
    fail(json_path, key + ".file must name the data file");
  }
  const std::filesystem::path name = it->get<std::string>();
  if (name.empty() || name.has_parent_path() || name == "." || name == "..") {
    fail(json_path, key + ".file = " + it->dump() + ": must be a file name beside the metadata");
  }
  return json_path.parent_path() / name;
}

template <typename T>
T get(const unsigned char* at) {
  T value;
  std::memcpy(&value, at, sizeof(T));
  return value;
}

}  // namespace

RecordingReader::RecordingReader(const std::filesystem::path& path) {
  json_path_ = recording_paths(path).json;
  std::string text;
  try {
    text = read_small_file(json_path_.string(), "the recording's metadata", kMaxMetadataBytes);
  } catch (const InputFileError& e) {
    throw RecordingError(e.what());
  }
  nlohmann::json json;
  try {
    json = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {  // also a number no double holds (1e400)
    fail(json_path_, "not valid JSON: " + quote_input(e.what(), 240));
  }
  metadata_ = metadata_from_json(json, json_path_.string());
  const RecordingGeometry& g = metadata_.geometry;
  stride_ = group_stride_bytes(g);

  const auto raw = json.find("raw");
  if (raw == json.end() || !raw->is_object()) fail(json_path_, "missing object 'raw'");
  raw_path_ = data_file(*raw, "raw", json_path_);
  const auto declared_stride = raw->find("group_stride_bytes");
  if (declared_stride == raw->end() || !declared_stride->is_number_unsigned() ||
      declared_stride->get<std::uint64_t>() != stride_) {
    fail(json_path_,
         "raw.group_stride_bytes = " +
             (declared_stride == raw->end() ? std::string("(missing)") : declared_stride->dump()) +
             ": the geometry makes records of " + std::to_string(stride_) + " bytes");
  }
  const auto complete = json.find("complete");
  complete_ = complete != json.end() && complete->is_boolean() && complete->get<bool>();

  std::uint64_t raw_size = 0;
  raw_fd_ = open_read(raw_path_, raw_size);
  try {
    if (complete_) {
      const auto count = json.find("group_count");
      if (count == json.end() || !count->is_number_unsigned()) {
        fail(json_path_, "a complete recording needs 'group_count' (an unsigned integer)");
      }
      groups_ = count->get<std::uint64_t>();
      // Checked before anything is sized by it: a product that wraps must not pass as "fits".
      std::uint64_t expected = 0;
      if (!multiply_fits(groups_, stride_, expected)) {
        fail(json_path_, "group_count = " + std::to_string(groups_) + ": " +
                             std::to_string(groups_) + " groups of " + std::to_string(stride_) +
                             " bytes is more than any file holds; " + raw_path_.string() + " has " +
                             std::to_string(raw_size) + " bytes");
      }
      if (raw_size != expected) {
        fail(raw_path_, std::to_string(raw_size) + " bytes, but " + std::to_string(groups_) +
                            " groups of " + std::to_string(stride_) + " bytes make " +
                            std::to_string(groups_ * stride_) +
                            (raw_size < groups_ * stride_ ? " (truncated)" : " (trailing data)"));
      }
    } else {
      groups_ = raw_size / stride_;  // a writer that died: whole records only
    }
    if (metadata_.has_truth) {
      truth_path_ = data_file(json.at("truth"), "truth", json_path_);
      truth_stride_ =
          GroupTruth::record_bytes(g.ascans_per_bscan, g.bscans_per_group, metadata_.truth_tools);
      const auto declared = json.at("truth").find("record_bytes");
      if (declared == json.at("truth").end() || !declared->is_number_unsigned() ||
          declared->get<std::uint64_t>() != truth_stride_) {
        fail(json_path_, "truth.record_bytes does not match the geometry (" +
                             std::to_string(truth_stride_) + " bytes per record)");
      }
      std::uint64_t truth_size = 0;
      truth_fd_ = open_read(truth_path_, truth_size);
      const std::uint64_t records = truth_size / truth_stride_;
      std::uint64_t expected = 0;
      const bool fits =
          multiply_fits(groups_, truth_stride_, expected);  // groups_ fit the raw file
      if (complete_ ? !fits || truth_size != expected : records < groups_) {
        if (complete_) {
          fail(truth_path_, std::to_string(truth_size) + " bytes, but " + std::to_string(groups_) +
                                " records of " + std::to_string(truth_stride_) + " bytes make " +
                                std::to_string(groups_ * truth_stride_));
        }
        groups_ = records;
      }
    }
  } catch (...) {
    ::close(raw_fd_);
    if (truth_fd_ >= 0) ::close(truth_fd_);
    throw;
  }
}

RecordingReader::RecordingReader(RecordingReader&& other) noexcept
    : metadata_(std::move(other.metadata_)),
      json_path_(std::move(other.json_path_)),
      raw_path_(std::move(other.raw_path_)),
      truth_path_(std::move(other.truth_path_)),
      raw_fd_(std::exchange(other.raw_fd_, -1)),
      truth_fd_(std::exchange(other.truth_fd_, -1)),
      groups_(other.groups_),
      complete_(other.complete_),
      stride_(other.stride_),
      truth_stride_(other.truth_stride_) {}

RecordingReader::~RecordingReader() {
  if (raw_fd_ >= 0) ::close(raw_fd_);
  if (truth_fd_ >= 0) ::close(truth_fd_);
}

void RecordingReader::read_at(int fd, const std::filesystem::path& path, std::uint64_t offset,
                              void* out, std::size_t bytes) const {
  auto* p = static_cast<unsigned char*>(out);
  while (bytes > 0) {
    const ssize_t n = ::pread(fd, p, bytes, static_cast<off_t>(offset));
    if (n < 0) {
      if (errno == EINTR) continue;
      fail(path, "read failed at byte " + std::to_string(offset) + ": " + errno_text(errno));
    }
    if (n == 0) fail(path, "ends at byte " + std::to_string(offset) + " (truncated while open)");
    p += n;
    offset += static_cast<std::uint64_t>(n);
    bytes -= static_cast<std::size_t>(n);
  }
}

void RecordingReader::read_info(std::uint64_t index, RecordedGroupInfo& info) const {
  if (index >= groups_) {
    throw std::out_of_range("recording " + json_path_.string() + ": group " +
                            std::to_string(index) + " of " + std::to_string(groups_));
  }
  const std::uint64_t words = metadata_.geometry.samples_per_group();
  unsigned char header[kGroupHeaderBytes];
  const std::uint64_t offset = index * stride_;
  read_at(raw_fd_, raw_path_, offset, header, sizeof(header));
  if (std::memcmp(header, kGroupMagic.data(), kGroupMagic.size()) != 0) {
    fail(raw_path_, "group " + std::to_string(index) + " at byte " + std::to_string(offset) +
                        ": not a group record (bad magic)");
  }
  info.group_index = get<std::uint64_t>(header + 8);
  info.first_sweep_counter = get<std::uint64_t>(header + 16);
  info.missed_sweeps = get<std::uint32_t>(header + 24);
  info.status = get<std::uint32_t>(header + 28);
  info.first_sweep_ns = get<std::uint64_t>(header + 32);
  info.last_sweep_ns = get<std::uint64_t>(header + 40);
  const auto payload_bytes = get<std::uint64_t>(header + 48);
  if (info.group_index != index) {
    fail(raw_path_, "group " + std::to_string(index) + " at byte " + std::to_string(offset) +
                        " says it is group " + std::to_string(info.group_index));
  }
  if (payload_bytes != 2 * words) {
    fail(raw_path_, "group " + std::to_string(index) + " holds " + std::to_string(payload_bytes) +
                        " bytes of samples; the geometry has " + std::to_string(2 * words));
  }
}

void RecordingReader::read_group(std::uint64_t index, std::span<std::uint16_t> payload,
                                 RecordedGroupInfo& info) const {
  const std::uint64_t words = metadata_.geometry.samples_per_group();
  if (index < groups_ && payload.size() < words) {
    throw std::invalid_argument("recording reader: payload of " + std::to_string(payload.size()) +
                                " words, a group has " + std::to_string(words));
  }
  read_info(index, info);
  read_at(raw_fd_, raw_path_, index * stride_ + kGroupHeaderBytes, payload.data(), 2 * words);
}

void RecordingReader::read_truth(std::uint64_t index, GroupTruth& truth) const {
  if (!metadata_.has_truth) {
    throw std::logic_error("recording " + json_path_.string() + " has no ground truth");
  }
  if (index >= groups_) {
    throw std::out_of_range("recording " + json_path_.string() + ": truth of group " +
                            std::to_string(index) + " of " + std::to_string(groups_));
  }
  const RecordingGeometry& g = metadata_.geometry;
  std::vector<unsigned char> record(truth_stride_);
  const std::uint64_t offset = index * truth_stride_;
  read_at(truth_fd_, truth_path_, offset, record.data(), record.size());
  if (std::memcmp(record.data(), kTruthMagic.data(), kTruthMagic.size()) != 0) {
    fail(truth_path_, "record " + std::to_string(index) + ": not a truth record (bad magic)");
  }
  const auto group_index = get<std::uint64_t>(record.data() + 8);
  const auto ascans = get<std::uint32_t>(record.data() + 24);
  const auto bscans = get<std::uint32_t>(record.data() + 28);
  const auto tools = get<std::uint32_t>(record.data() + 32);
  if (group_index != index || ascans != g.ascans_per_bscan || bscans != g.bscans_per_group ||
      tools != metadata_.truth_tools) {
    fail(truth_path_, "record " + std::to_string(index) +
                          " does not match the metadata (group index, A-scans, B-scans or tools)");
  }
  truth.resize(ascans, bscans, tools);
  truth.group_index = group_index;
  truth.first_sweep_counter = get<std::uint64_t>(record.data() + 16);
  std::size_t at = kTruthHeaderBytes;
  for (std::vector<float>* v :
       {&truth.ilm_px, &truth.rpe_px, &truth.tool_px, &truth.beam_x, &truth.beam_y}) {
    std::memcpy(v->data(), record.data() + at, v->size() * sizeof(float));
    at += v->size() * sizeof(float);
  }
  for (ToolState& s : truth.tool_states) {
    float values[kToolStateFloats];
    std::memcpy(values, record.data() + at, sizeof(values));
    at += sizeof(values);
    s = {values[0], values[1], values[2], values[3], values[4], values[5]};
  }
}

}  // namespace ioct::recording
