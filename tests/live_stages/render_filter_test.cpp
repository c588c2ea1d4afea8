// The renderer's filter by render mode (render_filter.hpp) in the live stages, host path (CPU
// stages): in Weiss's modes the frames are the CPU reference's renders of the volume filtered by a
// 3x3 median per B-scan, while the segmentation works on the 3x3x3 median + Gaussian volume; a
// change of mode through the view parameters re-filters the current volume with no new group; an
// explicit filter (render_filter_by_mode off) serves every mode. Frames are compared with
// render::render_volume() of the filters applied to the same volume directly.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "ioct/gpu/filters/volume_filter.hpp"
#include "ioct/gpu/live_stages/render_filter.hpp"
#include "ioct/gpu/live_stages/volume_stages.hpp"
#include "ioct/gpu/render/render_params_json.hpp"
#include "ioct/gpu/render/renderer.hpp"
#include "ioct/gpu/segmentation/segmenter.hpp"
#include "live_volumes.hpp"
#include "pass_gate.hpp"

namespace ioct::gpu::live {
namespace {

using render::RenderMode;

TEST(RenderFilterRule, WeissModesRenderThePerBscanMedianAndTheOthersTheSegmentationsVolume) {
  filters::VolumeFilterConfig segmentation_filter;
  segmentation_filter.gaussian_sigma = 1.5;
  for (const RenderMode mode :
       {RenderMode::layer_aware, RenderMode::la_mip_composite, RenderMode::axial_colorization}) {
    EXPECT_TRUE(renders_from_bscan_median(mode)) << render::to_string(mode);
    EXPECT_EQ(filters::filter_name(render_filter_for(mode, segmentation_filter)), "median-bscan");
  }
  for (const RenderMode mode : {RenderMode::basic, RenderMode::enhanced, RenderMode::bscan_slice,
                                RenderMode::en_face_slice}) {
    EXPECT_FALSE(renders_from_bscan_median(mode)) << render::to_string(mode);
    const filters::VolumeFilterConfig c = render_filter_for(mode, segmentation_filter);
    EXPECT_EQ(filters::filter_name(c), "median-gauss") << render::to_string(mode);
    EXPECT_EQ(c.gaussian_sigma, 1.5) << "the segmentation's own filter";
  }
}

Volume filtered_by(const char* filter, const Volume& volume) {
  Volume out;
  filters::make_volume_filter(Backend::cpu, filters::filter_by_name("filter", filter))
      ->filter_volume(volume, out);
  return out;
}

class RenderFilterStages : public ::testing::Test {
 protected:
  void SetUp() override { std::filesystem::create_directories(dir_); }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  VolumeStagesConfig config(RenderMode mode, bool by_mode) {
    VolumeStagesConfig c;
    c.backend = Backend::cpu;
    c.cpu_threads = 2;
    c.render.mode = mode;
    c.render.view.output_width = 160;
    c.render.view.output_height = 120;
    c.render.view.rotation_deg_per_s = 0.0;  // the same view whenever it is rendered
    c.cpu_render_interval_s = 0.0;
    c.final_modes = {};
    c.render_filter_by_mode = by_mode;
    c.on_pass = [this](const StagesPass& pass) { passes_.on_pass(pass); };
    return c;
  }

  // The whole volume in groups of 8, then a second lap over B-scans 8-15 (an incremental pass on
  // a volume the renderer already holds), each pass waited for.
  void hand_over(VolumeStages& stages) {
    live_.volume = layered_volume(32, 96, 256, 21);
    std::uint64_t handed = 0;
    for (std::uint32_t first = 0; first < 32; first += 8) {
      stages.on_bscans(live_, first, 8, GroupStamp{});
      passes_.wait_for_groups(++handed);
    }
    const Volume lap = layered_volume(32, 96, 256, 22);
    std::copy_n(lap.bscan(8).data(), 8 * lap.bscan_pixels(), live_.volume.bscan(8).data());
    stages.on_bscans(live_, 8, 8, GroupStamp{});
    passes_.wait_for_groups(++handed);
  }

  // The shared view after `changes`, rendered without a new group.
  static ViewSnapshot shown_after(VolumeStages& stages, const nlohmann::json& changes) {
    const std::uint64_t generation = stages.set_params(changes);
    ViewSnapshot shot = stages.snapshot(std::chrono::seconds(20));
    EXPECT_GE(shot.generation, generation) << changes.dump();
    return shot;
  }

  // The CPU reference's render of `volume` with the stages' surfaces, as `shot` was rendered.
  static render::RgbaImage reference(const VolumeStagesConfig& c, const Volume& volume,
                                     const segmentation::Surfaces& surfaces,
                                     const ViewSnapshot& shot) {
    return render::render_volume(volume, &surfaces,
                                 render::apply_render_changes(c.render, shot.params));
  }

