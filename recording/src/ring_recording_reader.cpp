#include "ioct/ringrec/ring_recording_reader.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <vector>

#include "ioct/ringrec/ring_recording_writer.hpp"

namespace ioct::ringrec {
namespace {

constexpr std::size_t kMaxTextAttributeBytes = 1 << 20;

std::uint64_t u64_attribute(hid_t object, const char* name, const std::string& where) {
  if (H5Aexists(object, name) <= 0) {
    throw RingRecordingError(where + ": missing attribute '" + std::string(name) + "'");
  }
  H5Handle attribute(H5Aopen(object, name, H5P_DEFAULT), H5Aclose);
  H5Handle space(attribute ? H5Aget_space(attribute.get()) : -1, H5Sclose);
  H5Handle type(attribute ? H5Aget_type(attribute.get()) : -1, H5Tclose);
  std::uint64_t value = 0;
  if (!attribute || !space || !type || H5Sget_simple_extent_npoints(space.get()) != 1 ||
      H5Tget_class(type.get()) != H5T_INTEGER ||
      H5Aread(attribute.get(), H5T_NATIVE_UINT64, &value) < 0) {
    h5_error_stack();
    throw RingRecordingError(where + ": attribute '" + std::string(name) +
                             "' is not one unsigned integer");
  }
  return value;
}

std::string text_attribute(hid_t object, const char* name, const std::string& where) {
  if (H5Aexists(object, name) <= 0) {
    throw RingRecordingError(where + ": missing attribute '" + std::string(name) + "'");
  }
  H5Handle attribute(H5Aopen(object, name, H5P_DEFAULT), H5Aclose);
  H5Handle space(attribute ? H5Aget_space(attribute.get()) : -1, H5Sclose);
  H5Handle type(attribute ? H5Aget_type(attribute.get()) : -1, H5Tclose);
  // One string: H5Aread writes every element of the attribute's space, so an array of strings
  // would overrun a buffer sized for one.
  if (!attribute || !space || !type || H5Sget_simple_extent_npoints(space.get()) != 1 ||
      H5Tget_class(type.get()) != H5T_STRING || H5Tis_variable_str(type.get()) != 0) {
    h5_error_stack();
    throw RingRecordingError(where + ": attribute '" + std::string(name) +
                             "' is not one fixed-length string");
  }
  const std::size_t size = H5Tget_size(type.get());
  if (size == 0 || size > kMaxTextAttributeBytes) {
    throw RingRecordingError(where + ": attribute '" + std::string(name) + "' of " +
                             std::to_string(size) + " bytes (at most " +
                             std::to_string(kMaxTextAttributeBytes) + ")");
  }
  std::string value(size, '\0');
  if (H5Aread(attribute.get(), type.get(), value.data()) < 0) {
    h5_error_stack();
    throw RingRecordingError(where + ": attribute '" + std::string(name) + "' unreadable");
  }
  value.resize(std::min(value.size(), value.find('\0')));
  return value;
}

std::uint32_t u32_geometry(hid_t root, const char* name, const std::string& where) {
  const std::uint64_t value = u64_attribute(root, name, where);
  if (value > 0xffffffffu) {
    throw RingRecordingError(where + ": " + name + " = " + std::to_string(value) +
                             ": out of range");
  }
  return static_cast<std::uint32_t>(value);
}

H5Handle open_dataset(hid_t file, const char* name, const std::string& where) {
  H5Handle set(H5Lexists(file, name, H5P_DEFAULT) > 0 ? H5Dopen2(file, name, H5P_DEFAULT) : -1,
               H5Dclose);
  if (!set) {
    h5_error_stack();
    throw RingRecordingError(where + ": no dataset '" + std::string(name) + "'");
  }
  return set;
}

// The dataset's shape; refuses another rank, or dimensions after the first that differ from
// `expected` (naming both).
std::uint64_t check_shape(hid_t set, const char* name, const std::vector<hsize_t>& expected,
                          std::size_t element_bytes, const std::string& where) {
  H5Handle space(H5Dget_space(set), H5Sclose);
  H5Handle type(H5Dget_type(set), H5Tclose);
  const int rank = space ? H5Sget_simple_extent_ndims(space.get()) : -1;
  if (rank != static_cast<int>(expected.size())) {
    throw RingRecordingError(where + ": dataset '" + name + "' has rank " + std::to_string(rank) +
                             ", expected " + std::to_string(expected.size()));
  }
  if (!type || H5Tget_size(type.get()) != element_bytes) {
    throw RingRecordingError(where + ": dataset '" + name + "' has elements of " +
                             std::to_string(type ? H5Tget_size(type.get()) : 0) +
                             " bytes, expected " + std::to_string(element_bytes));
  }
  std::vector<hsize_t> dims(expected.size());
  H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  static constexpr const char* kAxis[] = {"groups", "bscans_per_group", "ascans_per_bscan",
                                          "samples_per_ascan"};
  for (std::size_t i = 1; i < dims.size(); ++i) {
    if (dims[i] != expected[i]) {
      const std::string axis = expected.size() == 4 ? kAxis[i] : "dimension " + std::to_string(i);
      throw RingRecordingError(where + ": dataset '" + name + "' " + axis + " = " +
                               std::to_string(dims[i]) + ", but the geometry says " +
                               std::to_string(expected[i]) + " (wrong geometry)");
    }
  }
  return dims[0];
}

}  // namespace

RingRecordingReader::RingRecordingReader(const std::filesystem::path& path) : path_(path) {
  h5_quiet();
  const std::string where = path.string();
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    throw RingRecordingError(where + ": cannot open: " + std::strerror(errno));
  }
  if (!S_ISREG(st.st_mode)) throw RingRecordingError(where + ": not a regular file");
  file_bytes_ = static_cast<std::uint64_t>(st.st_size);
  if (H5Fis_hdf5(path.c_str()) <= 0) {
    h5_error_stack();
    throw RingRecordingError(where + ": not an HDF5 file");
  }
  // SWMR read: opens a file being written, and one whose writer was killed (its "open for
  // writing" mark is still set).
  file_ =
      H5Handle(H5Fopen(path.c_str(), H5F_ACC_RDONLY | H5F_ACC_SWMR_READ, H5P_DEFAULT), H5Fclose);
  if (!file_) throw RingRecordingError(where + ": cannot open: " + h5_error_stack());
  const hid_t root = file_.get();
  const std::string format = text_attribute(root, "format", where);
  if (format != kFormatName) {
    throw RingRecordingError(where + ": format = \"" + format.substr(0, 64) +
                             "\": not an ioct ring recording (expected \"" +
                             std::string(kFormatName) + "\")");
  }
  const std::uint64_t version = u64_attribute(root, "version", where);
  if (version != kFormatVersion) {
    throw RingRecordingError(where + ": version = " + std::to_string(version) + ": expected " +
                             std::to_string(kFormatVersion));
  }
  geometry_.samples_per_ascan = u32_geometry(root, "samples_per_ascan", where);
  geometry_.ascans_per_bscan = u32_geometry(root, "ascans_per_bscan", where);
  geometry_.bscans_per_group = u32_geometry(root, "bscans_per_group", where);
  geometry_.bscans_per_volume = u32_geometry(root, "bscans_per_volume", where);
  geometry_.bytes_per_sample = u32_geometry(root, "bytes_per_sample", where);
  try {
    geometry_.validate();
    group_bytes_ = geometry_.group_payload_bytes();
    sample_type(geometry_.bytes_per_sample);
  } catch (const std::exception& e) {
    throw RingRecordingError(where + ": geometry: " + e.what());
  }
  const std::uint64_t header_bytes = u64_attribute(root, "slot_header_bytes", where);
  if (header_bytes != sizeof(shm::SlotHeader)) {
    throw RingRecordingError(where + ": slot_header_bytes = " + std::to_string(header_bytes) +
                             ": this build's slot header has " +
                             std::to_string(sizeof(shm::SlotHeader)));
  }
  run_metadata_ = text_attribute(root, "run_metadata", where);
  ring_name_ = text_attribute(root, "ring_name", where);
  ring_producer_pid_ = u64_attribute(root, "ring_producer_pid", where);

