// ioct-segment as a process: a Heidelberg .vol and an NRRD volume in, the surfaces CSV, overlay
// PNGs and summary out; bad input and bad options give a message naming the problem and a
// non-zero exit (1 for the input, 2 for the options), and no output files.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "ioct/gpu/offline/nrrd_file.hpp"
#include "simulated_volume.hpp"
#include "test_paths.hpp"

extern char** environ;

namespace ioct::seg_test {
namespace {

namespace fs = std::filesystem;

struct CommandRun {
  int exit_code = -1;
  std::string out;
  std::string err;
};

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

CommandRun run_segment(std::vector<std::string> args, const fs::path& dir) {
  args.insert(args.begin(), segment_executable());
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const fs::path out = dir / "stdout.txt";
  const fs::path err = dir / "stderr.txt";
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) throw std::runtime_error(std::string("cannot start ioct-segment: ") + strerror(rc));
  CommandRun run;
  int status = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (::waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      run.err = "timed out";
      return run;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  run.out = read_text(out);
  run.err = read_text(err);
  return run;
}

class SegmentCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("ioct-seg-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }
  fs::path dir_;
};

std::size_t count_lines(const std::string& text) {
  return static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n'));
}

bool is_png(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  char magic[8] = {};
  in.read(magic, 8);
  return in.gcount() == 8 && std::string(magic + 1, 3) == "PNG";
}

TEST_F(SegmentCommand, SegmentsTheSpectralisExport) {
  const fs::path input = spectralis_file();
  ASSERT_TRUE(fs::exists(input)) << "test data missing: " << input;
  const CommandRun run =
      run_segment({input.string(), "--out", (dir_ / "out").string(), "--backend", "cpu"}, dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("1 of 1 B-scans with a retina"), std::string::npos) << run.out;
  const std::string csv = read_text(dir_ / "out" / "surfaces.csv");
  EXPECT_EQ(count_lines(csv), 1u + 768u);
  EXPECT_EQ(csv.substr(0, csv.find('\n')),
            "bscan,ascan,state,confidence,ilm_px,rpe_px,bm_px,ilm_um,rpe_um,bm_um");
  EXPECT_TRUE(is_png(dir_ / "out" / "overlay_bscan000.png"));
  const nlohmann::json summary = nlohmann::json::parse(read_text(dir_ / "out" / "summary.json"));
  EXPECT_EQ(summary.at("ascans").get<int>(), 768);
  EXPECT_GT(summary.at("ascans_measured").get<int>(), 700);
  EXPECT_NEAR(summary.at("sampling_um").at("axial_per_px").get<double>(), 3.87, 0.01);
}

TEST_F(SegmentCommand, SegmentsAnNrrdVolumeWithItsSpacings) {
  SimulatedVolumeSpec spec;
  spec.ascans = 128;
  spec.bscans = 8;
  spec.bscans_per_group = 8;
  spec.samples_per_ascan = 1024;
  spec.simulation.scan.extent_y = 0.05f;
  const SimulatedVolume v = make_simulated_volume(spec);
  gpu::offline::NrrdMetadata metadata;
  metadata.spacings = {v.axial_um_per_px / 1000.0, 6.0 / 127, 0.3 / 7};
  metadata.unit = "mm";
  metadata.key_values = {{"ioct_filter", "median3x3x3+gauss5x5"}};
  const fs::path input = dir_ / "retina.nrrd";
  gpu::offline::write_nrrd_file(input, v.volume, metadata);
  const CommandRun run = run_segment(
      {input.string(), "--out", (dir_ / "out").string(), "--overlay", "all", "--backend", "cpu"},
      dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(count_lines(read_text(dir_ / "out" / "surfaces.csv")), 1u + 8u * 128u);
  for (int b = 0; b < 8; ++b) {
    char name[32];
    std::snprintf(name, sizeof name, "overlay_bscan%03d.png", b);
    EXPECT_TRUE(is_png(dir_ / "out" / name)) << name;
  }
  const nlohmann::json summary = nlohmann::json::parse(read_text(dir_ / "out" / "summary.json"));
  EXPECT_EQ(summary.at("bscans_with_retina").get<int>(), 8);
  EXPECT_FALSE(summary.at("filtered").get<bool>()) << "the NRRD says it was filtered";
  EXPECT_NEAR(summary.at("sampling_um").at("ascan_spacing").get<double>(), 6000.0 / 127, 1e-6);
}

TEST_F(SegmentCommand, BadInputAndBadOptionsFailWithAMessage) {
  const auto expect_failure = [&](std::vector<std::string> args, int code,
                                  const std::string& text) {
    args.push_back("--out");
    args.push_back((dir_ / "out").string());
    const CommandRun run = run_segment(args, dir_);
    EXPECT_EQ(run.exit_code, code) << run.err;
    EXPECT_NE(run.err.find(text), std::string::npos) << run.err;
    EXPECT_FALSE(fs::exists(dir_ / "out" / "surfaces.csv"));
  };
  expect_failure({(dir_ / "missing.vol").string()}, 1, "missing.vol");
  {
    std::ofstream(dir_ / "notes.txt") << "not a volume\n";
    expect_failure({(dir_ / "notes.txt").string()}, 1, "use .nrrd, .vol or a Bioptigen .OCT");
  }
  {
    std::ofstream(dir_ / "short.vol", std::ios::binary) << std::string(1000, 'x');
    expect_failure({(dir_ / "short.vol").string()}, 1, "short.vol");
  }
  {
    std::ofstream(dir_ / "flat.nrrd", std::ios::binary)
        << "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 16 4 2\nencoding: raw\n\n"
        << std::string(16 * 4 * 2, '\0');
    expect_failure({(dir_ / "flat.nrrd").string()}, 1, "2 x 4 x 16");  // too shallow to search
  }
  expect_failure({"x.vol", "--backend", "gpu"}, 2, "backend");
  expect_failure({"x.vol", "--filter", "maybe"}, 2, "filter");
  expect_failure({"x.vol", "--max-slope", "0"}, 2, "segmentation.max_slope");
}

}  // namespace
}  // namespace ioct::seg_test
