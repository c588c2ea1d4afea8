// The stages' frames as ioct-view reads them from the frame ring (CPU path): each frame carries
// its group's index and timestamps; a parameter change, the auto-rotation and a private view each
// bring new frames without a new group; the status and the heartbeat are kept current.
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "decoded_jpeg.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/gpu/live_stages/volume_stages.hpp"
#include "ioct/shm/frame_ring.hpp"
#include "ioct/test_support/eventually.hpp"
#include "live_volumes.hpp"

namespace ioct::gpu::live {
namespace {

// Mean absolute difference per channel of two pictures of one size.
double difference(const DecodedJpeg& a, const DecodedJpeg& b) {
  return mean_abs_difference(a.pixels, b.pixels);
}

class LiveFramesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    config_.backend = Backend::cpu;
    config_.cpu_threads = 2;
    config_.render.view.output_width = 96;
    config_.render.view.output_height = 72;
    config_.render.view.auto_rotate = false;
    config_.cpu_render_interval_s = 0.0;
    config_.cpu_moving_scale = 0.5;  // moving frames 48x36
    config_.nice = 0;
    config_.frame_ring = "ioct-test-frames-" + std::to_string(::getpid()) + "-" +
                         ::testing::UnitTest::GetInstance()->current_test_info()->name();
    live_.volume = layered_volume(32, 96, 256, 11);
  }

  // Frames until `accept` takes one (true) or 20 s pass.
  bool wait_for_frame(shm::FrameRingReader& reader, shm::Frame& frame,
                      const std::function<bool(const shm::Frame&)>& accept) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (std::chrono::steady_clock::now() < deadline) {
      if (reader.read_next(frame)) {
        if (accept(frame)) return true;
      } else {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
      }
    }
    return false;
  }

  GroupStamp stamp(std::uint64_t group) const {
    GroupStamp s;
    s.group_index = group;
    s.volume_index = 3;
    s.t_published_ns = 1'000'000'000ull * group;
    s.t_processed_ns = s.t_published_ns + 500'000;
    s.ingest_ns = 1'234;
    s.groups_consumed = group + 1;
    s.groups_dropped = 2;
    s.volumes_completed = 1;
    return s;
  }

  VolumeStagesConfig config_;
  FakeLiveVolume live_;
};

