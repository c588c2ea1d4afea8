// Shadows carried from earlier volumes (finishing.hpp, carried_fit): a live segmenter that saw
// the retina unshadowed in one volume bridges an instrument's shadow in the next with those
// measured fits, moved by the retina's axial motion in between, where the neighbours' bridges
// cut across the surface's shape. A first volume, segment_volume and a memory older than
// kCarryCycles cycles carry nothing. The figures are printed ("[ figures ]").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "ioct/gpu/segmentation/cpu_segmenter.hpp"
#include "ioct/gpu/segmentation/finishing.hpp"
#include "simulated_volume.hpp"
#include "surface_errors.hpp"

namespace ioct::seg_test {
namespace {

using gpu::segmentation::BscanSpan;
using gpu::segmentation::CpuSegmenter;
using gpu::segmentation::Surfaces;
using gpu::segmentation::SurfaceState;
using gpu::segmentation::VolumeSampling;

// Under the shadow, carried: what it reaches (ILM p99 1.65 px, max 1.99 px), with a margin.
constexpr double kMaxShadowIlmP99 = 2.5;
constexpr double kMaxShadowIlmError = 3.0;
// Under the shadow, the neighbours' bridges alone are off by more than this somewhere (41 px):
// the scene is one that needs the previous volume.
constexpr double kMinNeighbourIlmError = 10.0;

// 32 x 512 A-scans spaced as the default raster (accuracy_test.cpp) with a macular hole; the
// retina `deeper` of the depth axis lower than by default (its axial motion between volumes).
SimulatedVolumeSpec hole_spec(double deeper, std::uint64_t seed) {
  SimulatedVolumeSpec spec;
  spec.ascans = 512;
  spec.bscans = 32;
  spec.simulation.scan.extent_y = 0.25f;
  spec.simulation.seed = seed;
  spec.simulation.retina.macular_hole.enabled = true;
  spec.simulation.retina.rpe_depth_fraction += deeper;
  return spec;
}

sim::InstrumentConfig forceps(float x, float y, float yaw, float jaws) {
  sim::InstrumentConfig t;
  t.pose.tip_x = x;
  t.pose.tip_y = y;
  t.pose.tip_depth_fraction = 0.45f;
  t.pose.yaw_deg = yaw;
  t.pose.jaw_opening_deg = jaws;
  return t;
}

// The forceps moves from the periphery (closed, its shaft leaving the field temporally) to the
// macular hole (open, its shaft across the B-scans: their neighbours across are all shadowed,
// and along each B-scan the shadow spans the hole's cuff); between the volumes the retina moves
// 0.01 of the depth axis (6.9 px) deeper, and again in the third, the forceps staying put.
class Carry : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    SimulatedVolumeSpec first = hole_spec(0.0, 1);
    first.simulation.instruments.push_back(forceps(-0.6f, 0.1f, 180.0f, 0.0f));
    SimulatedVolumeSpec second = hole_spec(0.01, 2);
    second.simulation.instruments.push_back(forceps(0.06f, -0.25f, 90.0f, 30.0f));
    SimulatedVolumeSpec third = hole_spec(0.02, 3);
    third.simulation.instruments = second.simulation.instruments;
    volumes_ = new std::vector<SimulatedVolume>{
        make_simulated_volume(first), make_simulated_volume(second), make_simulated_volume(third)};
    sampling_ = sampling_of(second, (*volumes_)[1]);
  }
  static void TearDownTestSuite() {
    delete volumes_;
    volumes_ = nullptr;
  }

  static const SimulatedVolume& volume(std::size_t k) { return (*volumes_)[k]; }
  static std::unique_ptr<CpuSegmenter> segmenter() {
    return std::make_unique<CpuSegmenter>(gpu::segmentation::SegmentationConfig{}, sampling_, 2);
  }

  static std::vector<SimulatedVolume>* volumes_;
  static VolumeSampling sampling_;
};

std::vector<SimulatedVolume>* Carry::volumes_ = nullptr;
VolumeSampling Carry::sampling_;

// One cycle as the live pipeline segments it: groups of 16 B-scans, each widened by the volume
// filters' reach of one B-scan either side (so the B-scans between groups are searched twice).
void live_cycle(CpuSegmenter& segmenter, const gpu::Volume& volume, Surfaces& surfaces) {
  for (std::uint32_t first = 0; first < volume.bscans(); first += 16) {
    const std::uint32_t from = first > 0 ? first - 1 : 0;
    const std::uint32_t to = std::min(volume.bscans(), first + 17);
    segmenter.segment_group(volume, BscanSpan{from, to - from}, surfaces);
  }
}

bool same_surfaces(const Surfaces& a, const Surfaces& b) {
  const auto same = [](const std::vector<float>& x, const std::vector<float>& y) {
    return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(float)) == 0;
  };
  return a.state == b.state && a.verdict == b.verdict && same(a.ilm, b.ilm) && same(a.rpe, b.rpe) &&
         same(a.bm, b.bm) && same(a.confidence, b.confidence);
}

std::size_t differing_ascans(const Surfaces& a, const Surfaces& b) {
  std::size_t n = 0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    n += std::memcmp(&a.ilm[k], &b.ilm[k], sizeof(float)) != 0 ? 1 : 0;
  }
  return n;
}

std::vector<bool> bridged(const Surfaces& s) {
  std::vector<bool> mask(s.size());
  for (std::size_t k = 0; k < s.size(); ++k) mask[k] = s.state[k] == SurfaceState::bridged;
  return mask;
}

