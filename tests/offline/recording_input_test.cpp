// ioct-process on raw recordings (recording/raw): the recording's metadata gives the dimensions,
// the calibration, the dispersion and the scan direction; --volume picks one of its volumes; a
// damaged recording or a volume it does not hold is refused with no output left. The last test
// records the simulator with ioct-sim-record and finds its RPE at the ground truth.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <string>
#include <vector>

#include "ioct/gpu/offline/nrrd_file.hpp"
#include "ioct/recording/recording_reader.hpp"
#include "ioct/recording/recording_writer.hpp"
#include "offline_test_support.hpp"

namespace ioct::gpu::offline {
namespace {

namespace fs = std::filesystem;
using testing::ScratchDir;
using testing::SpectraSpec;

std::uint32_t brightest_depth(const Volume& v, std::uint32_t b, std::uint32_t a,
                              std::uint32_t from = 1, std::uint32_t to = ~0u) {
  to = std::min(to, v.depth() - 1);
  std::uint32_t best = from;
  for (std::uint32_t d = from; d <= to; ++d) {
    if (v.at(b, a, d) > v.at(b, a, best)) best = d;
  }
  return best;
}

// Writes `spec`'s B-scans as a recording of groups of `per_group` B-scans, `per_volume` B-scans
// per volume; group `faulty_group` carries the overrun status bit.
void write_recording(const fs::path& stem, const SpectraSpec& spec, std::uint32_t per_group,
                     std::uint32_t per_volume, recording::RecordingMetadata metadata = {},
                     std::uint64_t faulty_group = ~std::uint64_t{0}) {
  metadata.geometry.samples_per_ascan = spec.samples;
  metadata.geometry.ascans_per_bscan = spec.ascans;
  metadata.geometry.flyback_sweeps = 0;
  metadata.geometry.bscans_per_group = per_group;
  metadata.geometry.bscans_per_volume = per_volume;
  metadata.producer = "recording_input_test";
  const std::vector<std::uint16_t> spectra = testing::make_spectra(spec);
  recording::RecordingWriter writer(stem, metadata);
  const std::size_t group_values = std::size_t{per_group} * spec.ascans * spec.samples;
  for (std::size_t g = 0; g * group_values < spectra.size(); ++g) {
    recording::RecordedGroupInfo info;
    info.first_sweep_counter = g * per_group * spec.ascans;
    if (g == faulty_group) info.status = recording::kStatusOverrun;
    writer.append(std::span(spectra).subspan(g * group_values, group_values), info);
  }
  writer.close();
}

class RecordingInput : public ::testing::Test {
 protected:
  testing::ToolResult process(const std::vector<std::string>& args) {
    return testing::run_tool(IOCT_PROCESS_EXE, args, dir_.path());
  }
  ScratchDir dir_;
};

// Two volumes of 8 B-scans in groups of 4; the reflector deepens with every B-scan of the
// recording, so each volume's B-scans show where they came from.
TEST_F(RecordingInput, EachVolumeOfTheRecordingComesFromItsOwnBscans) {
  SpectraSpec spec;
  spec.bscans = 16;
  spec.depth = [](std::uint32_t b, std::uint32_t a) { return 30.0 + a + b; };
  write_recording(dir_ / "run", spec, 4, 8, {}, 3);

  const auto first = process({(dir_ / "run.json").string(), "--out", (dir_ / "v0.nrrd").string()});
  ASSERT_EQ(first.exit_code, 0) << first.err;
  EXPECT_EQ(first.err.find("acquired with faults"), std::string::npos) << first.err;
  const auto second =
      process({(dir_ / "run").string(), "--volume", "1", "--out", (dir_ / "v1.nrrd").string()});
  ASSERT_EQ(second.exit_code, 0) << second.err;
  EXPECT_NE(second.err.find("acquired with faults (status bits 0x1"), std::string::npos)
      << "group 3 (in volume 1) was recorded with an overrun: " << second.err;

  const NrrdVolume v0 = read_nrrd_file(dir_ / "v0.nrrd");
  const NrrdVolume v1 = read_nrrd_file(dir_ / "v1.nrrd");
  ASSERT_EQ(v0.volume.bscans(), 8u);
  ASSERT_EQ(v0.volume.ascans(), spec.ascans);
  ASSERT_EQ(v0.volume.depth(), spec.samples / 2);
  EXPECT_NE(v1.metadata.content.find("volume 1 of run"), std::string::npos) << v1.metadata.content;
  for (std::uint32_t z = 0; z < 8; ++z) {
    for (std::uint32_t x = 0; x < spec.ascans; x += 7) {
      EXPECT_EQ(brightest_depth(v0.volume, z, x), 30 + x + z) << "volume 0, B-scan " << z;
      EXPECT_EQ(brightest_depth(v1.volume, z, x), 38 + x + z) << "volume 1, B-scan " << z;
    }
  }
}

// The recording says its samples are linear in λ (a calibration) and that odd lines run
// backwards: both are applied without options, and options still override them.
TEST_F(RecordingInput, CalibrationAndScanDirectionComeFromTheMetadata) {
  const std::vector<double> c{0.0, 0.85, 0.15};
  SpectraSpec spec;
  spec.samples = 512;
  spec.ascans = 8;
  spec.bscans = 4;
  spec.depth = [](std::uint32_t b, std::uint32_t a) { return b % 2 == 1 ? 150.0 + a : 150.0; };
  spec.position = [&](std::uint32_t i) { return testing::inverse_calibration_position(c, 512, i); };
  recording::RecordingMetadata metadata;
  metadata.resampling_coefficients = c;
  metadata.scan.bidirectional = true;
  write_recording(dir_ / "cal", spec, 2, 4, metadata);

  const auto run = process({(dir_ / "cal").string(), "--out", (dir_ / "v.nrrd").string()});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const Volume v = read_nrrd_file(dir_ / "v.nrrd").volume;
  for (std::uint32_t x = 0; x < spec.ascans; ++x) {
    EXPECT_NEAR(brightest_depth(v, 0, x), 150.0, 1.0) << "resampled; A-scan " << x;
    EXPECT_NEAR(brightest_depth(v, 1, x), 150.0 + (spec.ascans - 1 - x), 1.0)
        << "odd B-scan flipped; A-scan " << x;
  }
  const auto forward = process(
      {(dir_ / "cal").string(), "--out", (dir_ / "f.nrrd").string(), "--bidirectional=false"});
  ASSERT_EQ(forward.exit_code, 0) << forward.err;
  EXPECT_NEAR(brightest_depth(read_nrrd_file(dir_ / "f.nrrd").volume, 1, 0), 150.0, 1.0)
      << "--bidirectional=false overrides the metadata";
}

TEST_F(RecordingInput, AVolumeTheRecordingDoesNotHoldIsRefusedAndNothingIsWritten) {
  SpectraSpec spec;
  spec.bscans = 8;
  write_recording(dir_ / "run", spec, 4, 8);
  fs::create_directory(dir_ / "out");
  const auto run = process(
      {(dir_ / "run").string(), "--volume", "1", "--out", (dir_ / "out" / "v.nrrd").string()});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("holds 1 whole volume"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("volume 1 was asked for"), std::string::npos) << run.err;
  EXPECT_TRUE(fs::is_empty(dir_ / "out"));

  const auto dims = process({(dir_ / "run.json").string(), "--out",
                             (dir_ / "out" / "v.nrrd").string(), "--samples", "256"});
  EXPECT_EQ(dims.exit_code, 2);
  EXPECT_NE(dims.err.find("metadata gives its dimensions"), std::string::npos) << dims.err;
  EXPECT_TRUE(fs::is_empty(dir_ / "out"));
}

TEST_F(RecordingInput, ATruncatedRecordingIsABadInputNamingTheFile) {
  SpectraSpec spec;
  spec.bscans = 8;
  write_recording(dir_ / "run", spec, 4, 8);
  fs::resize_file(dir_ / "run.raw", fs::file_size(dir_ / "run.raw") - 1000);
  fs::create_directory(dir_ / "out");
  const auto run = process({(dir_ / "run").string(), "--out", (dir_ / "out" / "v.nrrd").string()});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("bad input"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("run.raw"), std::string::npos) << run.err;
  EXPECT_TRUE(fs::is_empty(dir_ / "out"));
}

// Simulated retina with a dispersion mismatch, recorded by ioct-sim-record: ioct-process takes
// the correction from the metadata and puts the RPE at the ground truth; forcing the correction
// off (options override the metadata) blurs it.
TEST_F(RecordingInput, SimulatedRecordingPutsTheRpeAtTheGroundTruth) {
  const auto record = testing::run_tool(
      IOCT_SIM_RECORD_EXE,
      {"--out", (dir_ / "sim").string(), "--groups", "2", "--samples", "1024", "--ascans", "64",
       "--bscans-per-group", "4", "--bscans-per-volume", "8", "--c2", "12", "--c3", "4"},
      dir_.path());
  ASSERT_EQ(record.exit_code, 0) << record.err;
  const auto run = process({(dir_ / "sim").string(), "--out", (dir_ / "v.nrrd").string()});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto blurred = process({(dir_ / "sim").string(), "--out", (dir_ / "b.nrrd").string(),
                                "--dispersion-c2", "0", "--dispersion-c3", "0"});
  ASSERT_EQ(blurred.exit_code, 0) << blurred.err;
  const Volume v = read_nrrd_file(dir_ / "v.nrrd").volume;
  const Volume b = read_nrrd_file(dir_ / "b.nrrd").volume;

  const recording::RecordingReader reader(dir_ / "sim");
  recording::GroupTruth truth;
  double error_sum = 0.0, sharp_sum = 0.0, blurred_sum = 0.0;
  std::uint32_t count = 0;
  for (std::uint64_t g = 0; g < reader.group_count(); ++g) {
    reader.read_truth(g, truth);
    for (std::uint32_t i = 0; i < truth.bscans; ++i) {
      const std::uint32_t z = static_cast<std::uint32_t>(g * 4 + i);
      for (std::uint32_t x = 0; x < truth.ascans_per_bscan; ++x) {
        const float rpe = truth.rpe_px[std::size_t{i} * truth.ascans_per_bscan + x];
        if (!std::isfinite(rpe)) continue;
        const auto centre = static_cast<std::uint32_t>(std::lround(rpe));
        const std::uint32_t peak = brightest_depth(v, z, x, centre - 4, centre + 4);
        error_sum += std::abs(double(peak) - rpe);
        sharp_sum += v.at(z, x, peak);
        blurred_sum += b.at(z, x, brightest_depth(b, z, x, centre - 4, centre + 4));
        ++count;
      }
    }
  }
  ASSERT_GT(count, 400u);
  std::cout << "[ figures  ] RPE: " << count << " A-scans, mean |peak - truth| "
            << error_sum / count << " px, mean peak " << sharp_sum / count << " corrected, "
            << blurred_sum / count << " without the correction\n";
  EXPECT_LT(error_sum / count, 1.0) << "mean |RPE peak - truth| over " << count << " A-scans";
  EXPECT_GT(sharp_sum / count, blurred_sum / count + 10.0)
      << "with the recording's dispersion correction the RPE is brighter (sharper)";
}

}  // namespace
}  // namespace ioct::gpu::offline