  groups_set_ = open_dataset(root, kGroupsDataset, where);
  headers_set_ = open_dataset(root, kSlotHeadersDataset, where);
  checksums_set_ = open_dataset(root, kChecksumsDataset, where);
  counters_set_ = open_dataset(root, kCountersDataset, where);
  refresh();
}

std::uint64_t RingRecordingReader::refresh() {
  const std::string where = path_.string();
  // The counters first: the writer writes them after the groups they count, so the extents and
  // the file's size read after them are at least as new (a file finished meanwhile is not taken
  // for a damaged or truncated one).
  H5Drefresh(counters_set_.get());  // SWMR: see the writer's latest state
  if (check_shape(counters_set_.get(), kCountersDataset, {0}, 8, where) != kCounterCount) {
    throw RingRecordingError(where + ": dataset 'counters' does not hold " +
                             std::to_string(kCounterCount) + " counters");
  }
  if (H5Dread(counters_set_.get(), H5T_NATIVE_UINT64, H5S_ALL, H5S_ALL, H5P_DEFAULT,
              counters_.data()) < 0) {
    throw RingRecordingError(where + ": counters unreadable: " + h5_error_stack());
  }
  for (const H5Handle* set : {&groups_set_, &headers_set_, &checksums_set_}) {
    H5Drefresh(set->get());
  }
  struct stat st {};  // after the extents: the file holds at least the groups they count
  if (::stat(path_.c_str(), &st) == 0) file_bytes_ = static_cast<std::uint64_t>(st.st_size);
  const std::uint64_t groups = check_shape(
      groups_set_.get(), kGroupsDataset,
      {0, geometry_.bscans_per_group, geometry_.ascans_per_bscan, geometry_.samples_per_ascan},
      geometry_.bytes_per_sample, where);
  const std::uint64_t headers =
      check_shape(headers_set_.get(), kSlotHeadersDataset, {0, sizeof(shm::SlotHeader)}, 1, where);
  const std::uint64_t checksums =
      check_shape(checksums_set_.get(), kChecksumsDataset, {0}, 8, where);
  group_count_ = std::min({groups, headers, checksums});
  // A file closed in order holds every group it counted, each with its slot header and checksum:
  // one missing from any of them is a loss to name, not a shorter recording.
  const std::uint64_t written = counters_[static_cast<std::size_t>(Counter::groups_written)];
  if (finished() && (groups != written || headers != written || checksums != written)) {
    throw RingRecordingError(where + ": finished with " + std::to_string(written) +
                             " groups written, but it holds " + std::to_string(groups) +
                             " groups, " + std::to_string(headers) + " slot headers and " +
                             std::to_string(checksums) + " checksums (damaged)");
  }
  // Every complete group's samples are in the file: more groups than its size holds is a
  // truncated file (checked before anything is allocated for them); an unfinished file may end
  // inside its last group.
  const std::uint64_t room = file_bytes_ / group_bytes_ + (finished() ? 0 : 1);
  if (group_count_ > room) {
    throw RingRecordingError(where + ": " + std::to_string(group_count_) + " groups of " +
                             std::to_string(group_bytes_) + " bytes, but the file has " +
                             std::to_string(file_bytes_) + " bytes (truncated)");
  }
  group_count_ = count_complete_groups();
  return group_count_;
}