  PassGate passes_;
  FakeLiveVolume live_;
  const std::filesystem::path dir_ =
      std::filesystem::temp_directory_path() /
      ("ioct-render-filter-" +
       std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "-" +
       std::to_string(::getpid()));
};

bool same_floats(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](float x, float y) {
           return x == y || (std::isnan(x) && std::isnan(y));
         });
}

bool same_image(const render::RgbaImage& a, const render::RgbaImage& b) {
  return a.width == b.width && a.height == b.height && a.rgba == b.rgba;
}

TEST_F(RenderFilterStages, LayerAwareModesRenderThePerBscanMedianAndSwitchingReFilters) {
  const VolumeStagesConfig c = config(RenderMode::layer_aware, true);
  VolumeStages stages(c);
  hand_over(stages);
  const std::uint64_t passes = passes_.passes();

  const ViewSnapshot layer_aware = stages.snapshot(std::chrono::seconds(20));
  const ViewSnapshot enhanced = shown_after(stages, {{"mode", "enhanced"}});
  const ViewSnapshot la_mip = shown_after(stages, {{"mode", "la-mip"}});
  const ViewSnapshot axial = shown_after(stages, {{"mode", "axial-colorization"}});
  EXPECT_EQ(passes_.passes(), passes) << "the changes of mode needed no pass";
  const nlohmann::json summary = stages.finish(dir_);
  ASSERT_EQ(summary.at("problem"), "") << summary.dump(2);

  // The segmentation's volume is the 3D filter's, the renderer's in Weiss's modes the median of
  // each B-scan, both of the volume as last handed over.
  const Volume volumetric = filtered_by("median-gauss", live_.volume);
  const Volume per_bscan = filtered_by("median-bscan", live_.volume);
  ASSERT_FALSE(std::ranges::equal(volumetric.pixels(), per_bscan.pixels()));
  EXPECT_TRUE(std::ranges::equal(stages.filtered().pixels(), volumetric.pixels()))
      << "the segmentation's input";
  segmentation::Surfaces expected_surfaces;
  segmentation::make_segmenter(Backend::cpu, c.segmentation, c.sampling, 2)
      ->segment_volume(volumetric, expected_surfaces);
  EXPECT_TRUE(same_floats(stages.surfaces().ilm, expected_surfaces.ilm))
      << "segmented on the 3D filter's volume";
  EXPECT_TRUE(same_floats(stages.surfaces().rpe, expected_surfaces.rpe));
  EXPECT_EQ(stages.surfaces().verdict, expected_surfaces.verdict);
  const segmentation::Surfaces& s = stages.surfaces();

  EXPECT_EQ(layer_aware.params.at("mode"), "layer-aware");
  EXPECT_TRUE(same_image(layer_aware.image, reference(c, per_bscan, s, layer_aware)))
      << "layer-aware after an incremental pass: the per-B-scan median";
  EXPECT_FALSE(same_image(layer_aware.image, reference(c, volumetric, s, layer_aware)))
      << "the two volumes render apart (else this test proves nothing)";
  EXPECT_EQ(enhanced.params.at("mode"), "enhanced");
  EXPECT_TRUE(same_image(enhanced.image, reference(c, volumetric, s, enhanced)))
      << "enhanced (Viehland): the 3D filter's volume, at once after the change";
  EXPECT_EQ(la_mip.params.at("mode"), "la-mip");
  EXPECT_TRUE(same_image(la_mip.image, reference(c, per_bscan, s, la_mip)))
      << "LA-MIP: re-filtered per B-scan after the change";
  EXPECT_TRUE(same_image(axial.image, reference(c, per_bscan, s, axial)))
      << "axial colorization (Weiss's comparison)";
  EXPECT_NE(summary.at("backends").get<std::string>().find("render median-bscan"),
            std::string::npos)
      << summary.at("backends");
}

TEST_F(RenderFilterStages, AnExplicitFilterServesEveryMode) {
  const VolumeStagesConfig c = config(RenderMode::layer_aware, false);
  VolumeStages stages(c);
  hand_over(stages);
  const ViewSnapshot layer_aware = stages.snapshot(std::chrono::seconds(20));
  const ViewSnapshot la_mip = shown_after(stages, {{"mode", "la-mip"}});
  const nlohmann::json summary = stages.finish(dir_);
  ASSERT_EQ(summary.at("problem"), "") << summary.dump(2);

  const Volume volumetric = filtered_by("median-gauss", live_.volume);
  EXPECT_TRUE(
      same_image(layer_aware.image, reference(c, volumetric, stages.surfaces(), layer_aware)));
  EXPECT_TRUE(same_image(la_mip.image, reference(c, volumetric, stages.surfaces(), la_mip)));
  EXPECT_EQ(summary.at("backends").get<std::string>().find("median-bscan"), std::string::npos)
      << summary.at("backends");
}

}  // namespace
}  // namespace ioct::gpu::live
