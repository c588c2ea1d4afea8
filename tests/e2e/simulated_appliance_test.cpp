// The simulated appliance end to end, as the demo runs it: ioct-rt and ioct-gpu as processes
// joined by the ring. The books must balance across the two processes (every group ioct-rt
// published was consumed or counted as dropped by ioct-gpu), and the B-scan image ioct-gpu wrote
// must show the simulated retina where the simulator's ground truth puts it.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ioct/gpu/volume/png_file.hpp"
#include "ioct/sim/simulated_digitizer.hpp"
#include "ioct/test_support/child_process.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "rt_options.hpp"

namespace ioct::e2e_test {
namespace {

using namespace std::chrono_literals;
using test_support::ChildProcess;

// A small raster at a quarter of the real sweep rate, so that a loaded 2-core CI machine runs
// both processes with room to spare (timing is the rt and ring tests' business, not this one's):
// 128 A-scans x 8 B-scans per group (49 ms at 25 kHz), 32 B-scans per volume (4 groups).
struct SmallRaster {
  std::string ring;
  std::uint32_t samples = 1376;  // ioct-rt's default
  std::uint32_t ascans = 128;
  std::uint32_t bscans_per_group = 8;
  std::uint32_t bscans_per_volume = 32;
  double ascan_rate = 25'000.0;
  double seconds = 4.0;
  std::uint64_t seed = 7;
};

std::vector<std::string> rt_arguments(const SmallRaster& o, const std::string& summary) {
  return {"--ring",
          o.ring,
          "--ascans",
          std::to_string(o.ascans),
          "--bscans-per-group",
          std::to_string(o.bscans_per_group),
          "--bscans-per-volume",
          std::to_string(o.bscans_per_volume),
          "--ascan-rate",
          std::to_string(o.ascan_rate),
          "--seconds",
          std::to_string(o.seconds),
          "--seed",
          std::to_string(o.seed),
          "--rt-priority",
          "0",  // CI runs unprivileged as often as not; timing is not what this test checks
          "--summary",
          summary};
}

nlohmann::json read_json(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path.string());
  return nlohmann::json::parse(in);
}

int wait_exit(ChildProcess& child, std::chrono::milliseconds timeout) {
  const auto status = child.wait_for(timeout);
  if (!status) {
    ADD_FAILURE() << "pid " << child.pid() << " still running after " << timeout.count() << " ms";
    return -1;
  }
  EXPECT_TRUE(WIFEXITED(*status)) << test_support::describe_wait_status(*status);
  return WIFEXITED(*status) ? WEXITSTATUS(*status) : -1;
}

class SimulatedAppliance : public ::testing::Test {
 protected:
  void SetUp() override {
    out_ = std::filesystem::temp_directory_path() /
           ("ioct-e2e-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(out_);
    std::filesystem::create_directories(out_);
  }
  void TearDown() override {
    if (!HasFailure()) std::filesystem::remove_all(out_);
  }
  std::filesystem::path out_;
};

struct SurfaceErrors {
  std::size_t ascans = 0;  // rows with both surfaces
  double ilm_mean = 0.0;   // mean |found - truth|, px
  double rpe_mean = 0.0;
};

// surfaces.csv (bscan,ascan,state,confidence,ilm_px,rpe_px,bm_px,...) against the truth.
SurfaceErrors surface_errors(const std::filesystem::path& csv,
                             const sim::SimulatedDigitizer& truth) {
  std::ifstream in(csv);
  if (!in) throw std::runtime_error("cannot open " + csv.string());
  std::string line;
  std::getline(in, line);  // header
  SurfaceErrors e;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::size_t start = 0;
    for (std::size_t comma; (comma = line.find(',', start)) != std::string::npos;
         start = comma + 1) {
      cells.push_back(line.substr(start, comma - start));
    }
    cells.push_back(line.substr(start));
    if (cells.size() < 6 || cells[4].empty() || cells[5].empty()) continue;
    const sim::LayerTruth t = truth.truth_at(static_cast<std::uint32_t>(std::stoul(cells[0])),
                                             static_cast<std::uint32_t>(std::stoul(cells[1])));
    e.ilm_mean += std::abs(std::stod(cells[4]) - t.ilm_px);
    e.rpe_mean += std::abs(std::stod(cells[5]) - t.rpe_px);
    ++e.ascans;
  }
  if (e.ascans > 0) {
    e.ilm_mean /= static_cast<double>(e.ascans);
    e.rpe_mean /= static_cast<double>(e.ascans);
  }
  return e;
}

TEST_F(SimulatedAppliance, BooksBalanceAndTheImageShowsTheRetinaWhereTheTruthIs) {
  const test_support::ScopedShmName ring("e2e");
  const SmallRaster options{ring.str()};
  const auto rt_summary = out_ / "rt-summary.json";

  ChildProcess gpu = ChildProcess::spawn(
      test_support::sibling_executable("ioct-gpu"),
      {"--ring", ring.str(), "--out", out_.string(), "--wait", "20", "--status-interval", "1",
       "--render-width", "320", "--render-height", "240", "--exit-when-producer-gone"});
  // The simulated laser watchdog at 2 s: at --rt-priority 0 on a loaded 2-core machine the safety
  // thread can stall past its 100 ms, which rightly ends scanning with a fault (rt's tests prove
  // that); this test is about the books and the image.
  const auto rt_config = out_ / "rt.toml";
  std::ofstream(rt_config) << "[simulation]\nlaser_watchdog_timeout_ms = 2000\n";
  std::vector<std::string> rt_args = rt_arguments(options, rt_summary.string());
  rt_args.insert(rt_args.end(), {"--config", rt_config.string()});
  ChildProcess rt = ChildProcess::spawn(test_support::sibling_executable("ioct-rt"), rt_args);
  ASSERT_EQ(wait_exit(rt, 60s), 0);
  // ioct-gpu reads what is left in the closed ring, writes its images and summary, exits 0.
  ASSERT_EQ(wait_exit(gpu, 60s), 0);

  const nlohmann::json produced = read_json(rt_summary);
  const nlohmann::json consumed = read_json(out_ / "summary.json");
  const std::uint64_t published = produced.at("groups_published");
  const nlohmann::json& groups = consumed.at("groups");
  const std::uint64_t got = groups.at("consumed");
  const std::uint64_t dropped = groups.at("dropped_lapped").get<std::uint64_t>() +
                                groups.at("dropped_behind").get<std::uint64_t>();
  std::printf(
      "[ stats    ] published %llu, consumed %llu, dropped %llu, volumes %llu\n",
      static_cast<unsigned long long>(published), static_cast<unsigned long long>(got),
      static_cast<unsigned long long>(dropped),
      static_cast<unsigned long long>(consumed.at("volumes").at("completed").get<std::uint64_t>()));
  EXPECT_GT(published, 40u) << "4 s at 20 groups/s; ioct-rt's summary: " << produced.dump();
  EXPECT_EQ(got + dropped, published) << "every published group is consumed or counted dropped";
  EXPECT_EQ(groups.at("processed").get<std::uint64_t>(), got);
  EXPECT_GE(consumed.at("volumes").at("completed").get<std::uint64_t>(), 1u);
  EXPECT_EQ(consumed.at("stop_reason"), "producer_gone");

  // The centre B-scan of the last complete volume, depth downwards: its first bright pixel in
  // each column is the ILM, and the RPE is bright where the truth says.
  const nlohmann::json& images = consumed.at("images");
  ASSERT_TRUE(images.at("complete").get<bool>());
  const gpu::GrayImage bscan = gpu::read_png_gray8(images.at("bscan").get<std::string>());
  ASSERT_EQ(bscan.width, options.ascans);
  ASSERT_EQ(bscan.height, options.samples / 2);
  const std::uint32_t shown = images.at("bscan_shown");

  // The simulator's truth for the same command line ioct-rt was given.
  rt::RtOptions parsed;
  CLI::App app;
  rt::add_rt_options(app, parsed);
  std::vector<std::string> arguments = rt_arguments(options, rt_summary.string());
  std::reverse(arguments.begin(), arguments.end());  // CLI11 takes them last first
  app.parse(arguments);
  const rt::RtSetup setup = rt::make_setup(parsed);
  sim::SimulatedDigitizer truth(setup.simulation);
  truth.prepare(setup.digitizer);
  constexpr std::uint8_t kBright = 128;
  std::uint32_t ilm_hits = 0;
  std::uint32_t rpe_hits = 0;
  for (std::uint32_t x = 0; x < bscan.width; ++x) {
    const sim::LayerTruth t = truth.truth_at(shown, x);
    std::uint32_t first_bright = bscan.height;
    for (std::uint32_t y = 0; y < bscan.height; ++y) {
      if (bscan.at(x, y) >= kBright) {
        first_bright = y;
        break;
      }
    }
    if (std::abs(static_cast<float>(first_bright) - t.ilm_px) <= 2.0f) ++ilm_hits;
    std::uint8_t rpe_peak = 0;
    const int rpe = static_cast<int>(std::lround(t.rpe_px));
    for (int y = std::max(0, rpe - 2); y <= std::min<int>(bscan.height - 1, rpe + 2); ++y) {
      rpe_peak = std::max(rpe_peak, bscan.at(x, static_cast<std::uint32_t>(y)));
    }
    if (rpe_peak >= kBright) ++rpe_hits;
  }
  EXPECT_GE(ilm_hits, bscan.width * 95 / 100) << "columns whose ILM is within 2 px of the truth";
  EXPECT_GE(rpe_hits, bscan.width * 95 / 100) << "columns bright within 2 px of the true RPE";

  // The live stages took every processed group (folded or not), segmented the whole live volume
  // where the truth puts the surfaces, and rendered it.
  const nlohmann::json& stages = consumed.at("stages");
  ASSERT_TRUE(stages.is_object()) << consumed.dump(2);
  EXPECT_EQ(stages.at("problem"), "");
  EXPECT_EQ(stages.at("groups").get<std::uint64_t>(), got);
  EXPECT_GE(stages.at("passes").get<std::uint64_t>(), 1u);
  EXPECT_GE(stages.at("renders").get<std::uint64_t>(), 1u);
  EXPECT_EQ(stages.at("surfaces").at("bscans_with_retina").get<std::uint32_t>(),
            options.bscans_per_volume);
  const SurfaceErrors errors =
      surface_errors(stages.at("files").at("surfaces").get<std::string>(), truth);
  std::printf("[ stats    ] live surfaces: %zu A-scans, ILM mean error %.2f px, RPE %.2f px\n",
              errors.ascans, errors.ilm_mean, errors.rpe_mean);
  EXPECT_EQ(errors.ascans, std::size_t{options.bscans_per_volume} * options.ascans);
  EXPECT_LE(errors.ilm_mean, 1.0) << "px, against the simulator's truth";
  EXPECT_LE(errors.rpe_mean, 1.0) << "px, against the simulator's truth";
  for (const char* file : {"render", "layer-aware", "la-mip", "bscan_overlay"}) {
    const std::filesystem::path png = stages.at("files").at(file).get<std::string>();
    EXPECT_GT(std::filesystem::file_size(png), 1000u) << png;
  }
}

TEST_F(SimulatedAppliance, GpuProcessWaitsForTheRingAndFailsClearlyWhenItNeverComes) {
  const test_support::ScopedShmName ring("e2e-absent");
  ChildProcess gpu =
      ChildProcess::spawn(test_support::sibling_executable("ioct-gpu"),
                          {"--ring", ring.str(), "--out", out_.string(), "--wait", "1"});
  EXPECT_EQ(wait_exit(gpu, 30s), 1);
  EXPECT_FALSE(std::filesystem::exists(out_ / "summary.json"))
      << "no summary that looks like a run when there was none";
}

}  // namespace
}  // namespace ioct::e2e_test
