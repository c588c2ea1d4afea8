// End to end through a real ring: this test is the producer, LiveProcessor runs in a thread.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <exception>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <regex>
#include <string>
#include <thread>

#include "ioct/gpu/ingest/live_processor.hpp"
#include "ioct/gpu/volume/png_file.hpp"
#include "ioct/shm/ring_error.hpp"
#include "live_ring_fixture.hpp"

namespace ioct::gpu {
namespace {

namespace fs = std::filesystem;
using testing::LiveRing;
using testing::wait_until;

}  // namespace

void PrintTo(Backend backend, std::ostream* out) {
  *out << to_string(backend);
}

namespace {

// Every test runs on both backends; the CUDA one where a usable GPU is present.
class LiveProcessorTest : public ::testing::TestWithParam<Backend> {
 protected:
  void SetUp() override {
    if (GetParam() == Backend::cuda) {
      if (const std::optional<std::string> reason = cuda_unavailable_reason()) {
        GTEST_SKIP() << "cuda backend not tested: " << *reason;
      }
    }
    out_dir_ = fs::temp_directory_path() /
               ("ioct-gpu-live-test-" + std::to_string(::getpid()) + "-" +
                std::regex_replace(::testing::UnitTest::GetInstance()->current_test_info()->name(),
                                   std::regex("/"), "-"));
    fs::remove_all(out_dir_);
  }
  void TearDown() override {
    if (!out_dir_.empty()) fs::remove_all(out_dir_);
  }

  LiveConfig config_for(const LiveRing& ring) const {
    LiveConfig config;
    config.ring_name = ring.name();
    config.out_dir = out_dir_;
    config.backend = GetParam();
    config.processing.fft.rigor = FftRigor::estimate;
    config.processing.threads = 2;
    config.wait_s = 20.0;
    config.exit_when_producer_gone = true;  // each test ends with its ring
    config.status_interval_s = 0.0;
    config.poll_interval_s = 1e-4;
    return config;
  }

  // Runs `processor` in a thread; join() returns its summary or rethrows its error.
  class Runner {
   public:
    explicit Runner(LiveProcessor& processor)
        : thread_([this, &processor] {
            try {
              summary_ = processor.run();
            } catch (...) {
              error_ = std::current_exception();
            }
          }) {}
    ~Runner() {
      if (thread_.joinable()) thread_.join();
    }
    RunSummary join() {
      thread_.join();
      if (error_) std::rethrow_exception(error_);
      return summary_;
    }

   private:
    RunSummary summary_;
    std::exception_ptr error_;
    std::thread thread_;
  };

