// ioct-render as a process: the real .vol and a NRRD rendered in every mode; bad options and
// files refused with the key or the file named.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "analytic_volumes.hpp"
#include "ioct/gpu/offline/nrrd_file.hpp"
#include "ioct/gpu/volume/png_file.hpp"
#include "test_paths.hpp"

namespace {

namespace fs = std::filesystem;
using ioct::render_test::render_executable;
using ioct::render_test::test_data_dir;

struct Result {
  int status = -1;
  std::string output;
};

Result run(const std::string& arguments) {
  Result r;
  const std::string command = render_executable() + " " + arguments + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return r;
  std::array<char, 4096> buffer{};
  while (fgets(buffer.data(), buffer.size(), pipe) != nullptr) r.output += buffer.data();
  const int status = pclose(pipe);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

class RenderCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("ioct_render_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  // A small synthetic retina as the NRRD ioct-process writes, spacings in mm.
  fs::path write_retina_nrrd() const {
    const auto v = ioct::render_test::make_synthetic_retina(16, 32, 64);
    ioct::gpu::offline::NrrdMetadata meta;
    meta.spacings = {0.005, 0.02, 0.08};
    meta.unit = "mm";
    const fs::path nrrd = dir_ / "retina.nrrd";
    ioct::gpu::offline::write_nrrd_file(nrrd, v.volume, meta);
    return nrrd;
  }
  fs::path dir_;
};

TEST_F(RenderCommand, RendersTheRealVolInEveryMode) {
  const fs::path vol = test_data_dir() / "spectralis_circle_valid.vol";
  ASSERT_TRUE(fs::exists(vol)) << vol;
  const Result r = run(vol.string() + " --out " + dir_.string() +
                       " --mode all --width 96 --height 64 --backend cpu --threads 2");
  ASSERT_EQ(r.status, 0) << r.output;
  for (const char* name :
       {"basic", "enhanced", "layer-aware", "axial-colorization", "la-mip", "bscan", "en-face"}) {
    EXPECT_TRUE(fs::exists(dir_ / (std::string(name) + ".png"))) << name << "\n" << r.output;
  }
  EXPECT_TRUE(fs::exists(dir_ / "summary.json"));
  EXPECT_NE(r.output.find("Bruch"), std::string::npos) << r.output;
}

std::string file_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Viehland Fig. 4's progression from the command line: with edge, feature, depth cues and Phong
// off, the enhanced caster is the basic one; each step on its own changes the image.
TEST_F(RenderCommand, EnhancementStepsSwitchOffOneByOne) {
  const fs::path nrrd = write_retina_nrrd();
  const std::string common = nrrd.string() + " --out " + dir_.string() +
                             " --width 48 --height 36 --backend cpu --layers none --threads 2";
  const std::string all_off = " --no-edge --no-feature --no-depth-cues --no-phong";
  ASSERT_EQ(run(common + " --mode basic --prefix basic_").status, 0);
  ASSERT_EQ(run(common + " --mode enhanced --prefix off_" + all_off).status, 0);
  ASSERT_EQ(run(common + " --mode enhanced --prefix on_").status, 0);
  const std::string basic = file_bytes(dir_ / "basic_basic.png");
  ASSERT_FALSE(basic.empty());
  EXPECT_EQ(file_bytes(dir_ / "off_enhanced.png"), basic);
  EXPECT_NE(file_bytes(dir_ / "on_enhanced.png"), basic);
  for (const char* step : {"--no-edge", "--no-feature", "--no-depth-cues", "--no-phong"}) {
    const std::string prefix = std::string("without") + (step + 4) + "_";
    ASSERT_EQ(run(common + " --mode enhanced --prefix " + prefix + " " + step).status, 0) << step;
    EXPECT_NE(file_bytes(dir_ / (prefix + "enhanced.png")), file_bytes(dir_ / "on_enhanced.png"))
        << step << " changed nothing";
  }
}

TEST_F(RenderCommand, WritesATurntableAndStereoPairsFromANrrd) {
  const fs::path nrrd = write_retina_nrrd();
  const Result r = run(nrrd.string() + " --out " + dir_.string() +
                       " --mode enhanced --stereo --turntable 4 --width 40 --height 30 "
                       "--backend cpu --layers none --threads 2");
  ASSERT_EQ(r.status, 0) << r.output;
  for (int f = 0; f < 4; ++f) {
    char name[64];
    std::snprintf(name, sizeof name, "enhanced_turn%04d.png", f);
    EXPECT_TRUE(fs::exists(dir_ / name)) << name;
  }
}

TEST_F(RenderCommand, RefusesBadOptionsNamingTheKey) {
  const fs::path vol = test_data_dir() / "spectralis_circle_valid.vol";
  Result r = run(vol.string() + " --out " + dir_.string() + " --width -5");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("render.view.output_width"), std::string::npos) << r.output;
  r = run(vol.string() + " --out " + dir_.string() + " --shadow-steps 5000");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("render.layer_aware.shadow_steps"), std::string::npos) << r.output;
  r = run(vol.string() + " --out " + dir_.string() + " --mode sparkle");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("render.mode"), std::string::npos) << r.output;
}

TEST_F(RenderCommand, RefusesADamagedFileNamingIt) {
  const fs::path bad = dir_ / "broken.nrrd";
  std::ofstream(bad) << "NRRD0004\ntype: uint8\n";
  const Result r = run(bad.string() + " --out " + dir_.string() + " --backend cpu");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("broken.nrrd"), std::string::npos) << r.output;
}

}  // namespace
