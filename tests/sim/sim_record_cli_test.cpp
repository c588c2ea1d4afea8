// ioct-sim-record as a process: it writes a recording the reader takes back (groups, injected
// faults, ground truth), refuses bad options with exit status 2 naming them, and never
// overwrites a recording unless asked (exit status 1).
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "ioct/hal/digitizer.hpp"
#include "ioct/recording/recording_reader.hpp"
#include "ioct/test_support/child_process.hpp"

namespace ioct::sim {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using test_support::ChildProcess;

class SimRecordCommand : public testing::Test {
 protected:
  void SetUp() override {
    dir_ =
        fs::temp_directory_path() / ("ioct-sim-record-" + std::to_string(::getpid()) + "-" +
                                     testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }
  int run(std::vector<std::string> arguments) {
    ChildProcess child =
        ChildProcess::spawn(test_support::sibling_executable("ioct-sim-record"), arguments);
    const auto status = child.wait_for(60s);
    if (!status || !WIFEXITED(*status)) {
      ADD_FAILURE() << "ioct-sim-record did not exit normally";
      return -1;
    }
    return WEXITSTATUS(*status);
  }
  std::vector<std::string> small(const std::string& out) {
    return {"--out",
            (dir_ / out).string(),
            "--groups",
            "4",
            "--samples",
            "256",
            "--ascans",
            "32",
            "--flyback",
            "2",
            "--bscans-per-group",
            "2",
            "--timeout-ms",
            "5"};
  }
  fs::path dir_;
};

TEST_F(SimRecordCommand, WritesARecordingWithFaultsAndTruth) {
  std::vector<std::string> args = small("run");
  // The driven galvo's scan is planned within ioct-rt's default limits: 2 flyback sweeps at
  // 100 kHz are refused, 4 at 10 kHz turn the mirrors round in time.
  const auto flyback = std::find(args.begin(), args.end(), "--flyback");
  ASSERT_NE(flyback, args.end());
  std::vector<std::string> refused = args;
  refused.push_back("--bidirectional");
  EXPECT_EQ(run(refused), 2) << "2 flyback sweeps are too few at 100 kHz";
  EXPECT_FALSE(fs::exists(dir_ / "run.json"));
  *std::next(flyback) = "4";
  for (const char* extra : {"--rate", "10000", "--tool", "forceps:x=0.1,depth=0.4,yaw=180,open=15",
                            "--fault", "k_clock_dropout@1-2", "--bidirectional", "--seed", "9"}) {
    args.push_back(extra);
  }
  ASSERT_EQ(run(args), 0);
  const recording::RecordingReader reader(dir_ / "run");
  EXPECT_TRUE(reader.complete());
  ASSERT_EQ(reader.group_count(), 4u);
  EXPECT_TRUE(reader.has_truth());
  EXPECT_EQ(reader.metadata().truth_tools, 1u);
  EXPECT_TRUE(reader.metadata().scan.bidirectional);
  EXPECT_EQ(reader.metadata().acquisition.at("seed"), 9);
  EXPECT_EQ(reader.metadata().producer.rfind("ioct-sim-record", 0), 0u);
  std::vector<std::uint16_t> payload(reader.geometry().samples_per_group());
  recording::RecordedGroupInfo info;
  for (std::uint64_t g = 0; g < 4; ++g) {
    reader.read_group(g, payload, info);
    EXPECT_EQ(info.status, g == 1 || g == 2 ? hal::kGroupClockFault : 0u) << g;
    EXPECT_EQ(info.first_sweep_counter, g * 2 * 36);
    recording::GroupTruth truth;
    reader.read_truth(g, truth);
    EXPECT_EQ(truth.ascans(), 64u);
    EXPECT_EQ(truth.tool_states.size(), 2u);
    // The detection's truth: with the jaws 15 degrees open, the middle of their ends, a little
    // back along the shaft from where the closed jaws would meet (x = 0.1).
    EXPECT_LT(truth.tool_states[0].tip_x, 0.1f);
    EXPECT_GT(truth.tool_states[0].tip_x, 0.09f);
    EXPECT_TRUE(std::isfinite(truth.rpe_px[10]));
  }
}

TEST_F(SimRecordCommand, RefusesBadOptionsAndExistingRecordings) {
  std::vector<std::string> args = small("bad");
  args.insert(args.end(), {"--preset", "lung"});
  EXPECT_EQ(run(args), 2);
  args = small("bad");
  args.insert(args.end(), {"--tool", "forceps:x=9"});
  EXPECT_EQ(run(args), 2);
  args = small("bad");
  args.insert(args.end(), {"--fault", "meteor@1"});
  EXPECT_EQ(run(args), 2);
  args = small("bad");
  args.insert(args.end(), {"--samples", "7"});
  EXPECT_EQ(run(args), 2);
  EXPECT_EQ(run({"--groups", "2"}), 2) << "--out is required";
  EXPECT_FALSE(fs::exists(dir_ / "bad.json"));

  ASSERT_EQ(run(small("once")), 0);
  EXPECT_EQ(run(small("once")), 1) << "an existing recording is kept";
  std::vector<std::string> again = small("once");
  again.push_back("--overwrite");
  EXPECT_EQ(run(again), 0);
}

}  // namespace
}  // namespace ioct::sim
