// ioct-process and ioct-vol-import as processes: what they write, that it is what the library
// computes, and that bad input ends with a clear message, a non-zero exit and no output.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

#include "bioptigen_test_file.hpp"
#include "ioct/gpu/filters/cpu_volume_filter.hpp"
#include "ioct/gpu/offline/bioptigen_oct.hpp"
#include "ioct/gpu/offline/heidelberg_vol.hpp"
#include "ioct/gpu/offline/nrrd_file.hpp"
#include "ioct/gpu/volume/png_file.hpp"
#include "offline_test_support.hpp"

namespace ioct::gpu::offline {
namespace {

namespace fs = std::filesystem;
using testing::ScratchDir;
using testing::SpectraSpec;

std::vector<std::string> layout_args(const SpectraSpec& spec) {
  return {"--samples", std::to_string(spec.samples), "--ascans", std::to_string(spec.ascans),
          "--bscans",  std::to_string(spec.bscans)};
}

std::vector<std::string> concat(std::vector<std::string> a, const std::vector<std::string>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

// The depth pixel where A-scan (b, a) is brightest.
std::uint32_t brightest_depth(const Volume& v, std::uint32_t b, std::uint32_t a) {
  std::uint32_t best = 0;
  for (std::uint32_t d = 1; d < v.depth(); ++d) {
    if (v.at(b, a, d) > v.at(b, a, best)) best = d;
  }
  return best;
}

// A reflector whose depth changes across the volume, so placement and orientation show.
SpectraSpec tilted_spec() {
  SpectraSpec spec;
  spec.depth = [](std::uint32_t b, std::uint32_t a) { return 30.0 + a + b; };
  return spec;
}

class ProcessCommand : public ::testing::Test {
 protected:
  testing::ToolResult process(const std::vector<std::string>& args) {
    return testing::run_tool(IOCT_PROCESS_EXE, args, dir_.path());
  }
  ScratchDir dir_;
};

TEST_F(ProcessCommand, EitherByteOrderGivesTheSameVolumeWithEachReflectorAtItsDepth) {
  const SpectraSpec spec = tilted_spec();
  const auto spectra = testing::make_spectra(spec);
  testing::write_u16_file(dir_ / "le.raw", spectra, true);
  testing::write_u16_file(dir_ / "be.raw", spectra, false);
  const auto le =
      process(concat({(dir_ / "le.raw").string(), "--out", (dir_ / "le.nrrd").string(), "--png",
                      (dir_ / "le.png").string(), "--spacing-mm", "0.0056,0.012,0.05"},
                     layout_args(spec)));
  ASSERT_EQ(le.exit_code, 0) << le.err;
  const auto be = process(concat({(dir_ / "be.raw").string(), "--out", (dir_ / "be.nrrd").string(),
                                  "--byte-order", "big", "--spacing-mm", "0.0056,0.012,0.05"},
                                 layout_args(spec)));
  ASSERT_EQ(be.exit_code, 0) << be.err;
  EXPECT_EQ(le.err.find('\r'), std::string::npos) << "no progress bar when stderr is a file";

  const NrrdVolume a = read_nrrd_file(dir_ / "le.nrrd");
  const NrrdVolume b = read_nrrd_file(dir_ / "be.nrrd");
  ASSERT_EQ(a.volume.bscans(), spec.bscans);
  ASSERT_EQ(a.volume.ascans(), spec.ascans);
  ASSERT_EQ(a.volume.depth(), spec.samples / 2);
  EXPECT_EQ(a.metadata.spacings, (std::array<double, 3>{0.0056, 0.012, 0.05}));
  EXPECT_EQ(a.metadata.unit, "mm");
  for (std::uint32_t z = 0; z < spec.bscans; ++z) {
    EXPECT_TRUE(std::ranges::equal(a.volume.bscan(z), b.volume.bscan(z))) << "B-scan " << z;
    for (std::uint32_t x = 0; x < spec.ascans; ++x) {
      ASSERT_EQ(brightest_depth(a.volume, z, x), 30 + x + z) << "B-scan " << z << ", A-scan " << x;
    }
  }
  const GrayImage png = read_png_gray8(dir_ / "le.png");
  EXPECT_EQ(png.width, spec.ascans);
  EXPECT_EQ(png.height, spec.samples / 2);
}

TEST_F(ProcessCommand, BidirectionalFlipsOddBscans) {
  const SpectraSpec spec = tilted_spec();
  testing::write_u16_file(dir_ / "s.raw", testing::make_spectra(spec), true);
  const auto run = process(
      concat({(dir_ / "s.raw").string(), "--out", (dir_ / "v.nrrd").string(), "--bidirectional"},
             layout_args(spec)));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const Volume v = read_nrrd_file(dir_ / "v.nrrd").volume;
  EXPECT_EQ(brightest_depth(v, 0, 0), 30u);
  EXPECT_EQ(brightest_depth(v, 1, 0), 31u + spec.ascans - 1) << "recorded right to left";
}

TEST_F(ProcessCommand, FilterOptionAppliesTheVolumeFilters) {
  const SpectraSpec spec = tilted_spec();
  testing::write_u16_file(dir_ / "s.raw", testing::make_spectra(spec), true);
  ASSERT_EQ(process(concat({(dir_ / "s.raw").string(), "--out", (dir_ / "plain.nrrd").string()},
                           layout_args(spec)))
                .exit_code,
            0);
  const auto run = process(concat({(dir_ / "s.raw").string(), "--out", (dir_ / "f.nrrd").string(),
                                   "--filter", "median-gauss", "--sigma", "1.5"},
                                  layout_args(spec)));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  filters::VolumeFilterConfig config;
  config.gaussian_sigma = 1.5;
  Volume expected;
  filters::CpuVolumeFilter(config).filter_volume(read_nrrd_file(dir_ / "plain.nrrd").volume,
                                                 expected);
  const Volume got = read_nrrd_file(dir_ / "f.nrrd").volume;
  for (std::uint32_t z = 0; z < spec.bscans; ++z) {
    EXPECT_TRUE(std::ranges::equal(got.bscan(z), expected.bscan(z))) << "B-scan " << z;
  }
}

// Calibration c = {0, 0.85, 0.15}: the chain reads k-linear sample j at raw position
// (N-1)(0.85 t + 0.15 t^2). Spectra sampled that way show a smeared reflector unless resampled.
TEST_F(ProcessCommand, CalibrationResamplesNonLinearSpectra) {
  const std::vector<double> c{0.0, 0.85, 0.15};
  SpectraSpec spec;
  spec.samples = 512;
  spec.ascans = 8;
  spec.bscans = 4;
  spec.depth = [](std::uint32_t, std::uint32_t) { return 150.0; };
  spec.position = [&](std::uint32_t i) { return testing::inverse_calibration_position(c, 512, i); };
  testing::write_u16_file(dir_ / "s.raw", testing::make_spectra(spec), true);
  std::ofstream(dir_ / "cal.txt") << "# lambda -> k\n0 0.85\n0.15\n";
  const auto with =
      process(concat({(dir_ / "s.raw").string(), "--out", (dir_ / "cal.nrrd").string(),
                      "--calibration-file", (dir_ / "cal.txt").string()},
                     layout_args(spec)));
  ASSERT_EQ(with.exit_code, 0) << with.err;
  const auto without = process(concat(
      {(dir_ / "s.raw").string(), "--out", (dir_ / "raw.nrrd").string()}, layout_args(spec)));
  ASSERT_EQ(without.exit_code, 0) << without.err;
  const Volume sharp = read_nrrd_file(dir_ / "cal.nrrd").volume;
  const Volume smeared = read_nrrd_file(dir_ / "raw.nrrd").volume;
  for (std::uint32_t x = 0; x < spec.ascans; ++x) {
    EXPECT_NEAR(brightest_depth(sharp, 1, x), 150.0, 1.0) << x;
    EXPECT_GT(sharp.at(1, x, brightest_depth(sharp, 1, x)),
              smeared.at(1, x, brightest_depth(smeared, 1, x)) + 20)
        << "resampled, the reflector's energy is in one depth pixel; A-scan " << x;
  }
}

TEST_F(ProcessCommand, DimensionsThatDoNotMatchTheFileAreRefusedAndNothingIsWritten) {
  const SpectraSpec spec = tilted_spec();
  testing::write_u16_file(dir_ / "s.raw", testing::make_spectra(spec), true);
  fs::create_directory(dir_ / "out");
  auto args = layout_args(spec);
  args[5] = std::to_string(spec.bscans + 1);  // --bscans one too many
  const auto run =
      process(concat({(dir_ / "s.raw").string(), "--out", (dir_ / "out/v.nrrd").string(), "--png",
                      (dir_ / "out/v.png").string()},
                     args));
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("truncated or wrong dimensions"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("s.raw"), std::string::npos) << run.err;
  EXPECT_TRUE(fs::is_empty(dir_ / "out"));

  // A file cut short by a crash: the same refusal.
  auto bytes = testing::read_bytes(dir_ / "s.raw");
  bytes.resize(bytes.size() - 1000);
  testing::write_bytes(dir_ / "cut.raw", bytes);
  const auto cut = process(concat(
      {(dir_ / "cut.raw").string(), "--out", (dir_ / "out/v.nrrd").string()}, layout_args(spec)));
  EXPECT_EQ(cut.exit_code, 1);
  EXPECT_NE(cut.err.find("cut.raw: truncated"), std::string::npos) << cut.err;
  EXPECT_TRUE(fs::is_empty(dir_ / "out"));
}

// Options the chain refuses: exit 2, the option named, nothing written.
struct BadOption {
  std::string name;
  std::vector<std::string> args;
  std::string expected;
};

class ProcessOption : public ProcessCommand, public ::testing::WithParamInterface<BadOption> {};

TEST_P(ProcessOption, IsRefusedNamingIt) {
  const SpectraSpec spec = tilted_spec();
  testing::write_u16_file(dir_ / "s.raw", testing::make_spectra(spec), true);
  fs::create_directory(dir_ / "out");
  const auto run =
      process(concat(concat({(dir_ / "s.raw").string(), "--out", (dir_ / "out/v.nrrd").string()},
                            layout_args(spec)),
                     GetParam().args));
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_NE(run.err.find(GetParam().expected), std::string::npos) << run.err;
  EXPECT_TRUE(fs::is_empty(dir_ / "out"));
}

INSTANTIATE_TEST_SUITE_P(
    Options, ProcessOption,
    ::testing::Values(
        BadOption{"byte_order",
                  {"--byte-order", "middle"},
                  "byte_order = 'middle': must be little or big"},
        BadOption{"nan_calibration", {"--resample-poly", "0,nan"}, "resampling_coefficients"},
        BadOption{"non_monotonic_calibration",
                  {"--resample-poly", "0,3.3,-6.9,4.6"},
                  "resampling_coefficients"},
        BadOption{
            "calibration_outside_sweep", {"--resample-poly", "0,1.2"}, "resampling_coefficients"},
        BadOption{"resample_without_calibration", {"--resample", "cubic"}, "needs a calibration"},
        BadOption{
            "two_calibrations", {"--resample-poly", "0,1", "--calibration-file", "x"}, "not both"},
        BadOption{"filter", {"--filter", "bilateral"}, "filter = 'bilateral'"},
        BadOption{"sigma", {"--filter", "median-gauss", "--sigma", "0"}, "gaussian_sigma"},
        BadOption{"spacing", {"--spacing-mm", "1,2"}, "spacing_mm"},
        BadOption{"group_size", {"--bscans-per-group", "65"}, "bscans_per_group = 65"}),
    [](const auto& option) { return option.param.name; });

TEST_F(ProcessCommand, MissingInputFileIsABadInput) {
  const auto run = process({(dir_ / "none.raw").string(), "--out", (dir_ / "v.nrrd").string(),
                            "--samples", "64", "--ascans", "4", "--bscans", "2"});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("none.raw: cannot open"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(dir_ / "v.nrrd"));
}

class VolImportCommand : public ::testing::Test {
 protected:
  testing::ToolResult import(const std::vector<std::string>& args) {
    return testing::run_tool(IOCT_VOL_IMPORT_EXE, args, dir_.path());
  }
  ScratchDir dir_;
};

TEST_F(VolImportCommand, WritesVolumeLinesAndImagesOfTheSpectralisFile) {
  const fs::path input = testing::spectralis_vol_file();
  if (input.empty())
    FAIL() << "test data missing: spectralis_circle_valid.vol not found in " << IOCT_TEST_DATA_DIR;
  fs::create_directory(dir_ / "out");
  const auto run = import({input.string(), "--out", (dir_ / "out").string(), "--name", "circle"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("768 A-scans x 496 px"), std::string::npos) << run.out;
  EXPECT_EQ(run.err.find('\r'), std::string::npos) << "no progress bar when stderr is a file";

  const HeidelbergVol vol = read_heidelberg_vol(input);
  const NrrdVolume nrrd = read_nrrd_file(dir_ / "out/circle.nrrd");
  EXPECT_EQ(nrrd.volume.depth(), 496u);
  EXPECT_EQ(nrrd.volume.ascans(), 768u);
  EXPECT_EQ(nrrd.volume.bscans(), 1u);
  EXPECT_NEAR(nrrd.metadata.spacings[0] * 1000, 3.87, 0.005);
  EXPECT_EQ(nrrd.metadata.spacings[1], vol.header.ascan_spacing_mm);
  EXPECT_EQ(nrrd.metadata.unit, "mm");
  const Volume expected = to_volume(vol);
  EXPECT_TRUE(std::ranges::equal(nrrd.volume.bscan(0), expected.bscan(0)));

  const GrayImage bscan = read_png_gray8(dir_ / "out/circle_bscan.png");
  EXPECT_EQ(bscan.width, 768u);
  EXPECT_EQ(bscan.height, 496u);
  EXPECT_EQ(bscan.at(400, 300), expected.at(0, 400, 300)) << "A-scans across, depth down";
  const GrayImage slo = read_png_gray8(dir_ / "out/circle_slo.png");
  EXPECT_EQ(slo.width, vol.header.slo_width);
  EXPECT_EQ(slo.height, vol.header.slo_height);

  // The CSV holds the file's lines exactly (float -> shortest decimal -> the same float).
  std::istringstream csv(testing::read_text(dir_ / "out/circle_layers.csv"));
  std::string row;
  std::getline(csv, row);
  EXPECT_EQ(row, "bscan,ascan,ILM_px,BM_px,RNFL_px,ILM_um,BM_um,RNFL_um");
  std::uint32_t rows = 0;
  while (std::getline(csv, row)) {
    std::vector<std::string> cells;
    std::istringstream fields(row);
    for (std::string cell; std::getline(fields, cell, ',');) cells.push_back(cell);
    if (row.back() == ',') cells.emplace_back();
    ASSERT_EQ(cells.size(), 8u) << row;
    const std::uint32_t a = static_cast<std::uint32_t>(std::stoul(cells[1]));
    ASSERT_EQ(a, rows);
    for (int l = 0; l < 3; ++l) {
      const float line = vol.bscans[0].layers[l][a];
      if (std::isnan(line)) {
        EXPECT_EQ(cells[2 + l], "") << row;
      } else {
        EXPECT_EQ(std::stof(cells[2 + l]), line) << row;
      }
    }
    ++rows;
  }
  EXPECT_EQ(rows, 768u);
}

TEST_F(VolImportCommand, DamagedFilesAreRefusedAndLeaveNoOutput) {
  fs::create_directory(dir_ / "out");
  auto bytes = testing::make_vol_bytes(testing::VolSpec{});
  bytes.resize(bytes.size() - 17);
  testing::write_bytes(dir_ / "cut.vol", bytes);
  const auto cut = import({(dir_ / "cut.vol").string(), "--out", (dir_ / "out").string()});
  EXPECT_EQ(cut.exit_code, 1);
  EXPECT_NE(cut.err.find("cut.vol: truncated: B-scan 1 of 2 is cut"), std::string::npos) << cut.err;
  EXPECT_TRUE(fs::is_empty(dir_ / "out"));

  testing::write_bytes(dir_ / "text.vol", {'h', 'e', 'l', 'l', 'o'});
  const auto text = import({(dir_ / "text.vol").string(), "--out", (dir_ / "out").string()});
  EXPECT_EQ(text.exit_code, 1);
  EXPECT_NE(text.err.find("text.vol: neither a Heidelberg .vol (it does not start with HSF-OCT-) "
                          "nor a Bioptigen .OCT"),
            std::string::npos)
      << text.err;
  EXPECT_TRUE(fs::is_empty(dir_ / "out"));

  const auto bad_bscan =
      import({(dir_ / "cut.vol").string(), "--out", (dir_ / "nowhere").string()});
  EXPECT_NE(bad_bscan.exit_code, 0);
}

TEST_F(VolImportCommand, ASyntheticFileRoundTripsThroughItsOutputs) {
  fs::create_directory(dir_ / "out");
  testing::write_bytes(dir_ / "s.vol", testing::make_vol_bytes(testing::VolSpec{}));
  const auto run =
      import({(dir_ / "s.vol").string(), "--out", (dir_ / "out").string(), "--bscan", "1"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const NrrdVolume nrrd = read_nrrd_file(dir_ / "out/s.nrrd");
  EXPECT_EQ(nrrd.metadata.spacings, (std::array<double, 3>{0.0039, 0.0117, 0.12}));
  const GrayImage png = read_png_gray8(dir_ / "out/s_bscan.png");
  EXPECT_EQ(png.at(3, 2), nrrd.volume.at(1, 3, 2)) << "the B-scan asked for";
  const auto outside =
      import({(dir_ / "s.vol").string(), "--out", (dir_ / "out").string(), "--bscan", "2"});
  EXPECT_EQ(outside.exit_code, 2);
  EXPECT_NE(outside.err.find("invalid configuration: --bscan = 2: the file has 2 B-scans"),
            std::string::npos)
      << outside.err;
  const auto nowhere = import({(dir_ / "s.vol").string(), "--out", (dir_ / "nowhere").string()});
  EXPECT_EQ(nowhere.exit_code, 2) << "refused before anything was written";
  EXPECT_NE(nowhere.err.find("--out = "), std::string::npos) << nowhere.err;
  EXPECT_NE(nowhere.err.find("must be an existing directory"), std::string::npos) << nowhere.err;
}

// A Bioptigen .OCT, detected by its magic under any name: the NRRD holds the reader's averaged
// volume voxel for voxel with the file's spacings in mm, the PNG the B-scan asked for.
TEST_F(VolImportCommand, ImportsABioptigenFileWithItsGeometry) {
  fs::create_directory(dir_ / "out");
  testing::BioptigenSpec spec;
  spec.frames = 3;
  testing::write_bytes(dir_ / "infant.dat", testing::make_bioptigen_bytes(spec));
  const auto run = import({(dir_ / "infant.dat").string(), "--out", (dir_ / "out").string(),
                           "--name", "eye", "--bscan", "2"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("Bioptigen .OCT version 0x10a, rectangular volume scan, 3 B-scan "
                         "position(s) x 3 frame(s) of 12 A-scans x 40 px"),
            std::string::npos)
      << run.out;
  const BioptigenOct oct = read_bioptigen_oct(dir_ / "infant.dat");
  const BioptigenVolume expected = to_volume(oct);
  const NrrdVolume nrrd = read_nrrd_file(dir_ / "out/eye.nrrd");
  ASSERT_TRUE(nrrd.volume.same_shape(expected.volume));
  EXPECT_TRUE(std::ranges::equal(nrrd.volume.pixels(), expected.volume.pixels()));
  EXPECT_EQ(nrrd.metadata.unit, "mm");
  EXPECT_DOUBLE_EQ(nrrd.metadata.spacings[0], spec.scan_depth_mm / spec.depth);
  EXPECT_DOUBLE_EQ(nrrd.metadata.spacings[1], spec.az_scan_length_mm / spec.ascans);
  EXPECT_DOUBLE_EQ(nrrd.metadata.spacings[2], spec.el_scan_length_mm / spec.scans);
  const GrayImage png = read_png_gray8(dir_ / "out/eye_bscan.png");
  EXPECT_EQ(png.width, spec.ascans);
  EXPECT_EQ(png.height, spec.depth);
  EXPECT_EQ(png.at(5, 20), expected.volume.at(2, 5, 20)) << "A-scans across, depth down";
  EXPECT_FALSE(fs::exists(dir_ / "out/eye_layers.csv"));

  // One frame instead of the mean.
  const auto one = import({(dir_ / "infant.dat").string(), "--out", (dir_ / "out").string(),
                           "--name", "one", "--repeat", "1"});
  ASSERT_EQ(one.exit_code, 0) << one.err;
  EXPECT_TRUE(std::ranges::equal(read_nrrd_file(dir_ / "out/one.nrrd").volume.pixels(),
                                 to_volume(oct, std::uint32_t{1}).volume.pixels()));
}

TEST_F(VolImportCommand, BioptigenBadOptionsAndDamageLeaveNoOutput) {
  fs::create_directory(dir_ / "out");
  const testing::BioptigenSpec spec;
  auto bytes = testing::make_bioptigen_bytes(spec);
  testing::write_bytes(dir_ / "eye.OCT", bytes);
  const auto repeat =
      import({(dir_ / "eye.OCT").string(), "--out", (dir_ / "out").string(), "--repeat", "2"});
  EXPECT_EQ(repeat.exit_code, 2);
  EXPECT_NE(
      repeat.err.find("invalid configuration: --repeat = 2: the file has 2 frame(s) per position"),
      std::string::npos)
      << repeat.err;
  const auto bscan =
      import({(dir_ / "eye.OCT").string(), "--out", (dir_ / "out").string(), "--bscan", "3"});
  EXPECT_EQ(bscan.exit_code, 2);
  testing::write_bytes(dir_ / "s.vol", testing::make_vol_bytes(testing::VolSpec{}));
  const auto vol_repeat =
      import({(dir_ / "s.vol").string(), "--out", (dir_ / "out").string(), "--repeat", "0"});
  EXPECT_EQ(vol_repeat.exit_code, 2);
  EXPECT_NE(vol_repeat.err.find(
                "invalid configuration: --repeat = 0: applies to Bioptigen .OCT files only"),
            std::string::npos)
      << vol_repeat.err;

  bytes.resize(bytes.size() - 100);
  testing::write_bytes(dir_ / "cut.OCT", bytes);
  const auto cut = import({(dir_ / "cut.OCT").string(), "--out", (dir_ / "out").string()});
  EXPECT_EQ(cut.exit_code, 1);
  EXPECT_NE(cut.err.find("ioct-vol-import: bad input: " + (dir_ / "cut.OCT").string() +
                         ": truncated: frame 5: FRAMESAMPLES"),
            std::string::npos)
      << cut.err;
  EXPECT_TRUE(fs::is_empty(dir_ / "out"));
}

}  // namespace
}  // namespace ioct::gpu::offline
