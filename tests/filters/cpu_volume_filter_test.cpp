// The CPU filters against their definitions: the median against sorting each voxel's 27 clamped
// neighbours, the Gaussian against the direct 2-D convolution, and incremental filtering against
// filtering the whole volume.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "filter_test_support.hpp"
#include "ioct/common/config_error.hpp"
#include "ioct/gpu/filters/cpu_volume_filter.hpp"

namespace ioct::gpu::filters {
namespace {

using testing::brute_force_median;
using testing::direct_gaussian;
using testing::first_difference;
using testing::random_volume;

struct Shape {
  std::uint32_t bscans, ascans, depth;
};

// Small and odd shapes: single B-scans and A-scans (every neighbour clamped), depths around the
// 32-voxel runs of the SIMD loop (interior runs, runs touching either end, a partial last run).
const Shape kShapes[] = {{1, 1, 1},  {1, 1, 7},  {2, 3, 31},  {3, 1, 32}, {4, 5, 33},
                         {5, 4, 34}, {3, 3, 65}, {6, 7, 100}, {1, 9, 64}, {7, 2, 2}};

Volume median_of(const Volume& in) {
  VolumeFilterConfig config;
  config.gaussian = false;
  CpuVolumeFilter filter(config);
  Volume out;
  filter.filter_volume(in, out);
  return out;
}

TEST(CpuMedian, EqualsSortingTheNeighboursBordersIncluded) {
  std::uint32_t seed = 1;
  for (const Shape& s : kShapes) {
    for (std::uint32_t levels : {256u, 3u}) {
      const Volume in = random_volume(s.bscans, s.ascans, s.depth, seed++, levels);
      const Volume out = median_of(in);
      EXPECT_EQ(first_difference(out, brute_force_median(in)), "")
          << s.bscans << " x " << s.ascans << " x " << s.depth << ", " << levels << " levels";
    }
  }
}

TEST(CpuMedian, RemovesAnIsolatedSpeckAndKeepsAnEdge) {
  Volume in(5, 6, 40);
  for (std::uint32_t b = 0; b < 5; ++b) {
    auto pixels = in.bscan(b);
    for (std::uint32_t a = 0; a < 6; ++a) {
      for (std::uint32_t d = 0; d < 40; ++d) pixels[a * 40 + d] = d < 20 ? 10 : 200;  // a layer
    }
  }
  in.bscan(2)[3 * 40 + 8] = 255;  // a speck in the dark part
  const Volume out = median_of(in);
  EXPECT_EQ(out.at(2, 3, 8), 10);
  for (std::uint32_t d = 0; d < 40; ++d) EXPECT_EQ(out.at(2, 3, d), d < 20 ? 10 : 200) << d;
}

// The second paper's median: each voxel's 3x3 neighbours in its own B-scan (A-scans x depth,
// clamped), sorted, the middle one.
Volume brute_force_bscan_median(const Volume& in) {
  Volume out(in.bscans(), in.ascans(), in.depth());
  const auto clamp = [](std::int64_t i, std::uint32_t n) {
    return static_cast<std::uint32_t>(std::clamp<std::int64_t>(i, 0, std::int64_t{n} - 1));
  };
  for (std::uint32_t b = 0; b < in.bscans(); ++b) {
    for (std::uint32_t a = 0; a < in.ascans(); ++a) {
      for (std::uint32_t d = 0; d < in.depth(); ++d) {
        std::vector<std::uint8_t> v;
        for (int da = -1; da <= 1; ++da) {
          for (int dd = -1; dd <= 1; ++dd) {
            v.push_back(in.at(b, clamp(std::int64_t{a} + da, in.ascans()),
                              clamp(std::int64_t{d} + dd, in.depth())));
          }
        }
        std::ranges::sort(v);
        out.bscan(b)[std::size_t{a} * in.depth() + d] = v[4];
      }
    }
  }
  return out;
}

TEST(CpuMedian3x3, EqualsSortingTheNeighboursInTheBscan) {
  std::uint32_t seed = 400;
  for (const Shape& s : kShapes) {
    for (std::uint32_t levels : {256u, 3u}) {
      const Volume in = random_volume(s.bscans, s.ascans, s.depth, seed++, levels);
      CpuVolumeFilter filter(filter_by_name("filter", "median-bscan"));
      Volume out;
      filter.filter_volume(in, out);
      EXPECT_EQ(first_difference(out, brute_force_bscan_median(in)), "")
          << s.bscans << " x " << s.ascans << " x " << s.depth << ", " << levels << " levels";
    }
  }
}

// Why Weiss et al. filter per B-scan: a thin membrane seen in one B-scan only (two depth pixels
// under the ILM's level) is kept by the 3x3 median and erased by the 3x3x3 one, where its voxels
// are 9 of 27 at best.
TEST(CpuMedian3x3, KeepsAStructureOfOneBscanThatThe3DMedianErases) {
  Volume in(5, 12, 40);
  for (std::uint32_t a = 2; a < 10; ++a) {
    in.bscan(2)[a * 40 + 12] = 180;
    in.bscan(2)[a * 40 + 13] = 180;
  }
  Volume per_bscan, volumetric;
  CpuVolumeFilter(filter_by_name("filter", "median-bscan")).filter_volume(in, per_bscan);
  CpuVolumeFilter(filter_by_name("filter", "median-gauss")).filter_volume(in, volumetric);
  for (std::uint32_t a = 3; a < 9; ++a) {
    EXPECT_EQ(per_bscan.at(2, a, 12), 180) << "A-scan " << a;
    EXPECT_EQ(per_bscan.at(2, a, 13), 180) << "A-scan " << a;
    EXPECT_EQ(volumetric.at(2, a, 12), 0) << "A-scan " << a;
  }
}

TEST(FilterByName, NamesEachFilterAndRefusesOthersNamingTheKey) {
  EXPECT_EQ(filter_name(filter_by_name("filter", "median-gauss")), "median-gauss");
  const VolumeFilterConfig weiss = filter_by_name("filter", "median-bscan");
  EXPECT_TRUE(weiss.median);
  EXPECT_EQ(weiss.median_window, MedianWindow::bscan_3x3);
  EXPECT_FALSE(weiss.gaussian);
  EXPECT_EQ(filter_name(weiss), "median-bscan");
  EXPECT_EQ(filter_name(filter_by_name("filter", "none")), "none");
  try {
    filter_by_name("stages.filter", "gauss-median");
    FAIL() << "accepted an unknown filter";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("stages.filter"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("gauss-median"), std::string::npos) << e.what();
  }
}

TEST(GaussianTaps, SumToOneSymmetricAndPeaked) {
  for (double sigma : {0.2, 0.5, 1.0, 1.7, 3.0, 10.0}) {
    const GaussianTaps taps = make_gaussian_taps(sigma);
    EXPECT_EQ(taps.taps[0] + taps.taps[1] + taps.taps[2] + taps.taps[3] + taps.taps[4],
              GaussianTaps::kOne);
    EXPECT_EQ(taps.taps[0], taps.taps[4]);
    EXPECT_EQ(taps.taps[1], taps.taps[3]);
    EXPECT_GE(taps.taps[2], taps.taps[1]);
    EXPECT_GE(taps.taps[1], taps.taps[0]);
    const auto exact = gaussian_taps_exact(sigma);
    for (int i = 0; i < 5; ++i) {
      EXPECT_NEAR(taps.taps[i] / double(GaussianTaps::kOne), exact[i], 1.5 / GaussianTaps::kOne);
    }
  }
}

TEST(GaussianTaps, RefusesSigmaOutsideItsRange) {
  for (double sigma : {0.0, 0.1, 10.5, -1.0, std::nan("")}) {
    EXPECT_THROW(make_gaussian_taps(sigma), ConfigError) << sigma;
    VolumeFilterConfig config;
    config.gaussian_sigma = sigma;
    EXPECT_THROW(CpuVolumeFilter{config}, ConfigError) << sigma;
  }
}

Volume gaussian_of(const Volume& in, double sigma) {
  VolumeFilterConfig config;
  config.median = false;
  config.gaussian_sigma = sigma;
  CpuVolumeFilter filter(config);
  Volume out;
  filter.filter_volume(in, out);
  return out;
}

TEST(CpuGaussian, EqualsTheDirect2DConvolutionExactly) {
  std::uint32_t seed = 100;
  for (const Shape& s : kShapes) {
    for (double sigma : {0.6, 1.0, 2.5}) {
      const Volume in = random_volume(s.bscans, s.ascans, s.depth, seed++);
      EXPECT_EQ(
          first_difference(gaussian_of(in, sigma), direct_gaussian(in, make_gaussian_taps(sigma))),
          "")
          << s.bscans << " x " << s.ascans << " x " << s.depth << ", sigma " << sigma;
    }
  }
}

TEST(CpuGaussian, WithinOneStepOfTheRealValuedGaussian) {
  for (double sigma : {0.3, 1.0, 4.0, 10.0}) {
    const Volume in = random_volume(3, 20, 50, 17);
    const Volume out = gaussian_of(in, sigma);
    const Volume exact = testing::real_gaussian(in, gaussian_taps_exact(sigma));
    int worst = 0;
    for (std::uint32_t b = 0; b < 3; ++b) {
      for (std::uint32_t a = 0; a < 20; ++a) {
        for (std::uint32_t d = 0; d < 50; ++d) {
          worst = std::max(worst, std::abs(int{out.at(b, a, d)} - int{exact.at(b, a, d)}));
        }
      }
    }
    EXPECT_LE(worst, 1) << "sigma " << sigma;
  }
}

TEST(CpuGaussian, LeavesAConstantBscanUnchanged) {
  Volume in(2, 9, 13);
  for (std::uint32_t b = 0; b < 2; ++b) std::ranges::fill(in.bscan(b), std::uint8_t{173});
  const Volume out = gaussian_of(in, 1.3);
  EXPECT_EQ(first_difference(out, in), "");
}

TEST(CpuVolumeFilter, MedianThenGaussianIsTheComposition) {
  const Volume in = random_volume(6, 11, 70, 23);
  CpuVolumeFilter filter(VolumeFilterConfig{}, 2);
  Volume out;
  filter.filter_volume(in, out);
  const Volume expected = direct_gaussian(brute_force_median(in), make_gaussian_taps(1.0));
  EXPECT_EQ(first_difference(out, expected), "");
}

TEST(CpuVolumeFilter, BothStepsOffCopies) {
  const Volume in = random_volume(3, 4, 5, 29);
  VolumeFilterConfig config;
  config.median = false;
  config.gaussian = false;
  CpuVolumeFilter filter(config);
  Volume out;
  filter.filter_volume(in, out);
  EXPECT_EQ(first_difference(out, in), "");
}

// The live case: groups of new B-scans arrive into a volume that still holds the previous one,
// and only the B-scans they touch are filtered. After every group the output must equal filtering
// the whole current input.
void expect_incremental_equals_whole(VolumeFilter& filter, std::uint32_t bscans,
                                     std::uint32_t group) {
  Volume in = random_volume(bscans, 9, 37, 41);
  Volume out;
  filter.filter_volume(in, out);  // the previous volume, filtered
  Volume whole;
  CpuVolumeFilter reference(filter.config());
  std::uint32_t seed = 500;
  for (std::uint32_t first = 0; first < bscans; first += group) {
    const std::uint32_t count = std::min(group, bscans - first);
    const Volume fresh = random_volume(count, 9, 37, seed++);
    for (std::uint32_t b = 0; b < count; ++b) {
      std::ranges::copy(fresh.bscan(b), in.bscan(first + b).begin());
    }
    const BscanRange done = filter.filter_group(in, out, first, count);
    EXPECT_EQ(done, outputs_affected_by({first, count}, bscans));
    reference.filter_volume(in, whole);
    ASSERT_EQ(first_difference(out, whole), "") << "after group at B-scan " << first;
  }
}

TEST(CpuVolumeFilter, IncrementalFilteringEqualsWholeVolumeFiltering) {
  for (std::uint32_t group : {1u, 2u, 4u, 5u}) {
    CpuVolumeFilter filter(VolumeFilterConfig{}, 2);
    expect_incremental_equals_whole(filter, 13, group);
  }
}

TEST(BscanRange, OutputsAndInputsWidenByOneAndClip) {
  EXPECT_EQ(outputs_affected_by({16, 16}, 128), (BscanRange{15, 18}));
  EXPECT_EQ(inputs_needed_for({15, 18}, 128), (BscanRange{14, 20}));
  EXPECT_EQ(outputs_affected_by({0, 16}, 128), (BscanRange{0, 17}));
  EXPECT_EQ(outputs_affected_by({112, 16}, 128), (BscanRange{111, 17}));
  EXPECT_EQ(outputs_affected_by({0, 1}, 1), (BscanRange{0, 1}));
  EXPECT_THROW(outputs_affected_by({0, 0}, 8), std::out_of_range);
  EXPECT_THROW(outputs_affected_by({8, 1}, 8), std::out_of_range);
  EXPECT_THROW(outputs_affected_by({4, 5}, 8), std::out_of_range);
}

TEST(CpuVolumeFilter, RefusesMismatchedVolumesAndRanges) {
  CpuVolumeFilter filter(VolumeFilterConfig{});
  Volume in = random_volume(4, 4, 4, 1);
  Volume out(4, 4, 5);
  EXPECT_THROW(filter.filter_group(in, out, 0, 1), std::invalid_argument);
  EXPECT_THROW(filter.filter_group(in, in, 0, 1), std::invalid_argument);
  EXPECT_THROW(filter.filter_volume(in, in), std::invalid_argument);
  Volume good(4, 4, 4);
  EXPECT_THROW(filter.filter_group(in, good, 3, 2), std::out_of_range);
  EXPECT_THROW(filter.filter_group(in, good, 0, 0), std::out_of_range);
}

TEST(VolumeFilterFactory, CpuAlwaysAndCudaOnlyWhenBuiltAndPresent) {
  EXPECT_EQ(make_volume_filter(Backend::cpu, {})->backend_name(), "cpu");
#if !IOCT_FILTERS_HAVE_CUDA
  EXPECT_THROW(make_volume_filter(Backend::cuda, {}), BackendUnavailable);
#endif
  VolumeFilterConfig bad;
  bad.gaussian_sigma = 0;
  EXPECT_THROW(make_volume_filter(Backend::cpu, bad), ConfigError);
}

}  // namespace
}  // namespace ioct::gpu::filters
