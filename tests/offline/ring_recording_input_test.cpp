// ioct-process on HDF5 ring recordings (ioct-record's): the volumes come from the slot headers'
// markers, so a recording that starts in the middle of a volume or lost a group yields only its
// complete volumes, and each is the same volume the same spectra give as a plain raw file.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include "ioct/gpu/offline/nrrd_file.hpp"
#include "ioct/ringrec/ring_recording_writer.hpp"
#include "offline_test_support.hpp"

namespace ioct::gpu::offline {
namespace {

namespace fs = std::filesystem;
using testing::ScratchDir;
using testing::SpectraSpec;

constexpr std::uint32_t kPerGroup = 4;
constexpr std::uint32_t kPerVolume = 8;

std::uint32_t brightest_depth(const Volume& v, std::uint32_t b, std::uint32_t a) {
  std::uint32_t best = 1;
  for (std::uint32_t d = 1; d < v.depth(); ++d) {
    if (v.at(b, a, d) > v.at(b, a, best)) best = d;
  }
  return best;
}

class RingRecordingInput : public ::testing::Test {
 protected:
  testing::ToolResult process(const std::vector<std::string>& args) {
    return testing::run_tool(IOCT_PROCESS_EXE, args, dir_.path());
  }
  ScratchDir dir_;
};

// Four groups of 4 B-scans: the second half of volume 5 (the recorder started mid-volume),
// volume 6 whole, then the first half of volume 7 (the rest was lost). Only volume 6 is complete.
TEST_F(RingRecordingInput, OnlyCompleteVolumesCountAndEachEqualsTheSameSpectraAsARawFile) {
  SpectraSpec spec;
  spec.bscans = 16;
  spec.depth = [](std::uint32_t b, std::uint32_t a) { return 30.0 + a + b; };
  const std::vector<std::uint16_t> spectra = testing::make_spectra(spec);
  shm::RingGeometry geometry;
  geometry.samples_per_ascan = spec.samples;
  geometry.ascans_per_bscan = spec.ascans;
  geometry.bscans_per_group = kPerGroup;
  geometry.bscans_per_volume = kPerVolume;
  const fs::path h5 = dir_ / "run.h5";
  {
    ringrec::RecordingDescription description;
    description.geometry = geometry;
    description.producer = "ring_recording_input_test";
    ringrec::RingRecordingWriter writer(h5, description, false);
    const std::size_t group_values = std::size_t{kPerGroup} * spec.ascans * spec.samples;
    const std::uint64_t volume_of_group[4] = {5, 6, 6, 7};
    const std::uint32_t first_in_volume[4] = {4, 0, 4, 0};
    for (std::uint64_t g = 0; g < 4; ++g) {
      shm::SlotHeader header{};
      header.group_index = 100 + g;
      header.bscan_count = kPerGroup;
      header.status_flags = shm::kStatusSimulated | shm::kStatusLaserOn;
      for (std::uint32_t b = 0; b < kPerGroup; ++b) {
        header.bscans[b].volume_index = volume_of_group[g];
        header.bscans[b].bscan_in_volume = first_in_volume[g] + b;
      }
      const auto group = std::span(spectra).subspan(g * group_values, group_values);
      writer.append(header, std::as_bytes(group));
    }
    writer.close({});
  }
  // The same spectra as a plain raw file: volume 6 is B-scans 4..11 of the recording.
  const std::size_t bscan_values = std::size_t{spec.ascans} * spec.samples;
  const std::vector<std::uint16_t> volume6(spectra.begin() + 4 * bscan_values,
                                           spectra.begin() + 12 * bscan_values);
  testing::write_u16_file(dir_ / "v6.u16", volume6, true);

  const auto from_h5 =
      process({h5.string(), "--volume", "0", "--out", (dir_ / "h5.nrrd").string()});
  ASSERT_EQ(from_h5.exit_code, 0) << from_h5.err;
  EXPECT_EQ(from_h5.err.find("acquired with faults"), std::string::npos) << from_h5.err;
  const auto from_raw =
      process({(dir_ / "v6.u16").string(), "--samples", std::to_string(spec.samples), "--ascans",
               std::to_string(spec.ascans), "--bscans", "8", "--bscans-per-group",
               std::to_string(kPerGroup), "--out", (dir_ / "raw.nrrd").string()});
  ASSERT_EQ(from_raw.exit_code, 0) << from_raw.err;

  const NrrdVolume a = read_nrrd_file(dir_ / "h5.nrrd");
  const NrrdVolume b = read_nrrd_file(dir_ / "raw.nrrd");
  ASSERT_EQ(a.volume.bscans(), kPerVolume);
  ASSERT_EQ(a.volume.ascans(), spec.ascans);
  ASSERT_EQ(a.volume.depth(), b.volume.depth());
  EXPECT_NE(a.metadata.content.find("volume 0 of run.h5"), std::string::npos) << a.metadata.content;
  std::uint64_t differing = 0;
  for (std::uint32_t z = 0; z < kPerVolume; ++z) {
    for (std::uint32_t x = 0; x < spec.ascans; ++x) {
      for (std::uint32_t d = 0; d < a.volume.depth(); ++d) {
        differing += a.volume.at(z, x, d) != b.volume.at(z, x, d);
      }
    }
    EXPECT_EQ(brightest_depth(a.volume, z, 7), 34 + 7 + z) << "B-scan " << z;
  }
  EXPECT_EQ(differing, 0u) << "voxels differ between the ring recording and the raw file";

  const auto missing =
      process({h5.string(), "--volume", "1", "--out", (dir_ / "none.nrrd").string()});
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("holds 1 complete volume (4 groups, 3 volumes begun); volume 1"),
            std::string::npos)
      << missing.err;
  EXPECT_FALSE(fs::exists(dir_ / "none.nrrd"));
}

TEST_F(RingRecordingInput, ACorruptChunkIsABadInputNamingGroupAndOffset) {
  SpectraSpec spec;
  spec.bscans = 8;
  const std::vector<std::uint16_t> spectra = testing::make_spectra(spec);
  shm::RingGeometry geometry;
  geometry.samples_per_ascan = spec.samples;
  geometry.ascans_per_bscan = spec.ascans;
  geometry.bscans_per_group = kPerGroup;
  geometry.bscans_per_volume = kPerVolume;
  const fs::path h5 = dir_ / "bad.h5";
  {
    ringrec::RecordingDescription description;
    description.geometry = geometry;
    ringrec::RingRecordingWriter writer(h5, description, false);
    const std::size_t group_values = std::size_t{kPerGroup} * spec.ascans * spec.samples;
    for (std::uint64_t g = 0; g < 2; ++g) {
      shm::SlotHeader header{};
      header.bscan_count = kPerGroup;
      for (std::uint32_t b = 0; b < kPerGroup; ++b) {
        header.bscans[b].bscan_in_volume = static_cast<std::uint32_t>(g * kPerGroup + b);
      }
      writer.append(header,
                    std::as_bytes(std::span(spectra).subspan(g * group_values, group_values)));
    }
    writer.close({});
  }
  // Flip bytes in the middle of the last group's samples (the file ends with the metadata the
  // close wrote, so find the samples by their content).
  std::vector<std::uint8_t> bytes = testing::read_bytes(h5);
  const std::size_t group_bytes = std::size_t{kPerGroup} * spec.ascans * spec.samples * 2;
  const auto* second = reinterpret_cast<const std::uint8_t*>(spectra.data()) + group_bytes;
  const auto at = std::search(bytes.begin(), bytes.end(), second, second + 64);
  ASSERT_NE(at, bytes.end());
  at[1000] ^= 0xff;
  testing::write_bytes(h5, bytes);
  const std::size_t offset = static_cast<std::size_t>(at - bytes.begin());

  const auto result = process({h5.string(), "--out", (dir_ / "v.nrrd").string()});
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(
      result.err.find("bad input: " + h5.string() + ": group 1 at byte " + std::to_string(offset)),
      std::string::npos)
      << result.err;
  EXPECT_NE(result.err.find("(corrupt chunk)"), std::string::npos) << result.err;
  EXPECT_FALSE(fs::exists(dir_ / "v.nrrd"));
}

}  // namespace
}  // namespace ioct::gpu::offline
