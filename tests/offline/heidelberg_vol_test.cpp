// The .vol reader: synthetic files written from the documented layout (every field checked, every
// corruption refused with its reason), and the real Spectralis export of the design brief (its
// stated geometry, and segmentation lines that sit on the image's edges).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "ioct/gpu/offline/heidelberg_vol.hpp"
#include "ioct/gpu/offline/input_file_error.hpp"
#include "ioct/gpu/offline/layer_csv.hpp"
#include "offline_test_support.hpp"

namespace ioct::gpu::offline {
namespace {

using testing::ScratchDir;
using testing::VolSpec;

TEST(HeidelbergVol, ReadsEveryFieldOfASyntheticFile) {
  ScratchDir dir;
  const VolSpec spec;
  testing::write_bytes(dir / "a.vol", testing::make_vol_bytes(spec));
  const HeidelbergVol vol = read_heidelberg_vol(dir / "a.vol");
  const VolHeader& h = vol.header;
  EXPECT_EQ(h.version, "HSF-OCT-103");
  EXPECT_EQ(h.ascans, spec.ascans);
  EXPECT_EQ(h.depth, spec.depth);
  EXPECT_EQ(h.bscans, spec.bscans);
  EXPECT_EQ(h.ascan_spacing_mm, spec.scale_x);
  EXPECT_EQ(h.bscan_distance_mm, spec.distance);
  EXPECT_EQ(h.depth_spacing_mm, spec.scale_y);
  EXPECT_EQ(h.slo_width, spec.slo_width);
  EXPECT_EQ(h.slo_height, spec.slo_height);
  EXPECT_EQ(h.scan_pattern, spec.scan_pattern);
  EXPECT_EQ(h.scan_position, "OS");
  ASSERT_EQ(vol.slo.size(), std::size_t{spec.slo_width} * spec.slo_height);
  EXPECT_EQ(vol.slo[5], 55);
  ASSERT_EQ(vol.bscans.size(), spec.bscans);
  for (std::uint32_t b = 0; b < spec.bscans; ++b) {
    const VolBscan& bscan = vol.bscans[b];
    EXPECT_EQ(bscan.start_x_mm, -1.5 + b);
    EXPECT_EQ(bscan.end_x_mm, 1.5 + b);
    EXPECT_EQ(bscan.quality, 30.5f);
    EXPECT_EQ(bscan.shift, -3);
    ASSERT_EQ(bscan.layers.size(), spec.lines);
    for (std::uint32_t l = 0; l < spec.lines; ++l) {
      for (std::uint32_t x = 0; x < spec.ascans; ++x) {
        const float stored = testing::vol_line(b, l, x);
        if (stored > 3e38f) {
          EXPECT_TRUE(std::isnan(bscan.layers[l][x])) << "no line: NaN";
        } else {
          EXPECT_EQ(bscan.layers[l][x], stored);
        }
      }
    }
  }
  EXPECT_EQ(layer_name(0), "ILM");
  EXPECT_EQ(layer_name(1), "BM");
  EXPECT_EQ(layer_name(2), "RNFL");
  EXPECT_EQ(layer_name(5), "line5");
}

TEST(HeidelbergVol, VolumeIsTheFourthRootOfIntensityWithAscansAcrossAndDepthDown) {
  ScratchDir dir;
  const VolSpec spec;
  testing::write_bytes(dir / "a.vol", testing::make_vol_bytes(spec));
  const Volume volume = to_volume(read_heidelberg_vol(dir / "a.vol"));
  ASSERT_EQ(volume.bscans(), spec.bscans);
  ASSERT_EQ(volume.ascans(), spec.ascans);
  ASSERT_EQ(volume.depth(), spec.depth);
  for (std::uint32_t b = 0; b < spec.bscans; ++b) {
    for (std::uint32_t y = 0; y < spec.depth; ++y) {
      for (std::uint32_t x = 0; x < spec.ascans; ++x) {
        const float v = testing::vol_intensity(b, y, x);
        const int expected = v > 3e38f ? 0 : static_cast<int>(std::lround(255 * std::pow(v, 0.25)));
        ASSERT_EQ(volume.at(b, x, y), expected) << b << ", row " << y << ", A-scan " << x;
      }
    }
  }
}

TEST(HeidelbergVol, LayerCsvHasOneRowPerAscanAndEmptyCellsWhereNoLine) {
  ScratchDir dir;
  const VolSpec spec;
  testing::write_bytes(dir / "a.vol", testing::make_vol_bytes(spec));
  const HeidelbergVol vol = read_heidelberg_vol(dir / "a.vol");
  std::FILE* file = std::fopen((dir / "l.csv").c_str(), "w");
  write_layer_csv(file, vol);
  std::fclose(file);
  const std::string text = testing::read_text(dir / "l.csv");
  EXPECT_EQ(text.substr(0, text.find('\n')),
            "bscan,ascan,ILM_px,BM_px,RNFL_px,ILM_um,BM_um,RNFL_um");
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1 + spec.bscans * spec.ascans);
  // Every row: B-scan, A-scan, the lines in px as stored (empty where none), then in um.
  std::istringstream rows(text);
  std::string row;
  std::getline(rows, row);
  for (std::uint32_t b = 0; b < spec.bscans; ++b) {
    for (std::uint32_t x = 0; x < spec.ascans; ++x) {
      ASSERT_TRUE(std::getline(rows, row));
      std::vector<std::string> cells;
      std::istringstream fields(row);
      for (std::string cell; std::getline(fields, cell, ',');) cells.push_back(cell);
      if (row.back() == ',') cells.emplace_back();
      ASSERT_EQ(cells.size(), 8u) << row;
      EXPECT_EQ(cells[0], std::to_string(b));
      EXPECT_EQ(cells[1], std::to_string(x));
      for (std::uint32_t l = 0; l < 3; ++l) {
        const float stored = testing::vol_line(b, l, x);
        if (stored > 3e38f) {
          EXPECT_EQ(cells[2 + l], "") << row;
          EXPECT_EQ(cells[5 + l], "") << row;
        } else {
          EXPECT_EQ(std::stod(cells[2 + l]), stored) << row;
          EXPECT_NEAR(std::stod(cells[5 + l]), stored * spec.scale_y * 1000, 1e-9) << row;
        }
      }
    }
  }
}

struct Corruption {
  std::string name;
  std::function<void(std::vector<std::uint8_t>&)> apply;
  std::string expected;
};

void put_u32(std::vector<std::uint8_t>& bytes, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) bytes[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

const std::size_t kFirstBscan = 2048 + 4 * 3;  // after the file header and the 4 x 3 SLO

class VolCorruption : public ::testing::TestWithParam<Corruption> {};

TEST_P(VolCorruption, IsRefusedWithItsReason) {
  ScratchDir dir;
  std::vector<std::uint8_t> bytes = testing::make_vol_bytes(VolSpec{});
  GetParam().apply(bytes);
  testing::write_bytes(dir / "bad.vol", bytes);
  try {
    read_heidelberg_vol(dir / "bad.vol");
    FAIL() << "accepted " << GetParam().name;
  } catch (const InputFileError& e) {
    EXPECT_NE(std::string(e.what()).find(GetParam().expected), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad.vol"), std::string::npos);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Files, VolCorruption,
    ::testing::Values(
        Corruption{"magic", [](auto& b) { b[0] = 'X'; }, "not a Heidelberg .vol file"},
        Corruption{"version", [](auto& b) { b[8] = '2'; }, "version 'HSF-OCT-203'"},
        Corruption{"short header", [](auto& b) { b.resize(100); }, "shorter than the 2048-byte"},
        Corruption{"cut in the SLO", [](auto& b) { b.resize(2050); }, "the SLO image is cut"},
        Corruption{"cut last bscan", [](auto& b) { b.pop_back(); },
                   "truncated: B-scan 1 of 2 is cut"},
        Corruption{"extra bytes", [](auto& b) { b.push_back(0); }, "1 bytes after the last B-scan"},
        Corruption{"zero width", [](auto& b) { put_u32(b, 12, 0); },
                   "size_x (A-scans per B-scan) = 0"},
        Corruption{"scale nan",
                   [](auto& b) {
                     const double nan = std::nan("");
                     std::memcpy(&b[40], &nan, 8);
                   },
                   "scale_y (axial spacing) = nan"},
        Corruption{"bscan magic", [](auto& b) { b[kFirstBscan] = 'X'; },
                   "B-scan 0: its header does not start with HSF-BS-"},
        Corruption{"bscan header size", [](auto& b) { put_u32(b, kFirstBscan + 12, 999); },
                   "B-scan 0: header size 999 differs"},
        Corruption{"too many lines", [](auto& b) { put_u32(b, kFirstBscan + 48, 9); },
                   "B-scan 0: 9 segmentation lines of 8 values at offset 256 do not fit"}),
    [](const auto& c) {
      std::string name = c.param.name;
      for (char& ch : name) {
        if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
      }
      return name;
    });

// The real export of the design brief: a Spectralis circle B-scan, 768 x 496, 3.87 um/px.
class SpectralisFile : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = testing::spectralis_vol_file();
    if (path_.empty())
      FAIL() << "test data missing: spectralis_circle_valid.vol not found in "
             << IOCT_TEST_DATA_DIR << " (it is part of the repository)";
  }
  std::filesystem::path path_;
};

TEST_F(SpectralisFile, HasTheStatedGeometry) {
  const HeidelbergVol vol = read_heidelberg_vol(path_);
  EXPECT_EQ(vol.header.ascans, 768u);
  EXPECT_EQ(vol.header.depth, 496u);
  EXPECT_EQ(vol.header.bscans, 1u);
  EXPECT_NEAR(vol.header.depth_spacing_mm * 1000, 3.87, 0.005);
  EXPECT_EQ(scan_pattern_name(vol.header.scan_pattern), "circle");
  const Volume volume = to_volume(vol);
  EXPECT_EQ(volume.ascans(), 768u);
  EXPECT_EQ(volume.depth(), 496u);
}

TEST_F(SpectralisFile, LinesAreIlmAboveBmAndSitOnTheImagesEdges) {
  const HeidelbergVol vol = read_heidelberg_vol(path_);
  const Volume volume = to_volume(vol);
  const VolBscan& bscan = vol.bscans.at(0);
  ASSERT_GE(bscan.layers.size(), 3u) << "ILM, BM and RNFL";
  const auto& ilm = bscan.layers[0];
  const auto& bm = bscan.layers[1];
  const auto& rnfl = bscan.layers[2];
  const double um = vol.header.depth_spacing_mm * 1000;
  int both = 0, edges = 0;
  double contrast = 0;
  // The middle half of the circle: the brief says the device's lines are unreliable where the
  // tissue folds out of the image near both ends.
  for (std::uint32_t a = 192; a < 576; ++a) {
    if (std::isnan(ilm[a]) || std::isnan(bm[a])) continue;
    ++both;
    EXPECT_GT(bm[a], ilm[a]) << "A-scan " << a << ": Bruch's membrane lies below the ILM";
    EXPECT_GT((bm[a] - ilm[a]) * um, 50) << a;
    EXPECT_LT((bm[a] - ilm[a]) * um, 800) << a;
    if (!std::isnan(rnfl[a])) {
      EXPECT_GE(rnfl[a], ilm[a] - 0.01f) << a;
      EXPECT_LE(rnfl[a], bm[a]) << a;
    }
    // Mean brightness just above and just below the ILM (vitreous: dark; retina: bright).
    const int row = static_cast<int>(std::lround(ilm[a]));
    if (row < 8 || row + 8 >= 496) continue;
    double above = 0, below = 0;
    for (int k = 3; k < 8; ++k) {
      above += volume.at(0, a, static_cast<std::uint32_t>(row - k));
      below += volume.at(0, a, static_cast<std::uint32_t>(row + k));
    }
    contrast += (below - above) / 5;
    ++edges;
  }
  ASSERT_GT(both, 300) << "ILM and BM drawn over most of the middle of the circle";
  ASSERT_GT(edges, 300);
  EXPECT_GT(contrast / edges, 25) << "the ILM line sits where the image turns from dark to bright";
}

}  // namespace
}  // namespace ioct::gpu::offline
