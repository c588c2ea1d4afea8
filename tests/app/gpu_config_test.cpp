// ioct-gpu's configuration: its file, its flags and the setup they resolve to, all from the one
// declaration of each key (gpu/app/src/gpu_config.cpp).
#include "gpu_config.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "ioct/common/config_error.hpp"
#include "ioct/test_support/temp_path.hpp"

namespace ioct::gpu {
namespace {

test_support::TempPath config_file(const std::string& text) {
  return test_support::TempPath::with_text("gpu-config", ".toml", text);
}

std::string error_for(const std::string& file, const config::Overrides& overrides = {}) {
  try {
    make_gpu_setup(file, overrides, {});
  } catch (const std::exception& e) {
    return e.what();
  }
  return "accepted";
}

TEST(GpuConfig, TheAppliancesFileResolvesToItsRingFramesAndViewSocket) {
  const GpuSetup setup = make_gpu_setup(IOCT_GPU_CONFIG_DIR "/appliance.toml", {}, {});
  EXPECT_EQ(setup.live.ring_name, "/dev/shm/ioct/ring");
  EXPECT_EQ(setup.live.wait_s, 3600.0);
  EXPECT_EQ(setup.live.out_dir, "/var/lib/ioct/frames");
  ASSERT_TRUE(setup.stages);
  EXPECT_EQ(setup.stages->frame_ring, "/dev/shm/ioct-frames/frames");
  EXPECT_EQ(setup.stages->frame_group, "ioct-frames");
  EXPECT_TRUE(setup.stages->instruments.enabled);
  // filter = "auto": the segmentation's volume median + Gaussian, the renderer's by render mode.
  EXPECT_TRUE(setup.stages->render_filter_by_mode);
  EXPECT_TRUE(setup.stages->filter.gaussian);
  EXPECT_EQ(setup.stages->filter.median_window, filters::MedianWindow::volume_3x3x3);
  EXPECT_EQ(setup.stages->live_image, "/var/lib/ioct/frames/render.png");
  ASSERT_TRUE(setup.socket);
  EXPECT_EQ(setup.socket->path, "/run/ioct-gpu/view.sock");
  EXPECT_EQ(setup.socket->snapshot_dir, "/var/lib/ioct/frames/snapshots");
}

TEST(GpuConfig, FlagsOverrideTheFileAndTheDefaultsFillTheRest) {
  const auto file =
      config_file("[processing]\nthreads = 3\nbackend = \"cpu\"\n[render]\nmode = \"la-mip\"\n");
  const GpuSetup setup = make_gpu_setup(
      file.str(), {{"processing.threads", {"4"}}, {"stages.filter", {"median-bscan"}}}, {});
  EXPECT_EQ(setup.live.processing.threads, 4u) << "the flag wins";
  EXPECT_EQ(setup.live.backend, Backend::cpu) << "the file's";
  ASSERT_TRUE(setup.stages);
  EXPECT_EQ(setup.stages->backend, Backend::cpu) << "the stages run where processing does";
  EXPECT_EQ(setup.stages->render.mode, render::RenderMode::la_mip_composite);
  EXPECT_FALSE(setup.stages->filter.gaussian) << "median-bscan";
  EXPECT_FALSE(setup.stages->render_filter_by_mode) << "an explicit filter serves every mode";
  EXPECT_EQ(setup.stages->frame_ring, "ioct-ring.frames") << "the ring's name + .frames";
  EXPECT_FALSE(setup.socket);
  EXPECT_FALSE(make_gpu_setup("", {{"stages.enabled", {"false"}}}, {}).stages);
}

TEST(GpuConfig, AFilesErrorIsLocatedAndAFlagsNamesItsKey) {
  const auto range = config_file("[processing]\nthreads = 0\n");
  EXPECT_EQ(error_for(range.str()),
            range.str() + ":2:11: processing.threads = 0: must be in [1, 16]");
  const auto unknown = config_file("[render]\nmode = \"enhanced\"\nthreshold = 0.3\n");
  EXPECT_EQ(
      error_for(unknown.str()),
      unknown.str() + ":3:1: render.threshold: unknown key; [render] takes mode, width, height");
  // A component's own check of a key the file set is placed at the key's line as well.
  const auto spacing = config_file("[sampling]\naxial_um_per_px = 0.01\n");
  EXPECT_EQ(
      error_for(spacing.str()).rfind(spacing.str() + ":2:19: sampling.axial_um_per_px = 0.01", 0),
      0u)
      << error_for(spacing.str());
  // A component's older name for a key is told as the file's key, at its line.
  const auto ring = config_file("[ring]\nname = \"a/b\"\n");
  EXPECT_EQ(error_for(ring.str()).rfind(ring.str() + ":2:8: ring.name = 'a/b': ", 0), 0u)
      << error_for(ring.str());
  const auto db = config_file("[processing]\ndb_min = 50\ndb_max = 40\n");
  EXPECT_EQ(error_for(db.str()).rfind(
                db.str() + ":3:10: processing.db_max = 40: must be at least 1 dB", 0),
            0u)
      << error_for(db.str());
  EXPECT_EQ(error_for("", {{"render.width", {"wide"}}}),
            "render.width = \"wide\": must be an integer in [1, 8192]");
  EXPECT_EQ(gpu_keys().flag_for("render.width"), "--render-width");
  const auto socket = config_file("[stages]\nenabled = false\n[view]\nsocket = \"/tmp/v.sock\"\n");
  EXPECT_EQ(error_for(socket.str()),
            socket.str() +
                ":4:10: view.socket = \"/tmp/v.sock\": needs the live stages (stages.enabled = "
                "true, not --no-stages)");
}

TEST(GpuConfig, TheFinalModesAreRenderModesEachNamedOnce) {
  using render::RenderMode;
  const std::vector<RenderMode> three{RenderMode::enhanced, RenderMode::layer_aware,
                                      RenderMode::la_mip_composite};
  EXPECT_EQ(make_gpu_setup("", {}, {}).stages->final_modes, three) << "the default";
  EXPECT_TRUE(
      make_gpu_setup(IOCT_GPU_CONFIG_DIR "/appliance.toml", {}, {}).stages->final_modes.empty())
      << "the appliance stops without rendering other modes";
  const auto two = config_file("[stages]\nfinal_modes = [\"axial-colorization\", \"en-face\"]\n");
  EXPECT_EQ(make_gpu_setup(two.str(), {}, {}).stages->final_modes,
            (std::vector<RenderMode>{RenderMode::axial_colorization, RenderMode::en_face_slice}));
  EXPECT_EQ(make_gpu_setup("", {{"stages.final_modes", {"bscan"}}}, {}).stages->final_modes,
            std::vector<RenderMode>{RenderMode::bscan_slice})
      << "the flag";

  const auto unknown = config_file("[stages]\nfinal_modes = [\"enhanced\", \"mip\"]\n");
  EXPECT_EQ(error_for(unknown.str()),
            unknown.str() +
                ":2:15: stages.final_modes[1] = 'mip': must be basic, enhanced, layer-aware, "
                "axial-colorization, la-mip, bscan or en-face");
  const auto twice = config_file("[stages]\nfinal_modes = [\"la-mip\", \"la-mip\"]\n");
  EXPECT_EQ(error_for(twice.str()),
            twice.str() + ":2:15: stages.final_modes[1] = 'la-mip': is named twice");
  EXPECT_EQ(error_for("", {{"stages.final_modes", {"enhanced", "nonsense"}}}),
            "stages.final_modes[1] = 'nonsense': must be basic, enhanced, layer-aware, "
            "axial-colorization, la-mip, bscan or en-face");
}

TEST(GpuConfig, ThePrintedConfigurationReadsBackAsTheSame) {
  const auto file = config_file("[processing]\ndispersion_c2 = -12.5\nresample_poly = \"0,1\"\n");
  const GpuSetup setup = make_gpu_setup(file.str(), {}, {});
  const std::string printed = gpu_keys().to_toml(setup.config);
  const auto again = config_file(printed);
  EXPECT_EQ(gpu_keys().to_toml(make_gpu_setup(again.str(), {}, {}).config), printed);
}

// docs/config-keys.md holds the table `ioct-gpu --config-keys` prints, as it is now.
TEST(GpuConfig, TheDocsKeyTableIsTheDeclarations) {
  std::ifstream in(IOCT_DOCS_DIR "/config-keys.md");
  ASSERT_TRUE(in) << IOCT_DOCS_DIR "/config-keys.md";
  const std::string docs((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(docs.find(gpu_keys().markdown()), std::string::npos)
      << "regenerate the ioct-gpu table of docs/config-keys.md with ioct-gpu --config-keys";
}

// The run's limits come from the command line alone and are checked with the rest, once.
TEST(GpuConfig, TheRunsLimitsAreCarriedAndChecked) {
  const GpuSetup setup = make_gpu_setup("", {}, {2.5, true});
  EXPECT_EQ(setup.live.run_s, 2.5);
  EXPECT_TRUE(setup.live.exit_when_producer_gone);
  try {
    (void)make_gpu_setup("", {}, {-1.0, false});
    ADD_FAILURE() << "a negative run time was accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "seconds");
  }
}

}  // namespace
}  // namespace ioct::gpu
