// The HDF5 ring recording as a file: what the writer appends reads back bit for bit with its
// slot headers; the reader refuses a foreign file, a wrong geometry, a corrupted chunk and a
// truncated file with messages naming the group and its byte offset.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "ioct/ringrec/ring_recording_reader.hpp"
#include "ioct/ringrec/ring_recording_writer.hpp"
#include "ioct/test_support/temp_path.hpp"

namespace ioct::ringrec {
namespace {

namespace fs = std::filesystem;

shm::RingGeometry small_geometry() {
  shm::RingGeometry g;
  g.samples_per_ascan = 64;
  g.ascans_per_bscan = 32;
  g.bscans_per_group = 4;
  g.bscans_per_volume = 8;
  return g;
}

// A group whose bytes depend on its index, and its slot header.
std::vector<std::byte> make_group(const shm::RingGeometry& g, std::uint64_t index) {
  std::vector<std::byte> payload(g.group_payload_bytes());
  std::mt19937_64 random(index + 1);
  for (auto& b : payload) b = static_cast<std::byte>(random());
  return payload;
}

shm::SlotHeader make_header(const shm::RingGeometry& g, std::uint64_t index) {
  shm::SlotHeader h{};
  h.group_index = index;
  h.producer_epoch = 7;
  h.payload_bytes = g.group_payload_bytes();
  h.first_sweep_counter = 1000 * index;
  h.t_publish_ns = 123456789 + index;
  h.bscan_count = g.bscans_per_group;
  h.bscans[1].volume_index = index / 2;
  h.bscans[1].galvo_start[0] = 0.25f;
  return h;
}

void write_groups(const fs::path& path, const shm::RingGeometry& g, std::uint64_t count) {
  RecordingDescription description;
  description.geometry = g;
  description.ring_name = "test-ring";
  description.producer = "ring_recording_file_test";
  description.run_metadata = "[scan]\npattern = \"raster\"\n";
  RingRecordingWriter writer(path, description, false);
  CounterValues counters{};
  for (std::uint64_t i = 0; i < count; ++i) {
    writer.append(make_header(g, i), make_group(g, i));
    counters[static_cast<std::size_t>(Counter::groups_written)] = i + 1;
    writer.write_counters(counters);
  }
  writer.close(counters);
}

// The byte offset the reader names for group `index`'s samples.
std::uint64_t chunk_address(const fs::path& path, std::uint64_t index) {
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY | H5F_ACC_SWMR_READ, H5P_DEFAULT);
  const hid_t set = H5Dopen2(file, "groups", H5P_DEFAULT);
  const hsize_t offset[4] = {index, 0, 0, 0};
  unsigned mask = 0;
  haddr_t address = 0;
  hsize_t size = 0;
  EXPECT_GE(H5Dget_chunk_info_by_coord(set, offset, &mask, &address, &size), 0);
  H5Dclose(set);
  H5Fclose(file);
  return address;
}

TEST(RingRecordingFile, GroupsAndSlotHeadersReadBackBitForBit) {
  const test_support::TempPath file("ringrec-roundtrip", ".h5");
  const shm::RingGeometry g = small_geometry();
  write_groups(file.path(), g, 5);

  const RingRecordingReader reader(file.path());
  EXPECT_EQ(reader.geometry(), g);
  EXPECT_EQ(reader.group_count(), 5u);
  EXPECT_TRUE(reader.finished());
  EXPECT_EQ(reader.counters()[static_cast<std::size_t>(Counter::groups_written)], 5u);
  EXPECT_EQ(reader.ring_name(), "test-ring");
  EXPECT_EQ(reader.run_metadata(), "[scan]\npattern = \"raster\"\n");
  std::vector<std::byte> payload(reader.group_bytes());
  for (std::uint64_t i = 0; i < 5; ++i) {
    shm::SlotHeader header{};
    reader.read_group(i, payload, header);
    EXPECT_EQ(payload, make_group(g, i)) << "group " << i;
    const shm::SlotHeader expected = make_header(g, i);
    EXPECT_EQ(std::memcmp(&header, &expected, sizeof header), 0) << "slot header " << i;
  }
  shm::SlotHeader header{};
  EXPECT_THROW(reader.read_group(5, payload, header), RingRecordingError);
}

TEST(RingRecordingFile, RefusesToOverwriteUnlessAsked) {
  const test_support::TempPath file("ringrec-exists", ".h5");
  write_groups(file.path(), small_geometry(), 1);
  RecordingDescription description;
  description.geometry = small_geometry();
  try {
    RingRecordingWriter writer(file.path(), description, false);
    FAIL() << "an existing file was overwritten";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("--overwrite"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(RingRecordingWriter(file.path(), description, true));
}

TEST(RingRecordingFile, CorruptedChunkIsNamedByGroupAndOffset) {
  const test_support::TempPath file("ringrec-corrupt", ".h5");
  const shm::RingGeometry g = small_geometry();
  write_groups(file.path(), g, 4);
  const std::uint64_t address = chunk_address(file.path(), 2);
  ASSERT_GT(address, 0u);
  {
    std::fstream f(file.path(), std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(address + 100));
    const char flipped[4] = {'\x5a', '\x5a', '\x5a', '\x5a'};
    f.write(flipped, sizeof flipped);
  }
  const RingRecordingReader reader(file.path());
  std::vector<std::byte> payload(reader.group_bytes());
  shm::SlotHeader header{};
  EXPECT_NO_THROW(reader.read_group(1, payload, header));
  try {
    reader.read_group(2, payload, header);
    FAIL() << "a corrupted chunk was read without complaint";
  } catch (const RingRecordingError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("group 2 at byte " + std::to_string(address)), std::string::npos)
        << message;
    EXPECT_NE(message.find("corrupt chunk"), std::string::npos) << message;
  }
}

TEST(RingRecordingFile, TruncatedFileIsRefusedOrShortened) {
  const test_support::TempPath file("ringrec-truncated", ".h5");
  const shm::RingGeometry g = small_geometry();
  write_groups(file.path(), g, 6);
  const std::uint64_t address = chunk_address(file.path(), 3);
  fs::resize_file(file.path(), address + 10);  // cut inside group 3
  try {
    const RingRecordingReader reader(file.path());
    std::vector<std::byte> payload(reader.group_bytes());
    shm::SlotHeader header{};
    for (std::uint64_t i = 0; i < reader.group_count(); ++i) reader.read_group(i, payload, header);
    FAIL() << "a truncated file read back " << reader.group_count() << " groups";
  } catch (const RingRecordingError& e) {
    // Either the file's metadata went with the cut, or a group's chunk runs past the end.
    std::printf("[ message  ] %s\n", e.what());
    EXPECT_NE(std::string(e.what()).find(file.path().string()), std::string::npos) << e.what();
  }
}

// A file closed in order that lost a group's slot header (a dataset cut short by a tool or a
// damaged copy) is refused as damaged, not read as a recording of one group fewer.
TEST(RingRecordingFile, FinishedFileMissingAGroupsSlotHeaderIsDamagedNotShorter) {
  const test_support::TempPath file("ringrec-damaged", ".h5");
  write_groups(file.path(), small_geometry(), 3);
  EXPECT_EQ(RingRecordingReader(file.path()).group_count(), 3u);
  {
    const hid_t f = H5Fopen(file.path().c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(f, 0) << "cannot reopen the closed recording for writing";
    const hid_t set = H5Dopen2(f, "slot_headers", H5P_DEFAULT);
    const hsize_t shorter[2] = {2, sizeof(shm::SlotHeader)};
    ASSERT_GE(H5Dset_extent(set, shorter), 0);
    H5Dclose(set);
    H5Fclose(f);
  }
  try {
    RingRecordingReader reader(file.path());
    FAIL() << "a finished file missing a slot header read back " << reader.group_count()
           << " groups";
  } catch (const RingRecordingError& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "finished with 3 groups written, but it holds 3 groups, 2 slot headers and 3 "
                  "checksums (damaged)"),
              std::string::npos)
        << e.what();
  }
}

TEST(RingRecordingFile, ForeignAndWrongGeometryFilesAreRefusedNamingBothValues) {
  const test_support::TempPath file("ringrec-foreign", ".h5");
  const hid_t h5 = H5Fcreate(file.path().c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(h5, 0);
  H5Fclose(h5);
  try {
    RingRecordingReader reader(file.path());
    FAIL() << "an HDF5 file of another kind was accepted";
  } catch (const RingRecordingError& e) {
    EXPECT_NE(std::string(e.what()).find("missing attribute 'format'"), std::string::npos)
        << e.what();
  }

  // A recording whose geometry attribute disagrees with the groups dataset's shape.
  const test_support::TempPath wrong("ringrec-geometry", ".h5");
  write_groups(wrong.path(), small_geometry(), 2);
  {
    const hid_t f = H5Fopen(wrong.path().c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(f, 0) << "cannot reopen the closed recording for writing";
    const hid_t attribute = H5Aopen(f, "samples_per_ascan", H5P_DEFAULT);
    const std::uint64_t value = 128;
    H5Awrite(attribute, H5T_NATIVE_UINT64, &value);
    H5Aclose(attribute);
    H5Fclose(f);
  }
  try {
    RingRecordingReader reader(wrong.path());
    FAIL() << "a recording whose geometry disagrees with its data was accepted";
  } catch (const RingRecordingError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("samples_per_ascan = 64, but the geometry says 128"), std::string::npos)
        << message;
  }

  // A text attribute that is an array of strings, not one: refused before it is read (reading it
  // into a buffer sized for one string would overrun it).
  const test_support::TempPath strings("ringrec-strings", ".h5");
  write_groups(strings.path(), small_geometry(), 1);
  {
    const hid_t f = H5Fopen(strings.path().c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(f, 0) << "cannot reopen the closed recording for writing";
    ASSERT_GE(H5Adelete(f, "run_metadata"), 0);
    const hid_t type = H5Tcopy(H5T_C_S1);
    H5Tset_size(type, 8);
    const hsize_t count[1] = {64};
    const hid_t space = H5Screate_simple(1, count, nullptr);
    const hid_t attribute = H5Acreate2(f, "run_metadata", type, space, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(attribute, 0);
    const std::string texts(64 * 8, 'x');
    ASSERT_GE(H5Awrite(attribute, type, texts.data()), 0);
    H5Aclose(attribute);
    H5Sclose(space);
    H5Tclose(type);
    H5Fclose(f);
  }
  try {
    RingRecordingReader reader(strings.path());
    FAIL() << "an array of strings was read as the run's metadata";
  } catch (const RingRecordingError& e) {
    EXPECT_NE(std::string(e.what()).find("attribute 'run_metadata' is not one fixed-length string"),
              std::string::npos)
        << e.what();
  }

  const test_support::TempPath text("ringrec-text", ".h5");
  std::ofstream(text.path()) << "not hdf5";
  EXPECT_THROW(RingRecordingReader{text.path()}, RingRecordingError);
}

}  // namespace
}  // namespace ioct::ringrec