// Under the shadow (`shadow`) and over every A-scan, against the truth of `v`.
void expect_accurate(const char* name, const Surfaces& s, const SimulatedVolume& v,
                     const std::vector<bool>& shadow) {
  const SurfaceErrors shadow_ilm = surface_errors(s.ilm, v.ilm_truth, &shadow);
  const SurfaceErrors shadow_rpe = surface_errors(s.rpe, v.rpe_truth, &shadow);
  const SurfaceErrors ilm = surface_errors(s.ilm, v.ilm_truth);
  const SurfaceErrors rpe = surface_errors(s.rpe, v.rpe_truth);
  std::printf("[ figures  ] %s, shadow ILM: %s\n", name, shadow_ilm.describe().c_str());
  std::printf("[ figures  ] %s, shadow RPE: %s\n", name, shadow_rpe.describe().c_str());
  std::printf("[ figures  ] %s, all ILM: %s\n", name, ilm.describe().c_str());
  std::printf("[ figures  ] %s, all RPE: %s\n", name, rpe.describe().c_str());
  EXPECT_GT(shadow_ilm.compared, 500u) << name;
  EXPECT_LE(shadow_ilm.p99, kMaxShadowIlmP99) << name;
  EXPECT_LE(shadow_ilm.max, kMaxShadowIlmError) << name;
  EXPECT_EQ(ilm.missing, 0u) << name;
  EXPECT_EQ(rpe.missing, 0u) << name;
  EXPECT_LE(ilm.mean_absolute, kMaxMeanError) << name;
  EXPECT_LE(ilm.p99, kMaxP99) << name;
  EXPECT_LE(rpe.mean_absolute, kMaxMeanError) << name;
  EXPECT_LE(rpe.p99, kMaxP99) << name;
  EXPECT_LE(rpe.max, kMaxRpeError) << name;
}

TEST_F(Carry, ShadowOverAMacularHoleTakesThePreviousVolumesSurfacesMovedWithTheRetina) {
  // The neighbours alone: the second volume on a fresh segmenter.
  Surfaces alone;
  segmenter()->segment_volume(volume(1).volume, alone);
  const std::vector<bool> shadow = bridged(alone);
  const SurfaceErrors neighbours = surface_errors(alone.ilm, volume(1).ilm_truth, &shadow);
  std::printf("[ figures  ] neighbours only, shadow ILM: %s\n", neighbours.describe().c_str());
  std::printf("[ figures  ] neighbours only, shadow RPE: %s\n",
              surface_errors(alone.rpe, volume(1).rpe_truth, &shadow).describe().c_str());
  EXPECT_GT(neighbours.max, kMinNeighbourIlmError);

  // Live, group by group: the second volume carries the first's fits, and the third (the
  // forceps still there, the retina moved again) the same fits moved on by the new motion.
  const auto live = segmenter();
  Surfaces surfaces;
  live_cycle(*live, volume(0).volume, surfaces);
  live_cycle(*live, volume(1).volume, surfaces);
  EXPECT_EQ(bridged(surfaces), shadow) << "carried A-scans stay bridged (inferred)";
  expect_accurate("carried, second volume", surfaces, volume(1), shadow);
  live_cycle(*live, volume(2).volume, surfaces);
  expect_accurate("carried, third volume", surfaces, volume(2), bridged(surfaces));
}

TEST_F(Carry, FirstVolumeSegmentVolumeAndForgetCarryNothing) {
  Surfaces fresh;
  live_cycle(*segmenter(), volume(1).volume, fresh);

  const auto live = segmenter();
  Surfaces surfaces;
  live_cycle(*live, volume(0).volume, surfaces);
  live_cycle(*live, volume(1).volume, surfaces);
  const std::size_t carried = differing_ascans(surfaces, fresh);
  std::printf("[ figures  ] A-scans carried from the first volume: %zu\n", carried);
  EXPECT_GT(carried, 500u);

  live->forget();
  live_cycle(*live, volume(1).volume, surfaces);
  EXPECT_TRUE(same_surfaces(surfaces, fresh)) << "after forget()";

  live_cycle(*live, volume(0).volume, surfaces);
  Surfaces whole;
  live->segment_volume(volume(1).volume, whole);
  Surfaces whole_fresh;
  segmenter()->segment_volume(volume(1).volume, whole_fresh);
  EXPECT_TRUE(same_surfaces(whole, whole_fresh)) << "segment_volume";
}

TEST_F(Carry, MemoryOlderThanTheBoundIsDropped) {
  // Whole-volume groups: every cycle of the same volume gives the same fits.
  const gpu::Volume& moved = volume(1).volume;
  const BscanSpan all{0, moved.bscans()};
  Surfaces fresh;
  segmenter()->segment_group(moved, all, fresh);

  const auto live = segmenter();
  Surfaces surfaces;
  live->segment_group(volume(0).volume, all, surfaces);
  for (std::uint32_t age = 1; age <= gpu::segmentation::detail::kCarryCycles; ++age) {
    live->segment_group(moved, all, surfaces);
    EXPECT_GT(differing_ascans(surfaces, fresh), 500u) << "carried at age " << age;
  }
  live->segment_group(moved, all, surfaces);
  EXPECT_TRUE(same_surfaces(surfaces, fresh)) << "dropped after kCarryCycles";
}

}  // namespace
}  // namespace ioct::seg_test
