#include "ioct/ringrec/ring_recording_writer.hpp"

#include <chrono>
#include <ctime>
#include <stdexcept>
#include <system_error>

namespace ioct::ringrec {
namespace {

constexpr hsize_t kChecksumChunk = 512;

H5Handle make(hid_t id, H5Handle::Closer closer, const std::string& what) {
  return H5Handle(h5_check_id(id, what), closer);
}

void write_string_attribute(hid_t object, const char* name, const std::string& value) {
  H5Handle type = make(H5Tcopy(H5T_C_S1), H5Tclose, "string type");
  h5_check(H5Tset_size(type.get(), value.empty() ? 1 : value.size()), "string size");
  h5_check(H5Tset_strpad(type.get(), H5T_STR_NULLPAD), "string padding");
  H5Handle space = make(H5Screate(H5S_SCALAR), H5Sclose, "scalar space");
  H5Handle attribute =
      make(H5Acreate2(object, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
           std::string("attribute ") + name);
  const std::string stored = value.empty() ? std::string(1, '\0') : value;
  h5_check(H5Awrite(attribute.get(), type.get(), stored.data()), std::string("attribute ") + name);
}

void write_u64_attribute(hid_t object, const char* name, std::uint64_t value) {
  H5Handle space = make(H5Screate(H5S_SCALAR), H5Sclose, "scalar space");
  H5Handle attribute =
      make(H5Acreate2(object, name, H5T_STD_U64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
           std::string("attribute ") + name);
  h5_check(H5Awrite(attribute.get(), H5T_NATIVE_UINT64, &value), std::string("attribute ") + name);
}

std::string utc_now() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

// An extensible dataset of `rank` dimensions, first one unlimited, chunked as given, whose
// chunks are allocated only when written and never filled.
H5Handle extensible_dataset(hid_t file, const char* name, hid_t type, int rank,
                            const hsize_t* chunk) {
  hsize_t dims[4] = {0, 0, 0, 0};
  hsize_t max[4] = {H5S_UNLIMITED, 0, 0, 0};
  for (int i = 1; i < rank; ++i) dims[i] = max[i] = chunk[i];
  H5Handle space = make(H5Screate_simple(rank, dims, max), H5Sclose, std::string(name) + " space");
  H5Handle dcpl = make(H5Pcreate(H5P_DATASET_CREATE), H5Pclose, "dataset properties");
  h5_check(H5Pset_chunk(dcpl.get(), rank, chunk), std::string(name) + " chunk");
  h5_check(H5Pset_fill_time(dcpl.get(), H5D_FILL_TIME_NEVER), "fill time");
  h5_check(H5Pset_alloc_time(dcpl.get(), H5D_ALLOC_TIME_INCR), "allocation time");
  // Direct chunk writes bypass the chunk cache; the small datasets need only a little of it.
  H5Handle dapl = make(H5Pcreate(H5P_DATASET_ACCESS), H5Pclose, "dataset access properties");
  h5_check(H5Pset_chunk_cache(dapl.get(), 521, 1 << 20, 1.0), "chunk cache");
  return make(H5Dcreate2(file, name, type, space.get(), H5P_DEFAULT, dcpl.get(), dapl.get()),
              H5Dclose, std::string("dataset ") + name);
}

}  // namespace

hid_t sample_type(std::uint32_t bytes_per_sample) {
  switch (bytes_per_sample) {
    case 1:
      return H5T_STD_U8LE;
    case 2:
      return H5T_STD_U16LE;
    case 4:
      return H5T_STD_U32LE;
    default:
      throw std::invalid_argument("bytes_per_sample = " + std::to_string(bytes_per_sample) +
                                  ": must be 1, 2 or 4");
  }
}

RingRecordingWriter::RingRecordingWriter(const std::filesystem::path& path,
                                         const RecordingDescription& description, bool overwrite)
    : path_(path) {
  h5_quiet();
  const shm::RingGeometry& g = description.geometry;
  g.validate();
  group_bytes_ = g.group_payload_bytes();
  samples_ = g.samples_per_ascan;
  ascans_ = g.ascans_per_bscan;
  bscans_ = g.bscans_per_group;
  std::error_code ec;
  if (!overwrite && std::filesystem::exists(path, ec)) {
    throw std::runtime_error(path.string() + ": exists; choose another name or pass --overwrite");
  }

  H5Handle fapl = make(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, "file access properties");
  // SWMR needs the latest file format (1.10's).
  h5_check(H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_LATEST, H5F_LIBVER_LATEST),
           "library version bounds");
  // Without overwrite, EXCL also refuses a file that appeared since the check above (O_EXCL).
  file_ = make(
      H5Fcreate(path.c_str(), overwrite ? H5F_ACC_TRUNC : H5F_ACC_EXCL, H5P_DEFAULT, fapl.get()),
      H5Fclose, path.string() + ": cannot create");

  const hid_t root = file_.get();
  write_string_attribute(root, "format", std::string(kFormatName));
  write_u64_attribute(root, "version", kFormatVersion);
  write_string_attribute(root, "producer", description.producer);
  write_string_attribute(root, "created_utc", utc_now());
  write_string_attribute(root, "ring_name", description.ring_name);
  write_u64_attribute(root, "ring_producer_pid", description.producer_pid);
  write_u64_attribute(root, "ring_layout_version", shm::kRingLayoutVersion);
  write_u64_attribute(root, "samples_per_ascan", g.samples_per_ascan);
  write_u64_attribute(root, "ascans_per_bscan", g.ascans_per_bscan);
  write_u64_attribute(root, "bscans_per_group", g.bscans_per_group);
  write_u64_attribute(root, "bscans_per_volume", g.bscans_per_volume);
  write_u64_attribute(root, "bytes_per_sample", g.bytes_per_sample);
  write_u64_attribute(root, "slot_header_bytes", sizeof(shm::SlotHeader));
  write_string_attribute(root, "run_metadata", description.run_metadata);

  const hsize_t group_chunk[4] = {1, bscans_, ascans_, samples_};
  groups_set_ =
      extensible_dataset(root, kGroupsDataset, sample_type(g.bytes_per_sample), 4, group_chunk);
  const hsize_t header_chunk[2] = {1, sizeof(shm::SlotHeader)};
  headers_set_ = extensible_dataset(root, kSlotHeadersDataset, H5T_STD_U8LE, 2, header_chunk);
  const hsize_t checksum_chunk[1] = {kChecksumChunk};
  checksums_set_ = extensible_dataset(root, kChecksumsDataset, H5T_STD_U64LE, 1, checksum_chunk);

  const hsize_t counter_dims[1] = {kCounterCount};
  H5Handle space = make(H5Screate_simple(1, counter_dims, nullptr), H5Sclose, "counters space");
  counters_set_ = make(H5Dcreate2(root, kCountersDataset, H5T_STD_U64LE, space.get(), H5P_DEFAULT,
                                  H5P_DEFAULT, H5P_DEFAULT),
                       H5Dclose, "dataset counters");
  std::string names;
  for (std::string_view name : kCounterNames) {
    if (!names.empty()) names += ',';
    names += name;
  }
  write_string_attribute(counters_set_.get(), "names", names);
  write_counters(CounterValues{});

  // From here on only raw data and dataset extents change: what SWMR allows.
  h5_check(H5Fstart_swmr_write(root), path.string() + ": cannot start SWMR writing");
}

RingRecordingWriter::~RingRecordingWriter() = default;

void RingRecordingWriter::append(const shm::SlotHeader& header,
                                 std::span<const std::byte> payload) {
  if (payload.size() != group_bytes_) {
    throw std::invalid_argument("group of " + std::to_string(payload.size()) +
                                " bytes; the recording's groups have " +
                                std::to_string(group_bytes_));
  }
  const hsize_t n = groups_;
  const std::string where = path_.string() + ": group " + std::to_string(n);
  // The slot header is written last: a reader counts the groups by it, so a group whose header
  // is in the file has its samples and checksum there too.
  const hsize_t group_extent[4] = {n + 1, bscans_, ascans_, samples_};
  h5_check(H5Dset_extent(groups_set_.get(), group_extent), where + ": extend groups");
  const hsize_t group_offset[4] = {n, 0, 0, 0};
  h5_check(H5Dwrite_chunk(groups_set_.get(), H5P_DEFAULT, 0, group_offset, payload.size(),
                          payload.data()),
           where + ": write samples");

  const hsize_t checksum_extent[1] = {n + 1};
  h5_check(H5Dset_extent(checksums_set_.get(), checksum_extent), where + ": extend checksums");
  {
    H5Handle file_space = make(H5Dget_space(checksums_set_.get()), H5Sclose, "checksum space");
    const hsize_t start[1] = {n}, count[1] = {1};
    h5_check(H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start, nullptr, count, nullptr),
             "checksum selection");
    H5Handle memory_space = make(H5Screate_simple(1, count, nullptr), H5Sclose, "memory space");
    const std::uint64_t checksum = group_checksum(payload);
    h5_check(H5Dwrite(checksums_set_.get(), H5T_NATIVE_UINT64, memory_space.get(), file_space.get(),
                      H5P_DEFAULT, &checksum),
             where + ": write checksum");
  }