  fs::path out_dir_;
};

TEST_P(LiveProcessorTest, BuildsVolumesFromTheRingAndWritesImagesAndSummary) {
  LiveRing ring;
  LiveProcessor processor(config_for(ring));
  std::vector<Volume> volumes;
  std::vector<VolumeInfo> infos;
  processor.set_volume_observer([&](const Volume& v, const VolumeInfo& info) {
    volumes.push_back(v);
    infos.push_back(info);
  });
  Runner runner(processor);  // waits for the ring to appear
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ring.create();
  ASSERT_TRUE(wait_until([&] { return processor.attached(); }));

  std::uint64_t published = 0;
  for (std::uint64_t volume = 0; volume < 2; ++volume) {
    for (std::uint32_t first = 0; first < 8; first += 4) {
      ring.publish(volume, first);
      ++published;
      ASSERT_TRUE(wait_until([&] { return processor.groups_consumed() == published; }));
    }
  }
  ring.close();
  const RunSummary summary = runner.join();

  EXPECT_EQ(summary.stop_reason, StopReason::producer_gone);
  const LiveCounters& c = summary.counters;
  EXPECT_EQ(c.groups_consumed, 4u);
  EXPECT_EQ(c.groups_processed, 4u);
  EXPECT_EQ(c.dropped(), 0u);
  EXPECT_EQ(c.groups_rejected, 0u);
  EXPECT_EQ(c.volumes_completed, 2u);
  EXPECT_EQ(c.volumes_with_gaps, 0u);
  EXPECT_EQ(c.volumes_abandoned, 0u);
  // Each volume's bscan.png and enface.png, written or (on the image writer's thread, latest
  // wins) replaced by the next volume's before their turn; the last volume's are on disk.
  EXPECT_EQ(c.images_written + c.images_replaced, 4u);
  EXPECT_GE(c.images_written, 2u);
  EXPECT_EQ(c.image_errors, 0u);
  EXPECT_EQ(summary.latency.count(), 4u);
  EXPECT_GT(summary.latency.quantile(0.5), 0u);
  EXPECT_EQ(summary.status_flags_seen, shm::kStatusSimulated | shm::kStatusLaserOn);

  // Every reflector at its place: B-scans by marker, A-scans flipped back on odd B-scans.
  ASSERT_EQ(volumes.size(), 2u);
  for (std::uint64_t v = 0; v < 2; ++v) {
    EXPECT_EQ(infos[v].volume_index, v);
    EXPECT_TRUE(infos[v].complete());
    const Volume& volume = volumes[v];
    ASSERT_EQ(volume.bscans(), 8u);
    ASSERT_EQ(volume.ascans(), testing::kActiveWidth);
    ASSERT_EQ(volume.depth(), 128u);
    for (std::uint32_t b = 0; b < volume.bscans(); ++b) {
      for (std::uint32_t a = 0; a < volume.ascans(); ++a) {
        const auto line = volume.bscan(b).subspan(std::size_t{a} * volume.depth(), volume.depth());
        const auto peak = std::ranges::max_element(line) - line.begin();
        EXPECT_NEAR(static_cast<double>(peak), testing::reflector_depth(v, b, a), 1.0)
            << "volume " << v << " B-scan " << b << " A-scan " << a;
        EXPECT_GT(*std::ranges::max_element(line), 150);
      }
    }
  }

  // The files show the last volume.
  ASSERT_TRUE(summary.images);
  EXPECT_EQ(summary.images->volume.volume_index, 1u);
  EXPECT_EQ(summary.images->bscan_shown, 4u);
  const GrayImage bscan = read_png_gray8(out_dir_ / "bscan.png");
  const GrayImage expected_bscan = bscan_image(volumes[1], 4);
  EXPECT_EQ(bscan.width, testing::kActiveWidth);
  EXPECT_EQ(bscan.height, 128u);
  EXPECT_EQ(bscan.pixels, expected_bscan.pixels);
  const GrayImage enface = read_png_gray8(out_dir_ / "enface.png");
  EXPECT_EQ(enface.width, testing::kActiveWidth);
  EXPECT_EQ(enface.height, 8u);
  EXPECT_EQ(enface.pixels, enface_image(volumes[1], EnfaceProjection::mean).pixels);

  std::ifstream file(out_dir_ / "summary.json");
  const nlohmann::json j = nlohmann::json::parse(file);
  EXPECT_EQ(j["stop_reason"], "producer_gone");
  EXPECT_EQ(j["groups"]["consumed"], 4);
  EXPECT_EQ(j["volumes"]["completed"], 2);
  EXPECT_EQ(j["latency_ms"]["count"], 4);
  EXPECT_GT(j["latency_ms"]["p99"].get<double>(), 0.0);
  EXPECT_EQ(j["images"]["bscan"], fs::absolute(out_dir_ / "bscan.png").string());
  EXPECT_EQ(j["images"]["volume_index"], 1);
  EXPECT_EQ(j["status_flags_seen"], (nlohmann::json{"laser_on", "simulated"}));

  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(out_dir_)) names.push_back(e.path().filename());
  std::ranges::sort(names);
  EXPECT_EQ(names, (std::vector<std::string>{"bscan.png", "enface.png", "summary.json"}));
}

TEST_P(LiveProcessorTest, RejectedGroupsAndLostVolumeEndsAreCountedNotShown) {
  LiveRing ring;
  ring.create();
  LiveProcessor processor(config_for(ring));
  std::vector<VolumeInfo> infos;
  processor.set_volume_observer([&](const Volume&, const VolumeInfo& i) { infos.push_back(i); });
  Runner runner(processor);
  ASSERT_TRUE(wait_until([&] { return processor.attached(); }));

  ring.publish(0, 0);
  ASSERT_TRUE(wait_until([&] { return processor.groups_consumed() == 1; }));
  // The group holding volume 0's end has an active range past the records: rejected.
  ring.publish(0, 4, [](shm::SlotHeader& h) { h.active_ascan_end = 25; });
  ASSERT_TRUE(wait_until([&] { return processor.groups_consumed() == 2; }));
  ring.publish(1, 0);
  ASSERT_TRUE(wait_until([&] { return processor.groups_consumed() == 3; }));
  ring.publish(1, 4);
  ASSERT_TRUE(wait_until([&] { return processor.groups_consumed() == 4; }));
  ring.close();
  const RunSummary summary = runner.join();

  EXPECT_EQ(summary.counters.groups_consumed, 4u);
  EXPECT_EQ(summary.counters.groups_rejected, 1u);
  EXPECT_EQ(summary.counters.groups_processed, 3u);
  EXPECT_EQ(summary.counters.volumes_abandoned, 1u);
  EXPECT_EQ(summary.counters.volumes_completed, 1u);
  ASSERT_EQ(infos.size(), 1u);
  EXPECT_EQ(infos[0].volume_index, 1u);
  EXPECT_NE(summary.last_problem.find("active A-scans [2, 25)"), std::string::npos)
      << summary.last_problem;
}

TEST_P(LiveProcessorTest, ShowsAPartialVolumeWhenNoneCompleted) {
  LiveRing ring;
  ring.create();
  LiveProcessor processor(config_for(ring));
  Runner runner(processor);
  ASSERT_TRUE(wait_until([&] { return processor.attached(); }));
  ring.publish(3, 4);  // the second half of volume 3 only
  ASSERT_TRUE(wait_until([&] { return processor.groups_consumed() == 1; }));
  ring.close();
  const RunSummary summary = runner.join();
  ASSERT_TRUE(summary.images);
  EXPECT_FALSE(summary.images->volume.complete());
  EXPECT_EQ(summary.images->volume.bscans_missing, 4u);
  // The centre B-scan (4) arrived; the first rows of the en face (B-scans 0..3) are zeroed.
  const GrayImage enface = read_png_gray8(out_dir_ / "enface.png");
  for (std::uint32_t x = 0; x < enface.width; ++x) EXPECT_EQ(enface.at(x, 0), 0);
  const GrayImage bscan = read_png_gray8(out_dir_ / "bscan.png");
  EXPECT_GT(*std::ranges::max_element(bscan.pixels), 150);
}

TEST_P(LiveProcessorTest, StopsAtTheTimeLimitOrOnRequest) {
  LiveRing ring;
  ring.create();
  LiveConfig config = config_for(ring);
  config.run_s = 0.3;
  LiveProcessor timed(config);
  const RunSummary summary = timed.run();
  EXPECT_EQ(summary.stop_reason, StopReason::time_limit);
  EXPECT_GE(summary.seconds, 0.3);
  EXPECT_FALSE(summary.images);
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(out_dir_ / "summary.json"));
  EXPECT_EQ(j["stop_reason"], "time_limit");
  EXPECT_TRUE(j["images"].is_null());

