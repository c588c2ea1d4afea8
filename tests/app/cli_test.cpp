// ioct-gpu as a process: its options, its exit codes, and a whole run against a ring this test
// publishes into, ended by the producer closing the ring or by SIGTERM.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "ioct/gpu/processing/oct_processor.hpp"
#include "live_ring_fixture.hpp"

extern char** environ;

namespace ioct::gpu {
namespace {

namespace fs = std::filesystem;
using testing::LiveRing;
using testing::wait_until;

std::string read_file(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// ioct-gpu in a child process, stdout and stderr into files.
class Child {
 public:
  Child(const fs::path& dir, std::vector<std::string> args, const char* exe = IOCT_GPU_EXE)
      : dir_(dir) {
    args.insert(args.begin(), exe);
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, (dir / "stdout.txt").c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, (dir / "stderr.txt").c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int rc = posix_spawn(&pid_, argv[0], &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (rc != 0) pid_ = -1;
  }
  ~Child() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }

  bool started() const { return pid_ > 0; }
  void signal(int number) const { ::kill(pid_, number); }

  // The exit status, or -1 when it did not exit within the timeout (it is then killed).
  int wait_exit(std::chrono::seconds timeout = std::chrono::seconds(30)) {
    int status = 0;
    const bool exited = wait_until([&] { return ::waitpid(pid_, &status, WNOHANG) == pid_; },
                                   std::chrono::duration_cast<std::chrono::milliseconds>(timeout));
    if (!exited) return -1;
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  std::string out() const { return read_file(dir_ / "stdout.txt"); }
  std::string err() const { return read_file(dir_ / "stderr.txt"); }

 private:
  fs::path dir_;
  pid_t pid_ = -1;
};

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("ioct-gpu-cli-test-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Runs ioct-gpu (or `exe`) to completion; returns its exit status.
  int run(const std::vector<std::string>& args, std::string* err = nullptr,
          const char* exe = IOCT_GPU_EXE, std::string* out = nullptr) {
    Child child(dir_, args, exe);
    EXPECT_TRUE(child.started());
    const int status = child.wait_exit();
    if (err != nullptr) *err = child.err();
    if (out != nullptr) *out = child.out();
    return status;
  }

  // The consumed count the running ioct-gpu reports to the producer, or -1 before it attached.
  static long consumed_by_ioct_gpu(LiveRing& ring) {
    for (const shm::ReaderReport& r : ring.writer().readers()) {
      if (r.label == "ioct-gpu" && r.alive) return static_cast<long>(r.counters.consumed);
    }
    return -1;
  }

  fs::path dir_;
};

TEST_F(Cli, BadOptionsExitNonZeroWithAClearMessage) {
  std::string err;
  if (const std::optional<std::string> reason = cuda_unavailable_reason()) {
    // No usable CUDA here (this build, or this machine): asking for it is refused, saying why.
    EXPECT_EQ(run({"--backend", "cuda"}, &err), 2);
    EXPECT_NE(err.find(*reason), std::string::npos) << err;
  }
  EXPECT_EQ(run({"--backend", "opencl"}, &err), 2);
  EXPECT_NE(err.find("processing.backend = \"opencl\": must be one of auto, cpu, cuda"),
            std::string::npos)
      << err;
  EXPECT_EQ(run({"--db-min", "50", "--db-max", "40"}, &err), 2);
  EXPECT_NE(err.find("db_max = 40"), std::string::npos) << err;
  EXPECT_EQ(run({"--threads", "0"}, &err), 2);
  EXPECT_NE(err.find("processing.threads = 0: must be in [1, 16] (option --threads)"),
            std::string::npos)
      << err;
  EXPECT_NE(run({"--threads", "many"}, &err), 0);
  EXPECT_NE(err.find("--threads"), std::string::npos) << err;
  EXPECT_NE(run({"--no-such-option"}, &err), 0);
  const std::string absent = "ioct-gtest-gpu-absent-" + std::to_string(::getpid());
  EXPECT_EQ(run({"--ring", absent, "--out", (dir_ / "o").string(), "--wait", "0.1"}, &err), 1);
  EXPECT_NE(err.find(absent), std::string::npos) << err;
  // The live view's options.
  EXPECT_EQ(run({"--frame-rate", "0"}, &err), 2);
  EXPECT_NE(err.find("stages.frame_rate_hz = 0: must be in [0.1, 1000]"), std::string::npos) << err;
  EXPECT_EQ(run({"--frames", "a/b"}, &err), 2);
  EXPECT_NE(err.find("view.frames = 'a/b'"), std::string::npos) << err;
  EXPECT_NE(err.find("(option --frames)"), std::string::npos) << err;
  EXPECT_EQ(run({"--no-stages", "--view-socket", (dir_ / "view.sock").string()}, &err), 2);
  EXPECT_NE(err.find("view-socket"), std::string::npos) << err;
  std::ofstream(dir_ / "not-a-socket") << "x";
  EXPECT_EQ(run({"--ring", absent, "--out", (dir_ / "o").string(), "--wait", "0.1", "--view-socket",
                 (dir_ / "not-a-socket").string()},
                &err),
            1);
  EXPECT_NE(err.find("not a socket"), std::string::npos) << err;
}

TEST_F(Cli, ProcessesARingUntilTheProducerClosesIt) {
  LiveRing ring;
  ring.create();
  const fs::path out = dir_ / "out";
  Child child(
      dir_, {"--ring", ring.name(), "--out", out.string(), "--wait", "10", "--threads", "2",
             "--fft-rigor", "estimate", "--status-interval", "0.05", "--exit-when-producer-gone"});
  ASSERT_TRUE(child.started());
  ASSERT_TRUE(wait_until([&] { return consumed_by_ioct_gpu(ring) == 0; })) << child.err();
  long published = 0;
  for (std::uint64_t volume = 0; volume < 2; ++volume) {
    for (std::uint32_t first = 0; first < 8; first += 4) {
      ring.publish(volume, first);
      ++published;
      ASSERT_TRUE(wait_until([&] { return consumed_by_ioct_gpu(ring) == published; }));
    }
  }
  // The copy is counted before the group is processed, but ioct-gpu finishes processing it
  // before it polls again and sees the ring closed.
  ring.close();
  ASSERT_EQ(child.wait_exit(), 0) << child.err();

  EXPECT_NE(child.err().find("groups/s"), std::string::npos) << child.err();
  // The default backend is auto: CUDA where it can run, else the CPU and one warning saying why.
  const std::optional<std::string> reason = cuda_unavailable_reason();
  const std::string err = child.err();
  const std::size_t warning = err.find("warning: backend auto: using the CPU");
  if (reason) {
    EXPECT_NE(warning, std::string::npos) << err;
    EXPECT_EQ(err.find("warning", warning + 1), std::string::npos)
        << "more than one warning: " << err;
    EXPECT_NE(err.find(*reason), std::string::npos) << err;
  } else {
    EXPECT_EQ(warning, std::string::npos) << err;
  }
  EXPECT_NE(child.out().find((fs::absolute(out) / "bscan.png").string()), std::string::npos)
      << child.out();
  const nlohmann::json j = nlohmann::json::parse(read_file(out / "summary.json"));
  EXPECT_EQ(j["stop_reason"], "producer_gone");
  EXPECT_EQ(j["backend"], reason ? "cpu" : "cuda");
  EXPECT_EQ(j["groups"]["processed"], 4);
  EXPECT_EQ(j["volumes"]["completed"], 2);
  EXPECT_EQ(j["images"]["volume_index"], 1);
  EXPECT_TRUE(fs::exists(out / "bscan.png"));
  EXPECT_TRUE(fs::exists(out / "enface.png"));
}

TEST_F(Cli, SigtermEndsTheRunWithASummary) {
  LiveRing ring;
  ring.create();
  const fs::path out = dir_ / "out";
  Child child(dir_, {"--ring", ring.name(), "--out", out.string(), "--wait", "10", "--fft-rigor",
                     "estimate", "--status-interval", "0"});
  ASSERT_TRUE(child.started());
  ASSERT_TRUE(wait_until([&] { return consumed_by_ioct_gpu(ring) == 0; })) << child.err();
  child.signal(SIGTERM);
  ASSERT_EQ(child.wait_exit(), 0) << child.err();
  const nlohmann::json j = nlohmann::json::parse(read_file(out / "summary.json"));
  EXPECT_EQ(j["stop_reason"], "stop_requested");
  EXPECT_EQ(j["groups"]["consumed"], 0);
}

// Issue F9: a service must survive a restart of ioct-rt. Without --exit-when-producer-gone,
// ioct-gpu says it waits when the ring closes, keeps running, and reads the new ring.
TEST_F(Cli, WaitsWhenTheProducerGoesAndReattachesWhenItComesBack) {
  LiveRing ring;
  ring.create();
  const fs::path out = dir_ / "out";
  Child child(dir_, {"--ring", ring.name(), "--out", out.string(), "--wait", "10", "--fft-rigor",
                     "estimate", "--status-interval", "0.05", "--no-stages"});
  ASSERT_TRUE(child.started());
  ASSERT_TRUE(wait_until([&] { return consumed_by_ioct_gpu(ring) == 0; })) << child.err();
  ring.publish(0, 0);
  ASSERT_TRUE(wait_until([&] { return consumed_by_ioct_gpu(ring) == 1; })) << child.err();
  ring.close();
  ASSERT_TRUE(wait_until([&] {
    return child.err().find("waiting for it to come back") != std::string::npos;
  })) << child.err();
  EXPECT_TRUE(wait_until([&] {
    return child.err().find("waiting for the producer (NO SIGNAL)") != std::string::npos;
  })) << "the wait is stated on the status line: "
      << child.err();
  EXPECT_EQ(child.wait_exit(std::chrono::seconds(1)), -1) << "it must not exit: " << child.err();
  ring.create();  // the producer restarted
  ASSERT_TRUE(wait_until([&] { return consumed_by_ioct_gpu(ring) == 0; }))
      << "reattached: " << child.err();
  ring.publish(0, 0);
  ring.publish(0, 4);
  ASSERT_TRUE(wait_until([&] { return consumed_by_ioct_gpu(ring) == 2; })) << child.err();
  child.signal(SIGTERM);
  ASSERT_EQ(child.wait_exit(), 0) << child.err();
  const nlohmann::json j = nlohmann::json::parse(read_file(out / "summary.json"));
  EXPECT_EQ(j["stop_reason"], "stop_requested");
  EXPECT_EQ(j["groups"]["consumed"], 2) << "the summary describes the last attachment";
}

TEST_F(Cli, DispersionEstimatesC2AndC3FromAGroupFile) {
  // 4 B-scans x 32 A-scans x 1024 samples, three layers dispersed by c2 = 30, c3 = -8.
  shm::RingGeometry g;
  g.samples_per_ascan = 1024;
  g.ascans_per_bscan = 32;
  g.bscans_per_group = 4;
  testing::SpectrumModel model{.samples = 1024, .noise_sigma = 2.0};
  model.c2 = 30.0;
  model.c3 = -8.0;
  testing::SpectrumSynthesizer synthesizer(model, 21);
  std::vector<std::uint16_t> payload(g.group_payload_bytes() / 2);
  testing::fill_group(
      g, synthesizer,
      [](std::uint32_t b, std::uint32_t) {
        return std::vector<testing::Reflector>{{150.0 + 5 * b, 30.0}, {400.0, 20.0}};
      },
      payload);
  const fs::path group = dir_ / "group.u16";
  std::ofstream(group, std::ios::binary)
      .write(reinterpret_cast<const char*>(payload.data()),
             static_cast<std::streamsize>(payload.size() * 2));

  std::string err;
  std::string out;
  const fs::path json = dir_ / "dispersion.json";
  ASSERT_EQ(run({"--group-file", group.string(), "--samples", "1024", "--ascans-per-bscan", "32",
                 "--ascans", "64", "--json", json.string()},
                &err, IOCT_DISPERSION_EXE, &out),
            0)
      << err;
  EXPECT_NE(out.find("--dispersion-c2"), std::string::npos) << out;
  const nlohmann::json j = nlohmann::json::parse(read_file(json));
  EXPECT_NEAR(j["c2"].get<double>(), 30.0, 2.0) << out;
  EXPECT_NEAR(j["c3"].get<double>(), -8.0, 2.0) << out;
  EXPECT_GT(j["sharpness"].get<double>(), j["sharpness_uncompensated"].get<double>());
  // Checked on the processed volume, both figures reported, the estimate kept.
  EXPECT_NE(out.find("processed volume, standard sharpness"), std::string::npos) << out;
  EXPECT_NE(out.find("estimate kept"), std::string::npos) << out;
  EXPECT_TRUE(j["checked"].get<bool>());
  EXPECT_FALSE(j["rejected"].get<bool>());
  EXPECT_GT(j["processed_sharpness"].get<double>(),
            j["processed_sharpness_uncompensated"].get<double>());
  EXPECT_EQ(j["searched_c2"].get<double>(), j["c2"].get<double>());

  // Bad input: no source, a file that is not whole B-scans, a bad calibration.
  EXPECT_EQ(run({}, &err, IOCT_DISPERSION_EXE), 2);
  EXPECT_NE(err.find("--group-file or --ring"), std::string::npos) << err;
  EXPECT_EQ(run({"--group-file", group.string(), "--samples", "1000"}, &err, IOCT_DISPERSION_EXE),
            2);
  EXPECT_NE(err.find("group_file"), std::string::npos) << err;
  EXPECT_EQ(run({"--group-file", group.string(), "--samples", "1024", "--ascans-per-bscan", "32",
                 "--resample", "linear", "--resample-poly", "0,nan"},
                &err, IOCT_DISPERSION_EXE),
            2);
  EXPECT_NE(err.find("resampling_coefficients"), std::string::npos) << err;
  EXPECT_EQ(run({"--group-file", group.string(), "--samples", "1024", "--ascans-per-bscan", "32",
                 "--fixed-coherence", "1.5"},
                &err, IOCT_DISPERSION_EXE),
            2);
  EXPECT_NE(err.find("fixed_coherence"), std::string::npos) << err;
}

TEST_F(Cli, DispersionResamplesAsIoctProcessWhenGivenACalibration) {
  // A lambda-linear sweep without dispersion, and the calibration that makes it k-linear. Given
  // only the calibration, ioct-dispersion resamples (cubic), as ioct-process does, and finds no
  // dispersion; told not to resample, it would "compensate" the sampling with a large c2 and
  // says so.
  const std::vector<double> calibration{0.0, 0.9, 0.14, -0.04};
  shm::RingGeometry g;
  g.samples_per_ascan = 1024;
  g.ascans_per_bscan = 64;
  g.bscans_per_group = 2;
  testing::SpectrumModel model{.samples = 1024, .noise_sigma = 2.0};
  model.k_of_sample = testing::k_of_raw_samples(calibration, 1024);
  testing::SpectrumSynthesizer synthesizer(model, 23);
  std::vector<std::uint16_t> payload(g.group_payload_bytes() / 2);
  testing::fill_group(
      g, synthesizer,
      [](std::uint32_t, std::uint32_t a) {
        return std::vector<testing::Reflector>{{250.0 + a % 7, 20.0}, {330.0, 15.0}};
      },
      payload);
  const fs::path group = dir_ / "lambda_linear.u16";
  std::ofstream(group, std::ios::binary)
      .write(reinterpret_cast<const char*>(payload.data()),
             static_cast<std::streamsize>(payload.size() * 2));
  const std::vector<std::string> common{"--group-file",       group.string(), "--samples", "1024",
                                        "--ascans-per-bscan", "64",           "--ascans",  "64"};
  const fs::path calibration_file = dir_ / "calibration.txt";
  std::ofstream(calibration_file) << "# lambda -> k\n0 0.9\n0.14 -0.04\n";

  std::string err;
  std::string out;
  const fs::path json = dir_ / "resampled.json";
  std::vector<std::string> args = common;
  args.insert(args.end(),
              {"--calibration-file", calibration_file.string(), "--json", json.string()});
  ASSERT_EQ(run(args, &err, IOCT_DISPERSION_EXE, &out), 0) << err;
  const nlohmann::json resampled = nlohmann::json::parse(read_file(json));
  EXPECT_EQ(resampled["resampling"], "cubic") << out;
  EXPECT_EQ(resampled["resampling_coefficients"], calibration) << out;
  EXPECT_NEAR(resampled["searched_c2"].get<double>(), 0.0, 1.0) << out;
  EXPECT_NEAR(resampled["searched_c3"].get<double>(), 0.0, 1.0) << out;
  EXPECT_FALSE(resampled["depth_dependent"].get<bool>()) << out;

  const fs::path raw_json = dir_ / "not_resampled.json";
  args = common;
  args.insert(args.end(), {"--resample", "none", "--json", raw_json.string()});
  ASSERT_EQ(run(args, &err, IOCT_DISPERSION_EXE, &out), 0) << err;
  EXPECT_GT(std::abs(nlohmann::json::parse(read_file(raw_json))["searched_c2"].get<double>()), 10.0)
      << out;
  EXPECT_NE(out.find("compensates the sampling"), std::string::npos) << out;
  // The "dispersion" it finds grows with depth, and it warns.
  const nlohmann::json raw = nlohmann::json::parse(read_file(raw_json));
  EXPECT_TRUE(raw["depth_dependent"].get<bool>()) << out;
  EXPECT_GT(raw["depth_split"].get<int>(), 253) << out;
  EXPECT_LT(raw["depth_split"].get<int>(), 331) << out;
  EXPECT_NE(out.find("the best c2 depends on depth"), std::string::npos) << out;

  // Resampling without a calibration is refused, as by ioct-process.
  args = common;
  args.insert(args.end(), {"--resample", "cubic"});
  EXPECT_EQ(run(args, &err, IOCT_DISPERSION_EXE), 2);
  EXPECT_NE(err.find("needs a calibration"), std::string::npos) << err;
}

}  // namespace
}  // namespace ioct::gpu