std::uint64_t RingRecordingReader::count_complete_groups() const {
  // A writer killed in the middle of a group may leave it partly in the file (an extent, a chunk
  // whose index or checksum did not reach the disk): the last group of an unfinished file is
  // counted only when it reads back intact. A finished file keeps every group, and
  // read_group() names what is wrong with one.
  if (group_count_ == 0 || finished()) return group_count_;
  std::vector<std::byte> payload(group_bytes_);
  shm::SlotHeader header{};
  try {
    read_group(group_count_ - 1, payload, header);
    return group_count_;
  } catch (const RingRecordingError&) {
    return group_count_ - 1;
  }
}

void RingRecordingReader::fail(const std::string& what) const {
  throw RingRecordingError(path_.string() + ": " + what);
}

void RingRecordingReader::read_header(std::uint64_t index, shm::SlotHeader& header) const {
  const std::string group = "group " + std::to_string(index);
  if (index >= group_count_) {
    fail(group + ": out of range (" + std::to_string(group_count_) + " groups)");
  }
  const hsize_t header_offset[2] = {index, 0};
  hsize_t header_bytes = 0;
  unsigned filter_mask = 0;
  if (H5Dget_chunk_storage_size(headers_set_.get(), header_offset, &header_bytes) < 0 ||
      header_bytes != sizeof header ||
      H5Dread_chunk(headers_set_.get(), H5P_DEFAULT, header_offset, &filter_mask, &header) < 0) {
    fail(group + ": slot header missing or of the wrong size: " + h5_error_stack());
  }
}