  // Waiting for a ring that never comes, then asked to stop.
  config = config_for(ring);
  config.ring_name += "-absent";
  config.wait_s = 60.0;
  LiveProcessor waiting(config);
  Runner runner(waiting);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  waiting.request_stop();
  const RunSummary stopped = runner.join();
  EXPECT_EQ(stopped.stop_reason, StopReason::stop_requested);
  EXPECT_FALSE(stopped.geometry);
}

TEST_P(LiveProcessorTest, ARingThatNeverAppearsIsAnErrorNamingIt) {
  LiveRing ring;  // never created
  LiveConfig config = config_for(ring);
  config.wait_s = 0.1;
  LiveProcessor processor(config);
  try {
    (void)processor.run();
    FAIL() << "ran without a ring";
  } catch (const shm::RingError& e) {
    EXPECT_EQ(e.code(), shm::RingErrc::not_found);
    EXPECT_NE(std::string(e.what()).find(ring.name()), std::string::npos) << e.what();
  }
}

TEST_P(LiveProcessorTest, AnOutputDirectoryThatCannotBeMadeIsAnErrorNamingIt) {
  LiveRing ring;
  ring.create();
  fs::create_directories(out_dir_);
  std::ofstream(out_dir_ / "file") << "in the way";
  LiveConfig config = config_for(ring);
  config.out_dir = out_dir_ / "file" / "out";
  LiveProcessor processor(config);
  try {
    (void)processor.run();
    FAIL() << "ran without an output directory";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(config.out_dir.string()), std::string::npos) << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(Backends, LiveProcessorTest,
                         ::testing::Values(Backend::cpu, Backend::cuda),
                         [](const ::testing::TestParamInfo<Backend>& p) {
                           return std::string(to_string(p.param));
                         });

}  // namespace
}  // namespace ioct::gpu
