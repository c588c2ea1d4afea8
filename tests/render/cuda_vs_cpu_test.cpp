// The CUDA renderer against the CPU reference, image by image, for every mode (and a stereo
// pair). Tolerance (docs/rendering.md): the texture unit interpolates with 8-bit fractional
// weights and the device rounds powf differently, so pixels may differ where a ray crosses a
// threshold or terminates a sample earlier; the mean absolute difference over all channels must
// stay below 1.0 level of 255, and 99 % of the values within 8 levels. Skipped without a GPU.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "analytic_volumes.hpp"
#include "ioct/gpu/render/cpu_renderer.hpp"
#include "ioct/gpu/render/layer_reference.hpp"
#include "ioct/gpu/render/renderer.hpp"
#if IOCT_RENDER_HAVE_CUDA
#include <random>

#include "ioct/gpu/cuda/cuda_support.hpp"
#include "ioct/gpu/render/cuda_renderer.hpp"
#include "ioct/gpu/segmentation/cuda_segmenter.hpp"
#endif

namespace {

using namespace ioct::gpu;
using namespace ioct::gpu::render;

struct Difference {
  double mean = 0.0;
  int p99 = 0;
  int max = 0;
};

Difference compare(const RgbaImage& a, const RgbaImage& b) {
  std::vector<int> d(a.rgba.size());
  double sum = 0.0;
  for (std::size_t i = 0; i < a.rgba.size(); ++i) {
    d[i] = std::abs(int{a.rgba[i]} - int{b.rgba[i]});
    sum += d[i];
  }
  Difference r;
  r.mean = sum / static_cast<double>(d.size());
  std::sort(d.begin(), d.end());
  r.p99 = d[static_cast<std::size_t>(0.99 * static_cast<double>(d.size() - 1))];
  r.max = d.back();
  return r;
}

TEST(CudaVsCpu, EveryModeWithinTolerance) {
  if (auto reason = cuda_unavailable_reason()) GTEST_SKIP() << "no CUDA renderer: " << *reason;
  const auto retina = ioct::render_test::make_synthetic_retina(48, 128, 160);
  std::unique_ptr<Renderer> cuda = make_renderer(Backend::cuda);
  ASSERT_EQ(cuda->backend_name(), "cuda");
  CpuRenderer cpu(0);
  cuda->set_volume(retina.volume, &retina.surfaces);
  cpu.set_volume(retina.volume, &retina.surfaces);

  RenderConfig base;
  base.spacing = {11.74, 47.24, 5.605};
  base.view.output_width = 256;
  base.view.output_height = 192;
  base.view.zoom = 1.3;
  struct Case {
    RenderMode mode;
    bool stereo;
    std::uint32_t shadow_steps;
    double azimuth;
  };
  const Case cases[] = {
      {RenderMode::basic, false, 0, 30},
      {RenderMode::enhanced, false, 0, 30},
      {RenderMode::enhanced, true, 0, 120},
      {RenderMode::layer_aware, false, 0, 30},
      {RenderMode::layer_aware, false, kShadowStepsLimited, 210},
      {RenderMode::layer_aware, true, kShadowStepsFull, 300},
      {RenderMode::axial_colorization, false, 0, 30},
      {RenderMode::axial_colorization, false, kShadowStepsLimited, 75},  // Weiss Fig. 4 B4
      {RenderMode::la_mip_composite, false, 0, 0},
      {RenderMode::bscan_slice, false, 0, 0},
      {RenderMode::en_face_slice, false, 0, 0},
  };
  for (const Case& c : cases) {
    RenderConfig config = base;
    config.mode = c.mode;
    config.view.stereo = c.stereo;
    config.view.azimuth_deg = c.azimuth;
    config.layer_aware.shadow_steps = c.shadow_steps;
    if (c.mode == RenderMode::axial_colorization) config.axial.shadow_steps = c.shadow_steps;
    RgbaImage from_cuda, from_cpu;
    cuda->render(config, from_cuda);
    cpu.render(config, from_cpu);
    ASSERT_EQ(from_cuda.width, from_cpu.width);
    ASSERT_EQ(from_cuda.height, from_cpu.height);
    const Difference d = compare(from_cuda, from_cpu);
    const std::string what = std::string(to_string(c.mode)) + (c.stereo ? " stereo" : "") +
                             " N_s=" + std::to_string(c.shadow_steps);
    std::printf("cuda vs cpu %-32s mean %.3f p99 %d max %d\n", what.c_str(), d.mean, d.p99, d.max);
    EXPECT_LT(d.mean, 1.0) << what;
    EXPECT_LE(d.p99, 8) << what;
  }
}

TEST(CudaVsCpu, GroupUpdatesMatchAFreshVolume) {
  if (auto reason = cuda_unavailable_reason()) GTEST_SKIP() << "no CUDA renderer: " << *reason;
  const auto first = ioct::render_test::make_synthetic_retina(32, 96, 128, 1);
  const auto second = ioct::render_test::make_synthetic_retina(32, 96, 128, 2);
  std::unique_ptr<Renderer> live = make_renderer(Backend::cuda);
  live->set_volume(first.volume, &first.surfaces);
  live->update_bscans(second.volume, 0, 32, &second.surfaces);
  std::unique_ptr<Renderer> fresh = make_renderer(Backend::cuda);
  fresh->set_volume(second.volume, &second.surfaces);
  RenderConfig config;
  config.view.output_width = 128;
  config.view.output_height = 96;
  for (const RenderMode mode : {RenderMode::enhanced, RenderMode::axial_colorization}) {
    config.mode = mode;
    RgbaImage a, b;
    live->render(config, a);
    fresh->render(config, b);
    EXPECT_EQ(a.rgba, b.rgba) << to_string(mode);
  }
}

#if IOCT_RENDER_HAVE_CUDA
// The live chain updates the renderer in two parts (the volume while the segmentation runs, then
// the layer reference): the same texture, bricks, sums and layer reference, so the same frames,
// bit for bit, as the update in one call, for a group in the middle and after a new shape.
TEST(CudaVsCpu, UpdateInTwoPartsIsTheUpdateInOne) {
  if (auto reason = cuda_unavailable_reason()) GTEST_SKIP() << "no CUDA renderer: " << *reason;
  const auto first = ioct::render_test::make_synthetic_retina(32, 96, 128, 1);
  const auto second = ioct::render_test::make_synthetic_retina(32, 96, 128, 2);
  const VolumeDims dims = VolumeDims::of(second.volume);
  const std::size_t n = std::size_t{dims.bscans} * dims.ascans;
  ioct::gpu::cuda::DeviceArray<std::uint8_t> pixels(dims.bytes());
  ioct::gpu::cuda::DeviceArray<float> ilm(n), rpe(n);
  IOCT_CUDA_CHECK(cudaMemcpy(pixels.data(), second.volume.pixels().data(), dims.bytes(),
                             cudaMemcpyHostToDevice));
  IOCT_CUDA_CHECK(cudaMemcpy(ilm.data(), second.surfaces.ilm.data(), n * sizeof(float),
                             cudaMemcpyHostToDevice));
  IOCT_CUDA_CHECK(cudaMemcpy(rpe.data(), second.surfaces.rpe.data(), n * sizeof(float),
                             cudaMemcpyHostToDevice));
  segmentation::DeviceSurfaceView surfaces;
  surfaces.ilm = ilm.data();
  surfaces.rpe = rpe.data();
  surfaces.bscans = dims.bscans;
  surfaces.ascans = dims.ascans;
  const VolumeRef volume = VolumeRef::on_device(pixels.data(), dims, nullptr);

  RenderConfig config;
  config.view.output_width = 128;
  config.view.output_height = 96;
  for (const bool new_shape : {false, true}) {
    SCOPED_TRACE(new_shape ? "after a new shape" : "a group of B-scans 8-23");
    CudaRenderer whole, parts;
    if (!new_shape) {
      whole.set_volume(first.volume, &first.surfaces);
      parts.set_volume(first.volume, &first.surfaces);
    }
    whole.update_bscans(volume, 8, 16, surfaces);
    parts.update_volume(volume, 8, 16);
    parts.update_layers(surfaces);
    const LayerReference a = whole.layer_reference();
    const LayerReference b = parts.layer_reference();
    EXPECT_EQ(a.rpe_px, b.rpe_px);
    EXPECT_EQ(a.axial_plane_px, b.axial_plane_px);
    EXPECT_EQ(a.mean_thickness_px, b.mean_thickness_px);
    for (const RenderMode mode :
         {RenderMode::enhanced, RenderMode::axial_colorization, RenderMode::layer_aware}) {
      config.mode = mode;
      RgbaImage from_whole, from_parts;
      whole.render(config, from_whole);
      parts.render(config, from_parts);
      EXPECT_EQ(from_whole.rgba, from_parts.rgba) << to_string(mode);
    }
  }
}

// The LA-MIP projections are kept between renders and made again only where the voxels or the
// RPE changed: after groups anywhere (the middle B-scans too, whose RPE sets every curve's depth),
// an RPE change without a voxel change (a B-scan that loses its RPE takes its neighbour's), and
// renders of other modes in between, the frames are those of a renderer given the final volume
// whole, bit for bit.
TEST(CudaVsCpu, LaMipAfterGroupsIsTheFinalVolumesOwn) {
  if (auto reason = cuda_unavailable_reason()) GTEST_SKIP() << "no CUDA renderer: " << *reason;
  auto current = ioct::render_test::make_synthetic_retina(64, 96, 128, 1);
  const auto next = ioct::render_test::make_synthetic_retina(64, 96, 128, 2);
  const std::size_t bscan_px = current.volume.bscan_pixels();
  const std::uint32_t ascans = current.volume.ascans();
  RenderConfig la_mip;
  la_mip.mode = RenderMode::la_mip_composite;
  la_mip.view.output_width = 160;
  la_mip.view.output_height = 120;
  RenderConfig enhanced = la_mip;
  enhanced.mode = RenderMode::enhanced;

  CudaRenderer live;
  live.set_volume(current.volume, &current.surfaces);
  RgbaImage frame, fresh_frame;
  live.render(la_mip, frame);
  // Groups of B-scans from `next`: at the start, over the middle (B-scans 31 and 32, whose RPE
  // sets every curve's depth), at the end with another mode rendered in between; then the middle's
  // voxels alone (the RPE kept).
  struct Step {
    std::uint32_t first, count;
    bool render_other_mode = false;
    bool voxels_only = false;
  };
  for (const Step step : {Step{0, 8}, Step{28, 8}, Step{52, 12, true}, Step{30, 4, false, true}}) {
    SCOPED_TRACE("group [" + std::to_string(step.first) + ", " +
                 std::to_string(step.first + step.count) + ")");
    if (!step.voxels_only) {
      std::copy_n(next.volume.bscan(step.first).data(), step.count * bscan_px,
                  current.volume.bscan(step.first).data());
      const std::size_t from = std::size_t{step.first} * ascans;
      const std::size_t n = std::size_t{step.count} * ascans;
      std::copy_n(next.surfaces.ilm.begin() + from, n, current.surfaces.ilm.begin() + from);
      std::copy_n(next.surfaces.rpe.begin() + from, n, current.surfaces.rpe.begin() + from);
    } else {
      // Other voxels, the same RPE: darken the B-scans.
      for (std::uint32_t b = step.first; b < step.first + step.count; ++b) {
        for (std::uint8_t& v : current.volume.bscan(b)) v = static_cast<std::uint8_t>(v / 2);
      }
    }
    live.update_bscans(current.volume, step.first, step.count, &current.surfaces);
    if (step.render_other_mode) live.render(enhanced, frame);
    live.render(la_mip, frame);
    CudaRenderer fresh;
    fresh.set_volume(current.volume, &current.surfaces);
    fresh.render(la_mip, fresh_frame);
    EXPECT_EQ(frame.rgba, fresh_frame.rgba);
  }
  // B-scan 20 loses its RPE (its reference row becomes a neighbour's) while only B-scan 2's voxels
  // change.
  std::fill_n(current.surfaces.rpe.begin() + std::size_t{20} * ascans, ascans,
              segmentation::Surfaces::kNone);
  std::copy_n(next.volume.bscan(2).data(), bscan_px, current.volume.bscan(2).data());
  live.update_bscans(current.volume, 2, 1, &current.surfaces);
  live.render(la_mip, frame);
  CudaRenderer fresh;
  fresh.set_volume(current.volume, &current.surfaces);
  fresh.render(la_mip, fresh_frame);
  EXPECT_EQ(frame.rgba, fresh_frame.rgba) << "an RPE change without a voxel change";
  // And against the CPU reference, within the renderers' tolerance.
  CpuRenderer cpu(0);
  cpu.set_volume(current.volume, &current.surfaces);
  RgbaImage cpu_frame;
  cpu.render(la_mip, cpu_frame);
  const Difference d = compare(frame, cpu_frame);
  EXPECT_LT(d.mean, 1.0);
  EXPECT_LE(d.p99, 8);
}

// The CUDA renderer makes its layer reference on the device (no round trip to the host): the same
// rows, bit for bit, as make_layer_reference() on the host, on fresh random volumes and surfaces
// with holes of every kind (single A-scans, runs at either end, whole B-scans, none at all).
TEST(CudaVsCpu, LayerReferenceOnTheDeviceIsTheHosts) {
  if (auto reason = cuda_unavailable_reason()) GTEST_SKIP() << "no CUDA renderer: " << *reason;
  const unsigned seed = std::random_device{}();
  SCOPED_TRACE("seed " + std::to_string(seed));
  std::mt19937 random(seed);
  const std::uint32_t bscans = 24, ascans = 200, depth = 96;
  Volume volume(bscans, ascans, depth);
  std::uniform_int_distribution<int> byte(0, 255);
  for (std::uint8_t& v : volume.pixels()) v = static_cast<std::uint8_t>(byte(random));
  const CentreOfMassSums sums = centre_of_mass_sums(volume, 0, bscans);
  std::uniform_real_distribution<float> ilm_depth(5.0f, 40.0f), thickness(10.0f, 50.0f);
  std::bernoulli_distribution hole(0.2);

  enum class Holes { scattered, with_empty_bscans, rpe_only_in_one_bscan, no_rpe };
  for (const Holes holes :
       {Holes::scattered, Holes::with_empty_bscans, Holes::rpe_only_in_one_bscan, Holes::no_rpe}) {
    SCOPED_TRACE("holes case " + std::to_string(static_cast<int>(holes)));
    segmentation::Surfaces surfaces;
    surfaces.reset(bscans, ascans, depth);
    for (std::uint32_t b = 0; b < bscans; ++b) {
      for (std::uint32_t a = 0; a < ascans; ++a) {
        const std::size_t i = std::size_t{b} * ascans + a;
        surfaces.ilm[i] = hole(random) ? segmentation::Surfaces::kNone : ilm_depth(random);
        surfaces.rpe[i] = hole(random) || a < 7 || a > ascans - 4
                              ? segmentation::Surfaces::kNone
                              : surfaces.ilm[i] + thickness(random);
        const bool empty = (holes == Holes::with_empty_bscans && (b == 0 || b % 5 == 2)) ||
                           (holes == Holes::rpe_only_in_one_bscan && b != 17) ||
                           holes == Holes::no_rpe;
        if (empty) surfaces.rpe[i] = segmentation::Surfaces::kNone;
      }
    }
    CudaRenderer cuda;
    cuda.set_volume(volume, &surfaces);
    const LayerReference on_device = cuda.layer_reference();
    const LayerReference on_host = make_layer_reference(bscans, ascans, depth, &surfaces, sums);
    ASSERT_EQ(on_device.rpe_px.size(), on_host.rpe_px.size());
    for (std::size_t i = 0; i < on_host.rpe_px.size(); ++i) {
      ASSERT_EQ(on_device.rpe_px[i], on_host.rpe_px[i])
          << "RPE, B-scan " << i / ascans << ", A-scan " << i % ascans;
      ASSERT_EQ(on_device.axial_plane_px[i], on_host.axial_plane_px[i]) << "axial plane " << i;
    }
    // Sums of doubles in another order: equal to the last bits in practice, held to 1e-6.
    EXPECT_NEAR(on_device.mean_thickness_px, on_host.mean_thickness_px,
                1e-6 * std::max(1.0f, on_host.mean_thickness_px));
    if (holes == Holes::no_rpe) {
      EXPECT_EQ(on_device.mean_thickness_px, 0.0f);
    }
  }

  // Without surfaces, or with surfaces of other dimensions: the axial plane stands in.
  segmentation::Surfaces other;
  other.reset(bscans + 1, ascans, depth);
  for (const segmentation::Surfaces* surfaces :
       {static_cast<segmentation::Surfaces*>(nullptr), &other}) {
    CudaRenderer cuda;
    cuda.set_volume(volume, surfaces);
    const LayerReference on_device = cuda.layer_reference();
    const LayerReference on_host = make_layer_reference(bscans, ascans, depth, surfaces, sums);
    EXPECT_EQ(on_device.rpe_px, on_host.rpe_px);
    EXPECT_EQ(on_device.axial_plane_px, on_host.axial_plane_px);
    EXPECT_EQ(on_device.mean_thickness_px, 0.0f);
  }
}
#endif

}  // namespace