void RingRecordingReader::read_group(std::uint64_t index, std::span<std::byte> payload,
                                     shm::SlotHeader& header) const {
  if (payload.size() != group_bytes_) {
    throw std::invalid_argument("buffer of " + std::to_string(payload.size()) +
                                " bytes for a group of " + std::to_string(group_bytes_));
  }
  const std::string group = "group " + std::to_string(index);
  if (index >= group_count_) {
    fail(group + ": out of range (" + std::to_string(group_count_) + " groups)");
  }
  const hsize_t offset[4] = {index, 0, 0, 0};
  unsigned filter_mask = 0;
  haddr_t address = HADDR_UNDEF;
  hsize_t stored = 0;
  if (H5Dget_chunk_info_by_coord(groups_set_.get(), offset, &filter_mask, &address, &stored) < 0 ||
      address == HADDR_UNDEF) {
    h5_error_stack();
    fail(group + ": its samples are not in the file (no chunk)");
  }
  const std::string at = group + " at byte " + std::to_string(address);
  if (stored != group_bytes_ || filter_mask != 0) {
    fail(at + ": chunk of " + std::to_string(stored) + " bytes, the geometry makes " +
         std::to_string(group_bytes_) + " (corrupt chunk)");
  }
  if (address + stored > file_bytes_) {
    fail(at + ": chunk ends at byte " + std::to_string(address + stored) + ", the file has " +
         std::to_string(file_bytes_) + " (truncated)");
  }
  if (H5Dread_chunk(groups_set_.get(), H5P_DEFAULT, offset, &filter_mask, payload.data()) < 0) {
    fail(at + ": unreadable: " + h5_error_stack());
  }
  read_header(index, header);
  H5Handle file_space(H5Dget_space(checksums_set_.get()), H5Sclose);
  const hsize_t start[1] = {index}, count[1] = {1};
  H5Handle memory_space(H5Screate_simple(1, count, nullptr), H5Sclose);
  std::uint64_t expected = 0;
  if (!file_space || !memory_space ||
      H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start, nullptr, count, nullptr) < 0 ||
      H5Dread(checksums_set_.get(), H5T_NATIVE_UINT64, memory_space.get(), file_space.get(),
              H5P_DEFAULT, &expected) < 0) {
    fail(group + ": checksum unreadable: " + h5_error_stack());
  }
  const std::uint64_t actual = group_checksum(payload);
  if (actual != expected) {
    char text[96];
    std::snprintf(text, sizeof text, ": checksum %016llx, recorded %016llx (corrupt chunk)",
                  static_cast<unsigned long long>(actual),
                  static_cast<unsigned long long>(expected));
    fail(at + text);
  }
}

}  // namespace ioct::ringrec
