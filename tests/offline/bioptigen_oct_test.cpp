// The Bioptigen .OCT reader: synthetic files written from the documented layout read back exactly
// (geometry, spacing, every sample; averaging and the u8 window), detection by magic whatever the
// extension, and every corruption refused naming the file, the field and its offset.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "bioptigen_test_file.hpp"
#include "ioct/gpu/offline/bioptigen_oct.hpp"
#include "ioct/gpu/offline/input_file_error.hpp"
#include "ioct/gpu/offline/input_format.hpp"
#include "ioct/gpu/offline/volume_file.hpp"
#include "offline_test_support.hpp"

namespace ioct::gpu::offline {
namespace {

using testing::BioptigenSpec;
using testing::ScratchDir;

void put_u32(std::vector<std::uint8_t>& b, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void put_f64(std::vector<std::uint8_t>& b, std::size_t at, double v) {
  std::memcpy(&b[at], &v, 8);
}

TEST(BioptigenOct, ReadsTheGeometryAndEverySampleOfASyntheticFile) {
  ScratchDir dir;
  const BioptigenSpec spec;
  testing::write_bytes(dir / "eye.OCT", testing::make_bioptigen_bytes(spec));
  const BioptigenOct oct = read_bioptigen_oct(dir / "eye.OCT");
  const BioptigenHeader& h = oct.header;
  EXPECT_EQ(h.version, 0x010A);
  EXPECT_EQ(h.frame_count, spec.scans * spec.frames);
  EXPECT_EQ(h.ascans, spec.ascans);
  EXPECT_EQ(h.depth, spec.depth);
  EXPECT_EQ(h.scan_type, 1u);
  EXPECT_EQ(h.sample_format, 2u);
  EXPECT_EQ(h.scans, spec.scans);
  EXPECT_EQ(h.frames_per_scan, spec.frames);
  EXPECT_FALSE(h.doppler);
  EXPECT_EQ(h.scan_depth_mm, spec.scan_depth_mm);
  EXPECT_EQ(h.az_scan_length_mm, spec.az_scan_length_mm);
  EXPECT_EQ(h.el_scan_length_mm, spec.el_scan_length_mm);
  EXPECT_EQ(h.description, "synthetic retina");
  EXPECT_EQ(oct.positions, spec.scans);
  EXPECT_EQ(oct.repeats, spec.frames);
  ASSERT_EQ(oct.samples.size(), std::size_t{h.frame_count} * spec.ascans * spec.depth);
  for (std::uint32_t f = 0; f < h.frame_count; ++f) {
    for (std::uint32_t a = 0; a < spec.ascans; ++a) {
      for (std::uint32_t s = 0; s < spec.depth; ++s) {
        ASSERT_EQ(oct.samples[(std::size_t{f} * spec.ascans + a) * spec.depth + s],
                  testing::bioptigen_sample(spec, f, a, s))
            << "frame " << f << " A-scan " << a << " sample " << s;
      }
    }
  }
  const BioptigenSpacingMm mm = spacing_mm(oct);
  EXPECT_DOUBLE_EQ(mm.depth, spec.scan_depth_mm / spec.depth);
  EXPECT_DOUBLE_EQ(mm.ascan, spec.az_scan_length_mm / spec.ascans);
  EXPECT_DOUBLE_EQ(mm.bscan, spec.el_scan_length_mm / spec.scans);
}

// The u8 volume: each position's frames averaged (rounded), then the window mapped to 0..255;
// the window is the 0.5th / 99.9th percentile of those means.
TEST(BioptigenOct, AveragesEachPositionsFramesAndMapsTheWindowToEightBits) {
  ScratchDir dir;
  BioptigenSpec spec;
  spec.frames = 3;
  testing::write_bytes(dir / "eye.OCT", testing::make_bioptigen_bytes(spec));
  const BioptigenOct oct = read_bioptigen_oct(dir / "eye.OCT");
  for (const bool averaged : {true, false}) {
    SCOPED_TRACE(averaged ? "mean of the frames" : "repeat 2 alone");
    const BioptigenVolume out = averaged ? to_volume(oct) : to_volume(oct, std::uint32_t{2});
    ASSERT_EQ(out.volume.bscans(), spec.scans);
    ASSERT_EQ(out.volume.ascans(), spec.ascans);
    ASSERT_EQ(out.volume.depth(), spec.depth);
    std::vector<std::uint16_t> means;
    for (std::uint32_t p = 0; p < spec.scans; ++p) {
      for (std::uint32_t a = 0; a < spec.ascans; ++a) {
        for (std::uint32_t s = 0; s < spec.depth; ++s) {
          std::uint32_t sum = 0;
          for (std::uint32_t r = averaged ? 0 : 2; r < (averaged ? spec.frames : 3); ++r) {
            sum += testing::bioptigen_sample(spec, r * spec.scans + p, a, s);
          }
          means.push_back(static_cast<std::uint16_t>(averaged ? (sum + 1) / 3 : sum));
        }
      }
    }
    std::vector<std::uint16_t> sorted = means;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_EQ(out.window_low, sorted[sorted.size() * 5 / 1000]);
    EXPECT_EQ(out.window_high, sorted[sorted.size() * 999 / 1000]);
    const double scale = 255.0 / (out.window_high - out.window_low);
    const auto voxels = out.volume.pixels();
    for (std::size_t i = 0; i < means.size(); ++i) {
      const double v =
          std::clamp((means[i] - static_cast<double>(out.window_low)) * scale, 0.0, 255.0);
      ASSERT_EQ(voxels[i], std::lround(v)) << "voxel " << i;
    }
    // The retina is where the writer put it: the first bright row of every A-scan is the ILM.
    for (std::uint32_t p = 0; p < spec.scans; ++p) {
      for (std::uint32_t a = 0; a < spec.ascans; ++a) {
        std::uint32_t first_bright = 0;
        while (out.volume.at(p, a, first_bright) < 100) ++first_bright;
        EXPECT_EQ(first_bright, testing::bioptigen_ilm_row(spec, p, a));
      }
    }
  }
  EXPECT_THROW(to_volume(oct, std::uint32_t{3}), std::out_of_range);
}

TEST(BioptigenOct, OlderKeysLinearScansAndDopplerFrames) {
  ScratchDir dir;
  {
    BioptigenSpec spec;  // FRAMESPERVOLUME only: one frame per position
    spec.scans_and_frames_keys = false;
    spec.frames = 1;
    testing::write_bytes(dir / "old.OCT", testing::make_bioptigen_bytes(spec));
    const BioptigenOct oct = read_bioptigen_oct(dir / "old.OCT");
    EXPECT_EQ(oct.positions, spec.scans);
    EXPECT_EQ(oct.repeats, 1u);
  }
  {
    BioptigenSpec spec;  // a linear scan repeats one line: every frame is a repeat
    spec.scan_type = 0;
    spec.scans = 4;
    spec.frames = 2;
    testing::write_bytes(dir / "line.OCT", testing::make_bioptigen_bytes(spec));
    const BioptigenOct oct = read_bioptigen_oct(dir / "line.OCT");
    EXPECT_EQ(oct.positions, 1u);
    EXPECT_EQ(oct.repeats, 8u);
    EXPECT_EQ(spacing_mm(oct).bscan, 0.0);
    EXPECT_DOUBLE_EQ(spacing_mm(oct).ascan, spec.scan_length_mm / spec.ascans);
    EXPECT_EQ(to_volume(oct).volume.bscans(), 1u);
  }
  {
    BioptigenSpec spec;  // Doppler samples are skipped, the intensity read as before
    spec.doppler = true;
    testing::write_bytes(dir / "doppler.OCT", testing::make_bioptigen_bytes(spec));
    const BioptigenOct oct = read_bioptigen_oct(dir / "doppler.OCT");
    EXPECT_TRUE(oct.header.doppler);
    EXPECT_EQ(oct.samples[5], testing::bioptigen_sample(spec, 0, 0, 5));
    EXPECT_EQ(oct.samples.back(), testing::bioptigen_sample(spec, spec.scans * spec.frames - 1,
                                                            spec.ascans - 1, spec.depth - 1));
  }
}

TEST(BioptigenOct, IsDetectedByItsMagicWhateverItsExtension) {
  ScratchDir dir;
  const BioptigenSpec spec;
  const auto bytes = testing::make_bioptigen_bytes(spec);
  testing::write_bytes(dir / "scan.vol", bytes);  // misnamed
  testing::write_bytes(dir / "scan.dat", bytes);
  testing::write_bytes(dir / "scan.oct", {'N', 'R', 'R', 'D', '0', '0', '0', '4'});
  testing::write_bytes(dir / "tiny", {0xA5, 0xA7});
  EXPECT_EQ(detect_input_format(dir / "scan.vol"), InputFormat::bioptigen_oct);
  EXPECT_EQ(detect_input_format(dir / "scan.dat"), InputFormat::bioptigen_oct);
  EXPECT_EQ(detect_input_format(dir / "scan.oct"), InputFormat::nrrd);
  EXPECT_EQ(detect_input_format(dir / "tiny"), InputFormat::unknown);
  // ioct-render and ioct-segment read it through read_volume_file, spacing in um.
  const VolumeFile file = read_volume_file(dir / "scan.dat");
  EXPECT_EQ(file.kind, "Bioptigen .OCT (rectangular volume)");
  EXPECT_EQ(file.volume.bscans(), spec.scans);
  ASSERT_TRUE(file.spacing.has_value());
  EXPECT_DOUBLE_EQ(file.spacing->axial_per_px, 1000.0 * spec.scan_depth_mm / spec.depth);
  EXPECT_DOUBLE_EQ(file.spacing->ascan, 1000.0 * spec.az_scan_length_mm / spec.ascans);
  EXPECT_DOUBLE_EQ(file.spacing->bscan, 1000.0 * spec.el_scan_length_mm / spec.scans);
}

struct Corruption {
  const char* name;
  std::function<void(std::vector<std::uint8_t>&)> apply;
  const char* message;  // a part of the refusal that names the field and what is wrong
};

TEST(BioptigenOct, RefusesEveryCorruptionNamingFileFieldAndOffset) {
  using B = std::vector<std::uint8_t>;
  using testing::bioptigen_field_data;
  const BioptigenSpec spec;
  const B good = testing::make_bioptigen_bytes(spec);
  const std::size_t frame_bytes = std::size_t{spec.ascans} * spec.depth * 2;
  const std::vector<Corruption> corruptions = {
      {"bad magic", [](B& b) { b[0] = 'X'; }, "not a Bioptigen .OCT file (magic number 0x0C7DA758"},
      {"empty file", [](B& b) { b.clear(); }, "truncated: magic number and version at offset 0"},
      {"cut in the header", [](B& b) { b.resize(30); }, "truncated: file header"},
      {"cut in the last frame", [](B& b) { b.resize(b.size() - 40); },
       "truncated: frame 5: FRAMESAMPLES"},
      {"frames missing", [&](B& b) { b.resize(b.size() - 3 * (frame_bytes + 120)); },
       "truncated: FRAMECOUNT 6"},
      {"first key not FRAMEHEADER", [](B& b) { b[10] = 'X'; }, "not FRAMEHEADER"},
      {"absurd FRAMECOUNT",
       [](B& b) { put_u32(b, bioptigen_field_data(b, "FRAMECOUNT"), 1000000000); },
       "FRAMECOUNT (offset 25) = 1000000000 is out of range [1, 1048576]"},
      {"frames the file cannot hold",
       [](B& b) {
         put_u32(b, bioptigen_field_data(b, "FRAMECOUNT"), 1u << 20);
         put_u32(b, bioptigen_field_data(b, "LINECOUNT"), 65536);
         put_u32(b, bioptigen_field_data(b, "LINELENGTH"), 65536);
         put_u32(b, bioptigen_field_data(b, "SCANS"), 65536);
         put_u32(b, bioptigen_field_data(b, "FRAMES"), 16);
       },
       "truncated: FRAMECOUNT 1048576 frames of 65536 x 65536 u16 need 9007199254740992 bytes"},
      {"more positions than a volume holds",
       [](B& b) { put_u32(b, bioptigen_field_data(b, "SCANS"), 65537); },
       "SCANS (offset 465) = 65537 is out of range [1, 65536]"},
      {"zero A-scans", [](B& b) { put_u32(b, bioptigen_field_data(b, "LINECOUNT"), 0); },
       "LINECOUNT (offset 47) = 0 is out of range [1, 65536]"},
      {"FRAMECOUNT not SCANS x FRAMES",
       [](B& b) { put_u32(b, bioptigen_field_data(b, "FRAMES"), 3); },
       "FRAMECOUNT (offset 25) = 6 is not SCANS (offset 465) 3 x FRAMES (offset 482) 3"},
      {"FRAMECOUNT of the wrong length",
       [](B& b) { put_u32(b, bioptigen_field_data(b, "FRAMECOUNT") - 4, 3); },
       "FRAMECOUNT (offset 25): data length 3 is not that of an integer"},
      {"mixed density", [](B& b) { put_u32(b, bioptigen_field_data(b, "SCANTYPE"), 6); },
       "SCANTYPE (offset"},
      {"unknown scan type", [](B& b) { put_u32(b, bioptigen_field_data(b, "SCANTYPE"), 9); },
       "= 9 is out of range [0, 6]"},
      {"NaN depth", [](B& b) { put_f64(b, bioptigen_field_data(b, "SCANDEPTH"), std::nan("")); },
       "SCANDEPTH (offset"},
      {"absurd key length",
       [](B& b) { put_u32(b, bioptigen_field_data(b, "SCANTYPE") - 16, 5000); },
       "key length 5000 at offset"},
      {"unprintable key", [](B& b) { b[bioptigen_field_data(b, "XMIN") - 6] = 0x07; },
       "is not printable text"},
      {"FRAMELINES differs",
       [&](B& b) { put_u32(b, bioptigen_field_data(b, "FRAMELINES"), spec.ascans + 1); },
       "frame 0: FRAMELINES (offset"},
      {"FRAMESAMPLES length differs",
       [](B& b) {
         const std::size_t at = bioptigen_field_data(b, "FRAMESAMPLES");
         put_u32(b, at - 4, 100);
       },
       "data length 100 is not LINECOUNT x LINELENGTH x 2 = 960"},
      {"frame without FRAMESAMPLES",
       [](B& b) { b[bioptigen_field_data(b, "FRAMESAMPLES") - 16] = 'Q'; },
       "frame 0 ends at offset"},
      {"frame marker missing",
       [](B& b) { b[bioptigen_field_data(b, "FRAMEDATA", 1000) - 6] = 'X'; },
       "expected FRAMEDATA at offset"},
      {"missing LINELENGTH", [](B& b) { b[bioptigen_field_data(b, "LINELENGTH") - 6] = 'X'; },
       "without LINELENGTH"},
      {"bytes after the last frame", [](B& b) { b.insert(b.end(), 7, 0); },
       "7 bytes after the last of FRAMECOUNT 6 frames"},
  };
  ScratchDir dir;
  for (const Corruption& c : corruptions) {
    SCOPED_TRACE(c.name);
    B bytes = good;
    c.apply(bytes);
    testing::write_bytes(dir / "bad.OCT", bytes);
    try {
      (void)read_bioptigen_oct(dir / "bad.OCT");
      ADD_FAILURE() << "accepted";
    } catch (const InputFileError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find((dir / "bad.OCT").string() + ": "), std::string::npos) << what;
      EXPECT_NE(what.find(c.message), std::string::npos) << what;
      for (const char ch : what) EXPECT_TRUE(ch >= 0x20 && ch < 0x7f) << what;
    }
  }
}

// The fuzz target's seeds (tests/fuzz/corpus/bioptigen_oct/) are this writer's files, small enough
// to mutate quickly: kept equal to it here. IOCT_WRITE_FUZZ_SEEDS=1 writes them afresh.
TEST(BioptigenOct, FuzzSeedsAreTheWritersFiles) {
  struct Seed {
    const char* name;
    BioptigenSpec spec;
  };
  std::vector<Seed> seeds(3);
  for (Seed& s : seeds) {
    s.spec.ascans = 4;
    s.spec.depth = 8;
    s.spec.scans = 2;
    s.spec.frames = 2;
    s.spec.description = "seed";
  }
  seeds[0].name = "volume-2x2-frames-4x8.OCT";
  seeds[1].name = "linear-doppler-4x8.OCT";
  seeds[1].spec.scan_type = 0;
  seeds[1].spec.doppler = true;
  seeds[2].name = "frames-per-volume-4x8.OCT";
  seeds[2].spec.scans_and_frames_keys = false;
  seeds[2].spec.frames = 1;
  const std::filesystem::path dir = std::filesystem::path(IOCT_FUZZ_CORPUS_DIR) / "bioptigen_oct";
  const char* write = std::getenv("IOCT_WRITE_FUZZ_SEEDS");
  for (const Seed& s : seeds) {
    SCOPED_TRACE(s.name);
    const auto bytes = testing::make_bioptigen_bytes(s.spec);
    if (write != nullptr && std::string(write) == "1") {
      std::filesystem::create_directories(dir);
      testing::write_bytes(dir / s.name, bytes);
    }
    ASSERT_TRUE(std::filesystem::exists(dir / s.name)) << "write it with IOCT_WRITE_FUZZ_SEEDS=1";
    EXPECT_EQ(testing::read_bytes(dir / s.name), bytes);
    const BioptigenOct oct = read_bioptigen_oct(dir / s.name);
    EXPECT_EQ(oct.samples.size(), std::size_t{s.spec.scans} * s.spec.frames * 4 * 8);
  }
}

}  // namespace
}  // namespace ioct::gpu::offline
