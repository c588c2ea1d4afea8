// The CUDA filters against the CPU ones, bit for bit, on the GPU machine; skipped, saying why,
// where the build has no CUDA or the machine no GPU.
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "filter_test_support.hpp"
#include "ioct/gpu/filters/cpu_volume_filter.hpp"
#if IOCT_FILTERS_HAVE_CUDA
#include "ioct/gpu/filters/cuda_volume_filter.hpp"
#endif

namespace ioct::gpu::filters {
namespace {

using testing::first_difference;
using testing::random_volume;

#if IOCT_FILTERS_HAVE_CUDA

// A CUDA filter, or the reason there is none here.
std::unique_ptr<CudaVolumeFilter> cuda_filter(const VolumeFilterConfig& config,
                                              CudaFilterTuning tuning, std::string& why_not) {
  try {
    return std::make_unique<CudaVolumeFilter>(config, tuning);
  } catch (const BackendUnavailable& e) {
    why_not = e.what();
    return nullptr;
  }
}

#define IOCT_REQUIRE_CUDA_FILTER(filter, config, tuning) \
  std::string why_not;                                   \
  auto filter = cuda_filter(config, tuning, why_not);    \
  if (!filter) GTEST_SKIP() << "no CUDA device: " << why_not

struct Shape {
  std::uint32_t bscans, ascans, depth;
};

// Depths that are and are not multiples of the 4 voxels a thread packs, tiny volumes where every
// thread is at a border, and one larger than a Gaussian tile in every direction.
const Shape kShapes[] = {{1, 1, 1},  {1, 1, 7},    {2, 3, 5},    {3, 2, 8},    {5, 7, 33},
                         {4, 9, 64}, {9, 17, 130}, {7, 40, 201}, {20, 33, 256}};

const MedianKernel kKernels[] = {MedianKernel::sorted_runs_u16x2, MedianKernel::sorted_runs_f16x2,
                                 MedianKernel::sorted_runs_u8x4, MedianKernel::forgetful};

class CudaVersusCpu : public ::testing::TestWithParam<MedianKernel> {};

TEST_P(CudaVersusCpu, MedianGaussianAndBothAreBitExact) {
  std::uint32_t seed = 1000;
  for (std::uint32_t walk : {1u, 2u, 3u, 16u}) {
    for (int steps = 0; steps < 3; ++steps) {
      VolumeFilterConfig config;
      config.median = steps != 1;
      config.gaussian = steps != 0;
      config.gaussian_sigma = 1.0 + 0.4 * walk;
      IOCT_REQUIRE_CUDA_FILTER(cuda, config, (CudaFilterTuning{GetParam(), walk, walk}));
      CpuVolumeFilter cpu(config);
      for (const Shape& s : kShapes) {
        const std::uint32_t levels = seed % 3 == 0 ? 4 : 256;  // some volumes full of ties
        const Volume in = random_volume(s.bscans, s.ascans, s.depth, seed++, levels);
        Volume expected, got;
        cpu.filter_volume(in, expected);
        cuda->filter_volume(in, got);
        ASSERT_EQ(first_difference(got, expected), "")
            << to_string(GetParam()) << ", walk " << walk << ", median " << config.median
            << ", gaussian " << config.gaussian << ", " << s.bscans << " x " << s.ascans << " x "
            << s.depth;
      }
    }
  }
}

// The second paper's 3x3 median per B-scan, alone and followed by the Gaussian.
TEST_P(CudaVersusCpu, BscanMedianIsBitExact) {
  std::uint32_t seed = 3000;
  for (const bool gaussian : {false, true}) {
    VolumeFilterConfig config = filter_by_name("filter", "median-bscan");
    config.gaussian = gaussian;
    IOCT_REQUIRE_CUDA_FILTER(cuda, config, (CudaFilterTuning{GetParam(), 3, 16}));
    CpuVolumeFilter cpu(config);
    for (const Shape& s : kShapes) {
      const std::uint32_t levels = seed % 3 == 0 ? 4 : 256;
      const Volume in = random_volume(s.bscans, s.ascans, s.depth, seed++, levels);
      Volume expected, got;
      cpu.filter_volume(in, expected);
      cuda->filter_volume(in, got);
      ASSERT_EQ(first_difference(got, expected), "")
          << "gaussian " << gaussian << ", " << s.bscans << " x " << s.ascans << " x " << s.depth;
    }
  }
}

TEST_P(CudaVersusCpu, IncrementalEqualsWholeVolume) {
  IOCT_REQUIRE_CUDA_FILTER(cuda, VolumeFilterConfig{}, (CudaFilterTuning{GetParam(), 4, 5}));
  CpuVolumeFilter cpu(VolumeFilterConfig{});
  Volume in = random_volume(37, 21, 90, 77);
  Volume out, whole;
  cuda->filter_volume(in, out);
  std::uint32_t seed = 900;
  for (std::uint32_t first = 0; first < 37; first += 8) {
    const std::uint32_t count = std::min(8u, 37 - first);
    const Volume fresh = random_volume(count, 21, 90, seed++);
    for (std::uint32_t b = 0; b < count; ++b) {
      std::ranges::copy(fresh.bscan(b), in.bscan(first + b).begin());
    }
    EXPECT_EQ(cuda->filter_group(in, out, first, count), outputs_affected_by({first, count}, 37));
    cpu.filter_volume(in, whole);
    ASSERT_EQ(first_difference(out, whole), "") << "after group at B-scan " << first;
  }
}

INSTANTIATE_TEST_SUITE_P(Kernels, CudaVersusCpu, ::testing::ValuesIn(kKernels),
                         [](const auto& kernel) { return std::string(to_string(kernel.param)); });

TEST(CudaVolumeFilter, DefaultGeometryEqualsCpu) {
  IOCT_REQUIRE_CUDA_FILTER(cuda, VolumeFilterConfig{}, CudaFilterTuning{});
  CpuVolumeFilter cpu(VolumeFilterConfig{}, 2);
  const Volume in = random_volume(128, 512, 688, 5);
  Volume expected, got;
  cpu.filter_volume(in, expected);
  cuda->filter_volume(in, got);
  EXPECT_EQ(first_difference(got, expected), "");
}

#else

TEST(CudaVolumeFilter, NotInThisBuild) {
  GTEST_SKIP() << "no CUDA device: this build has no CUDA (configure with -DIOCT_CUDA=ON)";
}

#endif

}  // namespace
}  // namespace ioct::gpu::filters
