// The CPU chain on synthetic spectra: reflectors come out at their depth, the background and the
// noise floor come out dark, reversed lines are flipped, only active A-scans are processed.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <vector>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/processing/cpu_oct_processor.hpp"
#include "ioct/gpu/processing/group_check.hpp"
#include "synthetic_spectra.hpp"

namespace ioct::gpu {
namespace {

using testing::Reflector;

shm::RingGeometry small_geometry() {
  shm::RingGeometry g;
  g.samples_per_ascan = 512;
  g.ascans_per_bscan = 40;
  g.bscans_per_group = 4;
  g.bscans_per_volume = 8;
  return g;
}

OctProcessorConfig quick_config(std::uint32_t threads = 1) {
  OctProcessorConfig config;
  config.fft.rigor = FftRigor::estimate;
  config.threads = threads;
  return config;
}

shm::SlotHeader header_for(const shm::RingGeometry& g, std::uint32_t active_begin,
                           std::uint32_t active_end) {
  shm::SlotHeader h{};
  h.group_index = 7;
  h.payload_bytes = g.group_payload_bytes();
  h.bscan_count = g.bscans_per_group;
  h.active_ascan_begin = active_begin;
  h.active_ascan_end = active_end;
  for (std::uint32_t b = 0; b < g.bscans_per_group; ++b) {
    h.bscans[b] = testing::marker_for(0, b, g.bscans_per_volume, false);
  }
  return h;
}

std::uint32_t brightest_depth(std::span<const std::uint8_t> ascan) {
  return static_cast<std::uint32_t>(std::ranges::max_element(ascan) - ascan.begin());
}

struct Fixture {
  explicit Fixture(shm::RingGeometry g = small_geometry(), double noise_sigma = 2.0)
      : geometry(g),
        payload(g.group_payload_bytes() / 2),
        synthesizer(
            testing::SpectrumModel{.samples = g.samples_per_ascan, .noise_sigma = noise_sigma},
            1234) {}
  shm::RingGeometry geometry;
  std::vector<std::uint16_t> payload;
  testing::SpectrumSynthesizer synthesizer;
};

TEST(CpuOctProcessor, ReflectorAppearsAtItsDepthAndNoiseFloorIsDark) {
  // The default sweep of 1376 samples and 4 counts of noise, as a 12-bit balanced detector
  // delivers at mid-scale.
  shm::RingGeometry g = small_geometry();
  g.samples_per_ascan = 1376;
  Fixture f(g, 4.0);
  const std::uint32_t depths[] = {37, 300, 501, 660};  // one per B-scan
  testing::fill_group(
      f.geometry, f.synthesizer,
      [&](std::uint32_t b, std::uint32_t) {
        return std::vector<Reflector>{{static_cast<double>(depths[b]), 30.0}};
      },
      f.payload);
  const shm::SlotHeader header = header_for(f.geometry, 0, f.geometry.ascans_per_bscan);

  CpuOctProcessor processor(quick_config());
  processor.prepare(f.geometry);
  ProcessedGroup out;
  processor.process(RawGroup{header, f.payload}, out);

  ASSERT_EQ(out.bscan_count, 4u);
  ASSERT_EQ(out.ascans, 40u);
  ASSERT_EQ(out.depth, 688u);
  std::size_t far_pixels = 0;
  std::size_t far_lit = 0;
  std::size_t dc_lit = 0;
  for (std::uint32_t b = 0; b < out.bscan_count; ++b) {
    for (std::uint32_t a = 0; a < out.ascans; ++a) {
      const auto ascan = out.bscan(b).subspan(std::size_t{a} * out.depth, out.depth);
      const std::uint32_t peak = brightest_depth(ascan);
      EXPECT_NEAR(static_cast<double>(peak), depths[b], 1.0) << "B-scan " << b << " A-scan " << a;
      // 30 counts at the envelope's peak, about 22 counts seen through window and envelope:
      // 27 dB, i.e. 27 / 40 of full scale at the default range.
      EXPECT_GE(ascan[peak], 150) << "B-scan " << b << " A-scan " << a;
      for (std::uint32_t d = 1; d < out.depth; ++d) {
        // Skip the main lobes and near side lobes of every reflector of the group: with only 160
        // A-scans the group's mean keeps 1/sqrt(160) of each fringe, a faint ghost 22 dB below
        // it in every A-scan (at the default 8192 A-scans per group it is 39 dB below).
        if (std::ranges::any_of(depths,
                                [&](std::uint32_t r) { return d + 12 > r && d < r + 12; })) {
          continue;
        }
        ++far_pixels;
        if (ascan[d] > 0) ++far_lit;
      }
      if (ascan[0] > 0) ++dc_lit;
    }
  }
  // White noise of 4 counts sits near -12 dB, well below db_min = 0 dB; only a rare speckle
  // peak of it shows.
  EXPECT_LT(static_cast<double>(far_lit) / static_cast<double>(far_pixels), 0.001);
  // The background (DC and source spectrum) is removed: the zero-delay pixel is dark.
  EXPECT_LE(dc_lit, 3u);
}

TEST(CpuOctProcessor, WithoutBackgroundRemovalTheDcSaturates) {
  Fixture f;
  testing::fill_group(
      f.geometry, f.synthesizer,
      [](std::uint32_t, std::uint32_t) {
        return std::vector<Reflector>{{60.0, 30.0}};
      },
      f.payload);
  const shm::SlotHeader header = header_for(f.geometry, 0, f.geometry.ascans_per_bscan);
  OctProcessorConfig config = quick_config();
  config.background.mode = BackgroundMode::none;
  CpuOctProcessor processor(config);
  processor.prepare(f.geometry);
  ProcessedGroup out;
  processor.process(RawGroup{header, f.payload}, out);
  EXPECT_EQ(out.bscan(0)[0], 255);
  EXPECT_EQ(processor.last_background()[100], 0.0f);
}

TEST(CpuOctProcessor, GroupMeanBackgroundIsTheMeanSpectrum) {
  Fixture f;
  testing::fill_group(
      f.geometry, f.synthesizer,
      [](std::uint32_t, std::uint32_t) { return std::vector<Reflector>{}; }, f.payload);
  const shm::SlotHeader header = header_for(f.geometry, 0, f.geometry.ascans_per_bscan);
  CpuOctProcessor processor(quick_config());
  processor.prepare(f.geometry);
  ProcessedGroup out;
  processor.process(RawGroup{header, f.payload}, out);
  const std::size_t samples = f.geometry.samples_per_ascan;
  const std::size_t spectra = f.payload.size() / samples;
  for (std::size_t s : {std::size_t{0}, samples / 2, samples - 1}) {
    double sum = 0.0;
    for (std::size_t i = 0; i < spectra; ++i) sum += f.payload[i * samples + s];
    EXPECT_NEAR(processor.last_background()[s], sum / static_cast<double>(spectra), 1e-3);
  }
}

TEST(CpuOctProcessor, ReversedLinesAreFlippedAndOnlyActiveAscansAreProcessed) {
  Fixture f;
  const std::uint32_t begin = 3;
  const std::uint32_t end = 35;
  // Record r of every B-scan: a reflector at depth 20 + r. Records outside the active range
  // carry a strong reflector elsewhere that must not show up.
  testing::fill_group(
      f.geometry, f.synthesizer,
      [&](std::uint32_t, std::uint32_t r) {
        if (r < begin || r >= end) return std::vector<Reflector>{{200.0, 400.0}};
        return std::vector<Reflector>{{20.0 + (r - begin) * 2.0, 30.0}};
      },
      f.payload);
  shm::SlotHeader header = header_for(f.geometry, begin, end);
  header.bscans[1].flags |= shm::kBscanReversed;
  header.bscans[3].flags |= shm::kBscanReversed;

  CpuOctProcessor processor(quick_config());
  processor.prepare(f.geometry);
  ProcessedGroup out;
  processor.process(RawGroup{header, f.payload}, out);

  const std::uint32_t width = end - begin;
  ASSERT_EQ(out.ascans, width);
  for (std::uint32_t b = 0; b < out.bscan_count; ++b) {
    const bool reversed = b % 2 == 1;
    for (std::uint32_t column = 0; column < width; ++column) {
      const std::uint32_t record = reversed ? width - 1 - column : column;
      const auto ascan = out.bscan(b).subspan(std::size_t{column} * out.depth, out.depth);
      EXPECT_NEAR(static_cast<double>(brightest_depth(ascan)), 20.0 + record * 2.0, 1.0)
          << "B-scan " << b << " column " << column;
      EXPECT_LT(ascan[200], 50) << "an inactive record leaked into B-scan " << b;
    }
  }
}

TEST(CpuOctProcessor, TwoThreadsGiveTheSamePixelsAsOne) {
  Fixture f;
  testing::fill_group(
      f.geometry, f.synthesizer,
      [](std::uint32_t b, std::uint32_t r) {
        return std::vector<Reflector>{{30.0 + b * 10 + r, 20.0}, {180.0, 8.0}};
      },
      f.payload);
  const shm::SlotHeader header = header_for(f.geometry, 1, 39);
  CpuOctProcessor one(quick_config(1));
  CpuOctProcessor two(quick_config(2));
  one.prepare(f.geometry);
  two.prepare(f.geometry);
  ProcessedGroup a;
  ProcessedGroup b;
  one.process(RawGroup{header, f.payload}, a);
  two.process(RawGroup{header, f.payload}, b);
  EXPECT_EQ(a.pixels, b.pixels);
}

// The assistant's dB range: a processor told a new range between groups gives the pixels of one
// made with that range, and a bad range is refused (naming the key) with the old one kept.
TEST(CpuOctProcessor, ANewDbRangeEqualsAProcessorMadeWithIt) {
  Fixture f;
  testing::fill_group(
      f.geometry, f.synthesizer,
      [](std::uint32_t, std::uint32_t r) {
        return std::vector<Reflector>{{40.0 + r, 30.0}, {150.0, 5.0}};
      },
      f.payload);
  const shm::SlotHeader header = header_for(f.geometry, 0, 40);
  OctProcessorConfig narrow_config = quick_config();
  narrow_config.scale = {5.0, 25.0};
  CpuOctProcessor narrow(narrow_config);
  CpuOctProcessor changed(quick_config());
  narrow.prepare(f.geometry);
  changed.prepare(f.geometry);
  // Both see the same groups (the rolling background remembers them); `changed` gets the new
  // range after the first.
  ProcessedGroup expected, before, after;
  narrow.process(RawGroup{header, f.payload}, expected);
  changed.process(RawGroup{header, f.payload}, before);
  EXPECT_NE(before.pixels, expected.pixels);
  changed.set_db_range({5.0, 25.0});
  narrow.process(RawGroup{header, f.payload}, expected);
  changed.process(RawGroup{header, f.payload}, after);
  EXPECT_EQ(after.pixels, expected.pixels);
  try {
    changed.set_db_range({30.0, 30.5});
    FAIL() << "accepted a range under 1 dB";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("db_max"), std::string::npos) << e.what();
  }
  ProcessedGroup again;
  narrow.process(RawGroup{header, f.payload}, expected);
  changed.process(RawGroup{header, f.payload}, again);
  EXPECT_EQ(again.pixels, expected.pixels);
}

TEST(CpuOctProcessor, RejectsAHeaderThatDoesNotFitTheGeometry) {
  Fixture f;
  CpuOctProcessor processor(quick_config());
  ProcessedGroup out;
  shm::SlotHeader header = header_for(f.geometry, 0, f.geometry.ascans_per_bscan + 1);
  EXPECT_THROW(processor.process(RawGroup{header, f.payload}, out), std::logic_error);
  processor.prepare(f.geometry);
  try {
    processor.process(RawGroup{header, f.payload}, out);
    FAIL() << "an active range past the records was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("active A-scans"), std::string::npos) << e.what();
  }
  header = header_for(f.geometry, 0, 10);
  header.bscans[2].bscan_in_volume = f.geometry.bscans_per_volume;
  EXPECT_THROW(processor.process(RawGroup{header, f.payload}, out), std::invalid_argument);
  header = header_for(f.geometry, 0, 10);
  header.bscan_count = f.geometry.bscans_per_group + 1;
  EXPECT_THROW(processor.process(RawGroup{header, f.payload}, out), std::invalid_argument);
}

TEST(CpuOctProcessor, RefusesAGeometryItCannotProcess) {
  shm::RingGeometry g = small_geometry();
  g.bytes_per_sample = 4;
  CpuOctProcessor processor(quick_config());
  EXPECT_THROW(processor.prepare(g), std::invalid_argument);
  g = small_geometry();
  g.samples_per_ascan = 511;
  EXPECT_THROW(processor.prepare(g), std::invalid_argument);
}

TEST(CpuOctProcessor, KeepsFftWisdomInAFileAndRejectsAFileThatIsNotWisdom) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("ioct-gpu-wisdom-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  OctProcessorConfig config = quick_config();
  config.fft.wisdom_path = (dir / "fftw.wisdom").string();
  {
    CpuOctProcessor processor(config);
    processor.prepare(small_geometry());
  }
  const std::string wisdom = [&] {
    std::ifstream in(config.fft.wisdom_path);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }();
  EXPECT_NE(wisdom.find("fftw"), std::string::npos) << wisdom;
  CpuOctProcessor again(config);
  EXPECT_NO_THROW(again.prepare(small_geometry()));  // reads it back

  std::ofstream(dir / "garbage.wisdom") << "not wisdom";
  config.fft.wisdom_path = (dir / "garbage.wisdom").string();
  CpuOctProcessor refused(config);
  try {
    refused.prepare(small_geometry());
    ADD_FAILURE() << "a garbage wisdom file was accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "fft_wisdom");
    EXPECT_NE(std::string(e.what()).find("garbage.wisdom"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace ioct::gpu