TEST_F(LiveFramesTest, FramesCarryTheirGroupAndAThresholdChangesTheNextFrame) {
  VolumeStages stages(config_);
  shm::FrameRingReader reader = shm::FrameRingReader::attach(config_.frame_ring);
  stages.on_bscans(live_, 0, 32, stamp(5));

  shm::Frame frame;
  ASSERT_TRUE(
      wait_for_frame(reader, frame, [](const shm::Frame& f) { return f.meta.group_index == 5; }));
  const shm::FrameMeta& m = frame.meta;
  EXPECT_EQ(m.view_id, 0u);
  EXPECT_EQ(m.volume_index, 3u);
  EXPECT_EQ(m.t_group_published_ns, 5'000'000'000ull);
  EXPECT_EQ(m.t_group_processed_ns, 5'000'500'000ull);
  EXPECT_GE(m.t_rendered_ns, m.t_group_processed_ns);
  EXPECT_GE(m.t_written_ns, m.t_rendered_ns);
  EXPECT_EQ(m.format, static_cast<std::uint32_t>(shm::FrameFormat::jpeg));
  EXPECT_EQ(m.width, 96u);
  EXPECT_EQ(m.height, 72u);
  EXPECT_EQ(m.stereo, 0u);
  EXPECT_STREQ(m.mode, "enhanced");
  EXPECT_EQ(m.bscans, 32u);
  EXPECT_EQ(m.bscan_index, 16u);  // slice.bscan -1: the centre
  EXPECT_EQ(m.bscan_width, 96u);
  EXPECT_EQ(m.bscan_height, 256u);
  const DecodedJpeg before = decode_jpeg(frame.render());
  ASSERT_EQ(before.width, 96);
  ASSERT_EQ(before.height, 72);
  const DecodedJpeg bscan = decode_jpeg(frame.bscan());
  EXPECT_EQ(bscan.width, 96);
  EXPECT_EQ(bscan.height, 256);

  shm::FrameRingStatus status{};
  ASSERT_TRUE(reader.read_status(status));
  EXPECT_EQ(status.source_state, static_cast<std::uint64_t>(shm::SourceState::live));
  EXPECT_EQ(status.last_group_index, 5u);
  EXPECT_EQ(status.last_group_published_ns, 5'000'000'000ull);
  EXPECT_EQ(status.groups_consumed, 6u);
  EXPECT_EQ(status.groups_dropped, 2u);
  // The figures behind /metrics: the group's publish -> processed latency as its stamp gives it,
  // its ingest time, and the pass that rendered this frame (timed before the frame went out); no
  // device memory on the CPU.
  EXPECT_EQ(status.published_to_processed.count, 1u);
  EXPECT_EQ(status.published_to_processed.sum_ns, 500'000u);
  EXPECT_EQ(status.published_to_processed.counts[2], 1u) << "0.5 ms: the bucket up to 0.5 ms";
  EXPECT_EQ(status.ingest.count, 1u);
  EXPECT_EQ(status.ingest.sum_ns, 1'234u);
  EXPECT_EQ(status.filter.count, status.passes);
  EXPECT_EQ(status.segmentation.count, status.passes);
  EXPECT_GE(status.passes, 1u);
  EXPECT_GE(status.render.count, 1u);
  EXPECT_EQ(status.published_to_rendered.count, status.passes) << "every CPU pass so far rendered";
  EXPECT_EQ(status.device_memory_known, 0u);

  // No new group: the change alone brings the next frames (on the CPU small at first, as the
  // view counts as moving just after a change, then full size), and they look different.
  const std::uint64_t generation = stages.set_params({{"enhanced", {{"threshold", 0.6}}}});
  ASSERT_TRUE(wait_for_frame(reader, frame, [&](const shm::Frame& f) {
    return f.meta.params_generation >= generation && f.meta.width == 96;
  }));
  EXPECT_EQ(frame.meta.group_index, 5u);
  const DecodedJpeg after = decode_jpeg(frame.render());
  EXPECT_GT(difference(before, after), 1.0) << "the threshold changed nothing visible";

  // A slice position moves the B-scan.
  stages.set_params({{"slice", {{"bscan", 4}}}});
  ASSERT_TRUE(
      wait_for_frame(reader, frame, [](const shm::Frame& f) { return f.meta.bscan_index == 4; }));

  const nlohmann::json summary = stages.finish(::testing::TempDir());
  EXPECT_EQ(summary.at("frame_errors"), 0);
  EXPECT_GE(summary.at("frames_published").get<int>(), 3);
  EXPECT_FALSE(reader.health().alive) << "closed at the end";
}

TEST_F(LiveFramesTest, AutoRotationBringsNewFramesWithoutNewGroups) {
  config_.render.view.auto_rotate = true;
  config_.render.view.rotation_deg_per_s = 90.0;
  config_.frame_rate_hz = 20.0;
  VolumeStages stages(config_);
  shm::FrameRingReader reader = shm::FrameRingReader::attach(config_.frame_ring);
  stages.on_bscans(live_, 0, 32, stamp(8));
  shm::Frame frame;
  ASSERT_TRUE(
      wait_for_frame(reader, frame, [](const shm::Frame& f) { return f.meta.group_index == 8; }));
  // On the CPU a moving view renders at half size.
  std::vector<DecodedJpeg> pictures;
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(wait_for_frame(reader, frame, [](const shm::Frame&) { return true; }));
    EXPECT_EQ(frame.meta.group_index, 8u);
    EXPECT_EQ(frame.meta.width, 48u);
    pictures.push_back(decode_jpeg(frame.render()));
  }
  EXPECT_GT(difference(pictures.front(), pictures.back()), 0.5) << "the view did not turn";

  // Stopped: one more frame, full size, then quiet.
  const std::uint64_t generation = stages.set_params({{"view", {{"auto_rotate", false}}}});
  ASSERT_TRUE(wait_for_frame(reader, frame, [&](const shm::Frame& f) {
    return f.meta.params_generation >= generation && f.meta.width == 96;
  }));
}

TEST_F(LiveFramesTest, APrivateViewGetsFramesOfItsOwnCamera) {
  VolumeStages stages(config_);
  shm::FrameRingReader reader = shm::FrameRingReader::attach(config_.frame_ring);
  stages.on_bscans(live_, 0, 32, stamp(1));
  shm::Frame frame;
  ASSERT_TRUE(wait_for_frame(reader, frame, [](const shm::Frame& f) {
    return f.meta.view_id == 0 && f.meta.group_index == 1;
  }));
  const DecodedJpeg shared = decode_jpeg(frame.render());
  stages.open_view(7, {{"view", {{"azimuth_deg", 150}}}});
  ASSERT_TRUE(wait_for_frame(reader, frame, [](const shm::Frame& f) {
    return f.meta.view_id == 7 && f.meta.width == 96;  // full size once it stood still
  }));
  EXPECT_GT(difference(shared, decode_jpeg(frame.render())), 1.0) << "the same camera as view 0";
  // A new group: both views get a frame of it.
  stages.on_bscans(live_, 0, 8, stamp(2));
  bool seen_shared = false, seen_private = false;
  ASSERT_TRUE(wait_for_frame(reader, frame, [&](const shm::Frame& f) {
    if (f.meta.group_index == 2) (f.meta.view_id == 7 ? seen_private : seen_shared) = true;
    return seen_shared && seen_private;
  }));
  stages.close_view(7);
}

TEST_F(LiveFramesTest, TheHeartbeatGoesOnWithoutGroupsAndASnapshotIsTheNextFrame) {
  VolumeStages stages(config_);
  shm::FrameRingReader reader = shm::FrameRingReader::attach(config_.frame_ring);
  EXPECT_THROW((void)stages.snapshot(std::chrono::seconds(1)), std::runtime_error)
      << "nothing to show before the first group";
  shm::FrameRingStatus status{};
  ASSERT_TRUE(reader.read_status(status));
  EXPECT_EQ(status.source_state, static_cast<std::uint64_t>(shm::SourceState::waiting));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  // Beats every 50 ms: a fresh one (under 100 ms old) long after the start, looked for a while so
  // that one beat late on a loaded machine does not count as none.
  shm::FrameWriterHealth health;
  test_support::eventually(
      [&] {
        health = reader.health();
        return !health.alive || health.heartbeat_age_ns < 100'000'000u;
      },
      std::chrono::seconds(5));
  EXPECT_TRUE(health.alive);
  EXPECT_LT(health.heartbeat_age_ns, 100'000'000u);

  stages.on_bscans(live_, 0, 32, stamp(4));
  shm::Frame frame;
  ASSERT_TRUE(
      wait_for_frame(reader, frame, [](const shm::Frame& f) { return f.meta.group_index == 4; }));
  stages.set_params({{"view", {{"azimuth_deg", 80}}}});
  const ViewSnapshot shot = stages.snapshot(std::chrono::seconds(20));
  EXPECT_EQ(shot.image.width, 96u);
  EXPECT_EQ(shot.group_index, 4u);
  EXPECT_DOUBLE_EQ(shot.params.at("view").at("azimuth_deg").get<double>(), 80.0);
}

}  // namespace
}  // namespace ioct::gpu::live
