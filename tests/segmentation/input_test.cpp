// What the segmentation does with input that is not a retina or not a volume it can handle:
// clear results (every B-scan no_retina, surfaces NaN) or clear errors, never silent garbage.
// Also the config's validation, the group bookkeeping and the CSV and overlay outputs.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/filters/volume_filter.hpp"
#include "ioct/gpu/segmentation/overlay_image.hpp"
#include "ioct/gpu/segmentation/segmenter.hpp"
#include "ioct/gpu/segmentation/surfaces_csv.hpp"
#include "simulated_volume.hpp"

namespace ioct::gpu::segmentation {
namespace {

std::unique_ptr<Segmenter> cpu_segmenter(SegmentationConfig config = {}) {
  return make_segmenter(Backend::cpu, config, {}, 1);
}

Volume filled(std::uint32_t bscans, std::uint32_t ascans, std::uint32_t depth, std::uint8_t value) {
  Volume v(bscans, ascans, depth);
  std::fill(v.pixels().begin(), v.pixels().end(), value);
  return v;
}

void expect_no_retina(const Surfaces& s, std::uint32_t bscans, std::uint32_t ascans) {
  ASSERT_EQ(s.bscans, bscans);
  ASSERT_EQ(s.ascans, ascans);
  for (std::uint32_t b = 0; b < bscans; ++b) EXPECT_EQ(s.verdict[b], BscanVerdict::no_retina);
  for (std::size_t k = 0; k < s.size(); ++k) {
    ASSERT_EQ(s.state[k], SurfaceState::none);
    ASSERT_TRUE(std::isnan(s.ilm[k]) && std::isnan(s.rpe[k]) && std::isnan(s.bm[k]));
  }
}

TEST(Input, AllBlackVolumeHasNoRetina) {
  Surfaces s;
  cpu_segmenter()->segment_volume(filled(3, 64, 128, 0), s);
  expect_no_retina(s, 3, 64);
}

TEST(Input, SaturatedVolumeHasNoRetina) {
  Surfaces s;
  cpu_segmenter()->segment_volume(filled(3, 64, 128, 255), s);
  expect_no_retina(s, 3, 64);
}

TEST(Input, FilteredNoiseHasNoRetina) {
  // A noisy detector and nothing in front of it: speckle-like noise, median and Gaussian filtered.
  std::mt19937 rng(11);
  std::exponential_distribution<double> speckle(1.0 / 25.0);
  Volume noise(8, 128, 256);
  for (std::uint8_t& v : noise.pixels()) {
    v = static_cast<std::uint8_t>(std::min(255.0, speckle(rng)));
  }
  Volume filtered_noise;
  filters::make_volume_filter(Backend::cpu, {}, 1)->filter_volume(noise, filtered_noise);
  Surfaces s;
  cpu_segmenter()->segment_volume(filtered_noise, s);
  expect_no_retina(s, 8, 128);
}

TEST(Input, EmptyVolumeGivesEmptySurfaces) {
  Surfaces s;
  s.reset(2, 3, 64);
  cpu_segmenter()->segment_volume(Volume{}, s);
  EXPECT_EQ(s.bscans, 0u);
  EXPECT_EQ(s.size(), 0u);
}

TEST(Input, VolumesTheSearchCannotHandleAreRefusedNamingTheirDimensions) {
  Surfaces s;
  const auto segmenter = cpu_segmenter();
  const auto message_of = [&](const Volume& v) {
    try {
      segmenter->segment_volume(v, s);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message_of(filled(2, 16, 16, 0)).find("2 x 16 x 16"), std::string::npos);
  EXPECT_NE(message_of(filled(2, 0, 64, 0)).find("2 x 0 x 64"), std::string::npos);
  EXPECT_NE(message_of(filled(1, 8, kMaxDepth + 1, 0)).find("depth in [32, 2048]"),
            std::string::npos);
}

TEST(Input, GroupsOutsideTheVolumeAreRefused) {
  Surfaces s;
  const auto segmenter = cpu_segmenter();
  const Volume v = filled(4, 32, 64, 0);
  EXPECT_THROW(segmenter->segment_group(v, {0, 0}, s), std::out_of_range);
  EXPECT_THROW(segmenter->segment_group(v, {3, 2}, s), std::out_of_range);
  EXPECT_THROW(segmenter->segment_group(v, {4, 1}, s), std::out_of_range);
  EXPECT_NO_THROW(segmenter->segment_group(v, {3, 1}, s));
}

TEST(Input, SamplingThatMakesTheSearchTooLargeIsRefusedNamingTheSetting) {
  VolumeSampling fine;
  fine.axial_um_per_px = 1.0;  // 700 um of retina would be 700 px: more than the search's 256
  try {
    make_params(SegmentationConfig{}, fine, 2048, 512);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("retina_max_thickness_um"), std::string::npos) << e.what();
  }
  VolumeSampling sparse;
  sparse.ascan_spacing_um = 200.0;  // a 1.2 slope over 200 um is 43 px per A-scan
  EXPECT_THROW(make_params(SegmentationConfig{}, sparse, 688, 512), std::invalid_argument);
}

TEST(Config, BadValuesAreRefusedNamingTheKey) {
  const auto key_of = [](auto change) {
    SegmentationConfig c;
    change(c);
    try {
      c.validate();
    } catch (const ConfigError& e) {
      return e.key();
    }
    return std::string("no error");
  };
  EXPECT_EQ(key_of([](SegmentationConfig& c) { c.max_slope = 0.0; }), "segmentation.max_slope");
  EXPECT_EQ(key_of([](SegmentationConfig& c) { c.ilm_level = 1.5; }), "segmentation.ilm_level");
  EXPECT_EQ(key_of([](SegmentationConfig& c) { c.retina_max_thickness_um = NAN; }),
            "segmentation.retina_max_thickness_um");
  EXPECT_EQ(key_of([](SegmentationConfig& c) { c.min_contrast = 0; }), "segmentation.min_contrast");
  EXPECT_EQ(key_of([](SegmentationConfig& c) { c.bridge_bscans = 65; }),
            "segmentation.bridge_bscans");
  EXPECT_EQ(key_of([](SegmentationConfig&) {}), "no error");
  VolumeSampling s;
  s.ascan_spacing_um = -1.0;
  EXPECT_THROW(s.validate(), ConfigError);
  EXPECT_THROW(make_segmenter(Backend::cpu, {}, s), ConfigError);
}

TEST(Config, CudaBackendWithoutCudaSaysWhy) {
#if !IOCT_SEGMENTATION_HAVE_CUDA
  try {
    make_segmenter(Backend::cuda, {}, {});
    FAIL() << "no error";
  } catch (const BackendUnavailable& e) {
    EXPECT_NE(std::string(e.what()).find("no CUDA"), std::string::npos) << e.what();
  }
#else
  GTEST_SKIP() << "this build has CUDA";
#endif
}

// A small simulated volume, for the bookkeeping tests.
struct SmallRetina {
  Volume volume;
  VolumeSampling sampling;
};

const SmallRetina& small_retina() {
  static const SmallRetina retina = [] {
    seg_test::SimulatedVolumeSpec spec;
    spec.ascans = 128;
    spec.bscans = 16;
    spec.bscans_per_group = 4;
    spec.samples_per_ascan = 1024;
    spec.simulation.scan.extent_y = 0.1f;
    const seg_test::SimulatedVolume v = seg_test::make_simulated_volume(spec);
    VolumeSampling s;
    s.axial_um_per_px = v.axial_um_per_px;
    s.ascan_spacing_um = 6000.0 / 127;
    s.bscan_spacing_um = 600.0 / 15;
    return SmallRetina{v.volume, s};
  }();
  return retina;
}

TEST(Groups, AGroupRewritesOnlyTheBscansItAffects) {
  const SmallRetina& r = small_retina();
  SegmentationConfig config;
  config.bridge_bscans = 2;
  const auto segmenter = make_segmenter(Backend::cpu, config, r.sampling, 1);
  Surfaces s;
  segmenter->segment_group(r.volume, {0, 4}, s);
  for (std::uint32_t b = 0; b < 16; ++b) {
    EXPECT_EQ(s.verdict[b], b < 4 ? BscanVerdict::retina : BscanVerdict::not_segmented)
        << "B-scan " << b;
  }
  // Mark what a later group must leave alone.
  for (std::size_t k = s.index(12, 0); k < s.size(); ++k) s.ilm[k] = -7.0f;
  const BscanSpan outputs = segmenter->segment_group(r.volume, {4, 4}, s);
  // The group, the 2 B-scans its bridges reach on each side and the 2 beyond those whose fits
  // decide whether a fit there counts as measured (clipped at the volume's start).
  EXPECT_EQ(outputs, (BscanSpan{0, 12}));
  for (std::uint32_t b = 0; b < 8; ++b) EXPECT_EQ(s.verdict[b], BscanVerdict::retina) << b;
  for (std::size_t k = s.index(12, 0); k < s.size(); ++k) ASSERT_EQ(s.ilm[k], -7.0f);
}

TEST(Groups, SurfacesOfOtherDimensionsAreStartedAfresh) {
  const SmallRetina& r = small_retina();
  const auto segmenter = make_segmenter(Backend::cpu, {}, r.sampling, 1);
  Surfaces s;
  s.reset(3, 7, 9);
  segmenter->segment_group(r.volume, {0, 16}, s);
  EXPECT_EQ(s.bscans, 16u);
  EXPECT_EQ(s.ascans, 128u);
  EXPECT_EQ(s.depth, 512u);
  for (std::uint32_t b = 0; b < 16; ++b) EXPECT_EQ(s.verdict[b], BscanVerdict::retina) << b;
}

TEST(Output, CsvHasOneRowPerAscanAndEmptyCellsForNone) {
  Surfaces s;
  s.reset(2, 3, 64);
  s.state[1] = SurfaceState::measured;
  s.confidence[1] = 0.5f;
  s.ilm[1] = 10.25f;
  s.rpe[1] = 40.5f;
  s.bm[1] = 43.0f;
  char* text = nullptr;
  std::size_t size = 0;
  std::FILE* stream = open_memstream(&text, &size);
  ASSERT_NE(stream, nullptr);
  write_surfaces_csv(stream, s, 4.0);
  std::fclose(stream);
  const std::string csv(text, size);
  std::free(text);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 1 + 6);
  EXPECT_NE(csv.find("0,1,measured,0.500,10.250,40.500,43.000,41.000,162.000,172.000\n"),
            std::string::npos)
      << csv;
  EXPECT_NE(csv.find("1,2,none,0.000,,,,,,\n"), std::string::npos) << csv;
}

TEST(Output, OverlayDrawsTheSurfacesOverTheBscan) {
  Volume v = filled(1, 4, 40, 60);
  Surfaces s;
  s.reset(1, 4, 40);
  for (std::uint32_t a = 0; a < 4; ++a) {
    s.state[a] = SurfaceState::measured;
    s.ilm[a] = 10.2f;
    s.rpe[a] = 30.6f;
    s.bm[a] = 33.0f;
  }
  const RgbImage image = make_overlay(v, 0, s);
  ASSERT_EQ(image.width, 4u);
  ASSERT_EQ(image.height, 40u);
  const auto pixel = [&](std::uint32_t x, std::uint32_t y) {
    const std::uint8_t* p = image.pixels.data() + (std::size_t{y} * image.width + x) * 3;
    return std::array<int, 3>{p[0], p[1], p[2]};
  };
  EXPECT_EQ(pixel(2, 10), (std::array<int, 3>{255, 40, 40}));
  EXPECT_EQ(pixel(2, 31), (std::array<int, 3>{0, 230, 0}));
  EXPECT_EQ(pixel(2, 20), (std::array<int, 3>{60, 60, 60}));
  EXPECT_THROW(make_overlay(v, 1, s), std::out_of_range);
}

// Every grey pixel is its voxel: sizes that are no multiple of the overlay's tiles, a B-scan not
// the first, values that differ along both axes (a transposed or shifted tile would show).
TEST(Output, OverlayShowsEveryVoxelOfItsBscanInPlace) {
  Volume v(3, 45, 70);
  for (std::uint32_t b = 0; b < v.bscans(); ++b) {
    for (std::uint32_t a = 0; a < v.ascans(); ++a) {
      for (std::uint32_t d = 0; d < v.depth(); ++d) {
        v.bscan(b)[std::size_t{a} * v.depth() + d] =
            static_cast<std::uint8_t>(b * 101 + a * 7 + d * 3);
      }
    }
  }
  Surfaces s;
  s.reset(3, 45, 70);  // no surface: nothing drawn over the grey
  const RgbImage image = make_overlay(v, 1, s);
  ASSERT_EQ(image.width, 45u);
  ASSERT_EQ(image.height, 70u);
  for (std::uint32_t d = 0; d < image.height; ++d) {
    for (std::uint32_t a = 0; a < image.width; ++a) {
      const std::uint8_t* p = image.pixels.data() + (std::size_t{d} * image.width + a) * 3;
      const std::uint8_t expected = v.at(1, a, d);
      ASSERT_TRUE(p[0] == expected && p[1] == expected && p[2] == expected)
          << "pixel (" << a << ", " << d << ") is " << int{p[0]} << "," << int{p[1]} << ","
          << int{p[2]} << ", its voxel " << int{expected};
    }
  }
}

}  // namespace
}  // namespace ioct::gpu::segmentation