  const hsize_t header_extent[2] = {n + 1, sizeof(shm::SlotHeader)};
  h5_check(H5Dset_extent(headers_set_.get(), header_extent), where + ": extend slot headers");
  const hsize_t header_offset[2] = {n, 0};
  h5_check(H5Dwrite_chunk(headers_set_.get(), H5P_DEFAULT, 0, header_offset,
                          sizeof(shm::SlotHeader), &header),
           where + ": write slot header");
  ++groups_;
}

void RingRecordingWriter::write_counters(const CounterValues& values) {
  h5_check(H5Dwrite(counters_set_.get(), H5T_NATIVE_UINT64, H5S_ALL, H5S_ALL, H5P_DEFAULT,
                    values.data()),
           path_.string() + ": write counters");
  // After every group (append is followed by write_counters): a process killed later leaves
  // this state in the file.
  h5_check(H5Fflush(file_.get(), H5F_SCOPE_LOCAL), path_.string() + ": flush");
}

void RingRecordingWriter::close(CounterValues values) {
  // An append that failed part-way (a write error) may have grown a dataset past the groups
  // appended whole: cut it back, so the finished file holds exactly them. (Normally nothing to
  // do; if the cut fails too, close() throws and the file stays unfinished, still readable.)
  bool cut = false;
  const auto trim = [&](const H5Handle& set, int rank, const char* what) {
    H5Handle space = make(H5Dget_space(set.get()), H5Sclose, what);
    hsize_t dims[4] = {};
    if (H5Sget_simple_extent_ndims(space.get()) != rank ||
        H5Sget_simple_extent_dims(space.get(), dims, nullptr) < 0) {
      throw H5Error(path_.string() + ": " + what + ": unreadable extent");
    }
    if (dims[0] <= groups_) return;
    dims[0] = groups_;
    h5_check(H5Dset_extent(set.get(), dims), path_.string() + ": cut back " + what);
    cut = true;
  };
  trim(groups_set_, 4, "groups");
  trim(checksums_set_, 1, "checksums");
  trim(headers_set_, 2, "slot headers");
  // The cut reaches the file before the counters that call it finished, so a reader never sees
  // "finished" over datasets still longer than the groups it counts.
  if (cut) h5_check(H5Fflush(file_.get(), H5F_SCOPE_LOCAL), path_.string() + ": flush the cut");
  // The file's own count: a reader holds a finished file to exactly this many groups.
  values[static_cast<std::size_t>(Counter::groups_written)] = groups_;
  values[static_cast<std::size_t>(Counter::finished)] = 1;
  write_counters(values);
  counters_set_.close(path_.string() + ": close counters");
  checksums_set_.close(path_.string() + ": close checksums");
  headers_set_.close(path_.string() + ": close slot headers");
  groups_set_.close(path_.string() + ": close groups");
  file_.close(path_.string() + ": close");
}

}  // namespace ioct::ringrec
