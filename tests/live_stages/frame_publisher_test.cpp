// The frame publisher encodes on a thread of its own: every frame handed over is written or
// replaced by a newer one of its view, each view's newest is always written (also when it is
// handed over just before close), with the B-scan current at that time; a frame the ring refuses
// or that cannot be encoded is counted, never thrown at the stages.
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "ioct/gpu/instruments/tip_bscans.hpp"
#include "ioct/gpu/live_stages/frame_publisher.hpp"
#include "ioct/shm/frame_ring.hpp"
#include "ioct/test_support/eventually.hpp"

namespace ioct::gpu::live {
namespace {

shm::FrameRingConfig ring_config(std::uint64_t max_payload_bytes) {
  shm::FrameRingConfig ring;
  ring.name = "ioct-test-publisher-" + std::to_string(::getpid()) + "-" +
              ::testing::UnitTest::GetInstance()->current_test_info()->name();
  ring.max_payload_bytes = max_payload_bytes;
  return ring;
}

render::RgbaImage flat_image(std::uint32_t width, std::uint32_t height, std::uint8_t level) {
  render::RgbaImage image;
  image.resize(width, height);
  std::ranges::fill(image.rgba, level);
  return image;
}

segmentation::RgbImage flat_bscan(std::uint32_t width, std::uint32_t height) {
  segmentation::RgbImage image;
  image.width = width;
  image.height = height;
  image.pixels.assign(std::size_t{width} * height * 3, 90);
  return image;
}

// Hands a frame of `group` over and waits (20 s at most) until the encoding thread has written
// it or counted it an error: one at a time, so that none replaces another.
void publish_one(FramePublisher& publisher, std::uint64_t group, render::RgbaImage image) {
  const auto done = [&] {
    const FramePublisher::FrameCounts c = publisher.frame_counts();
    return c.written + c.errors;
  };
  const std::uint64_t before = done();
  shm::FrameMeta meta{};
  meta.group_index = group;
  publisher.publish(meta, image);
  test_support::eventually([&] { return done() != before; }, std::chrono::seconds(20));
}

// Until the encoding thread has counted a frame error, or 20 s.
void wait_for_an_error(const FramePublisher& publisher) {
  test_support::eventually([&] { return publisher.frame_counts().errors != 0; },
                           std::chrono::seconds(20));
}

TEST(FramePublisher, EveryFrameIsWrittenOrReplacedAndTheNewestIsWritten) {
  const shm::FrameRingConfig config = ring_config(8ull << 20);
  FramePublisher publisher(config);
  shm::FrameRingReader reader = shm::FrameRingReader::attach(config.name);
  publisher.set_bscan(flat_bscan(64, 48), 5, 16);
  constexpr std::uint64_t kFrames = 200;
  for (std::uint64_t g = 0; g < kFrames; ++g) {
    shm::FrameMeta meta{};
    meta.group_index = g;
    render::RgbaImage image = flat_image(160, 120, static_cast<std::uint8_t>(g));
    const std::uint8_t* handed = image.rgba.data();
    publisher.publish(meta, image);
    EXPECT_NE(image.rgba.data(), handed) << "the publisher takes the pixels, it does not copy";
  }
  publisher.close();

  const FramePublisher::FrameCounts counts = publisher.frame_counts();
  EXPECT_EQ(counts.written + counts.replaced, kFrames);
  EXPECT_GE(counts.written, 1u);
  EXPECT_EQ(counts.errors, 0u) << counts.problem;
  shm::Frame frame;
  shm::Frame newest;
  std::uint64_t read = 0;
  while (reader.read_next(frame)) {
    newest = frame;
    ++read;
  }
  ASSERT_GT(read, 0u);
  EXPECT_EQ(newest.meta.group_index, kFrames - 1) << "the newest frame is never the one lost";
  EXPECT_EQ(newest.meta.width, 160u);
  EXPECT_EQ(newest.meta.bscan_index, 5u);
  EXPECT_EQ(newest.meta.bscan_width, 64u);
  EXPECT_GT(newest.meta.bscan_bytes, 0u);
}

TEST(FramePublisher, AFrameTheRingRefusesIsCountedAndTheNextIsWritten) {
  const shm::FrameRingConfig config = ring_config(64 * 1024);
  FramePublisher publisher(config);
  shm::FrameRingReader reader = shm::FrameRingReader::attach(config.name);
  // Noise does not compress: far more than 64 kB of JPEG.
  render::RgbaImage noise = flat_image(512, 512, 0);
  std::mt19937 random(7);
  for (std::uint8_t& v : noise.rgba) v = static_cast<std::uint8_t>(random());
  shm::FrameMeta meta{};
  meta.group_index = 1;
  publisher.publish(meta, noise);
  // Its turn comes on the encoding thread; then a frame that fits.
  wait_for_an_error(publisher);
  render::RgbaImage small = flat_image(64, 48, 128);
  meta.group_index = 2;
  publisher.publish(meta, small);
  publisher.close();  // writes the waiting frame first

  const FramePublisher::FrameCounts counts = publisher.frame_counts();
  EXPECT_EQ(counts.errors, 1u);
  EXPECT_FALSE(counts.problem.empty());
  EXPECT_EQ(counts.written, 1u);
  shm::Frame frame;
  ASSERT_TRUE(reader.read_next(frame));
  EXPECT_EQ(frame.meta.group_index, 2u);
  EXPECT_FALSE(reader.read_next(frame)) << "the refused frame left nothing in the ring";
}

// Views do not replace each other's frames: while the encoding thread is busy with one view's
// frame, the others' wait each in a place of its own, and only a newer frame of the same view
// replaces one; every view's newest frame is written, in the order they came.
TEST(FramePublisher, EachViewsNewestFrameIsWritten) {
  const shm::FrameRingConfig config = ring_config(8ull << 20);
  FramePublisher publisher(config);
  shm::FrameRingReader reader = shm::FrameRingReader::attach(config.name);
  const auto hand_over = [&](std::uint64_t view, std::uint64_t group, std::uint32_t size) {
    shm::FrameMeta meta{};
    meta.view_id = view;
    meta.group_index = group;
    render::RgbaImage image = flat_image(size, size, static_cast<std::uint8_t>(group));
    publisher.publish(meta, image);
  };
  hand_over(0, 1, 1024);  // a large frame keeps the encoding thread busy
  hand_over(1, 2, 64);
  hand_over(2, 3, 64);
  hand_over(3, 4, 64);
  hand_over(2, 5, 64);
  publisher.close();
  const FramePublisher::FrameCounts counts = publisher.frame_counts();
  EXPECT_EQ(counts.errors, 0u) << counts.problem;
  EXPECT_EQ(counts.written + counts.replaced, 5u);
  std::vector<std::uint64_t> groups_of_view(4, 0);
  shm::Frame frame;
  while (reader.read_next(frame)) {
    ASSERT_LT(frame.meta.view_id, 4u);
    groups_of_view[frame.meta.view_id] = frame.meta.group_index;
  }
  EXPECT_EQ(groups_of_view, (std::vector<std::uint64_t>{1, 2, 5, 4}))
      << "every view's newest frame";
}

// A B-scan that cannot be encoded (its pixels do not fill its size) is counted and its frame goes
// out without one: never the older B-scan as if it were the new one. A render that cannot be
// encoded is counted and its frame not written. The encoding thread goes on with the next.
TEST(FramePublisher, APictureThatCannotBeEncodedIsCountedAndShownAsNone) {
  const shm::FrameRingConfig config = ring_config(8ull << 20);
  FramePublisher publisher(config);
  shm::FrameRingReader reader = shm::FrameRingReader::attach(config.name);
  const auto publish = [&](std::uint64_t group, render::RgbaImage image) {
    publish_one(publisher, group, image);
  };
  publisher.set_bscan(flat_bscan(64, 48), 1, 16);
  publish(1, flat_image(64, 48, 10));  // with B-scan 1
  segmentation::RgbImage broken = flat_bscan(64, 48);
  broken.pixels.resize(10);
  publisher.set_bscan(std::move(broken), 2, 16);
  publish(2, flat_image(64, 48, 20));
  EXPECT_NE(publisher.frame_counts().problem.find("B-scan"), std::string::npos)
      << publisher.frame_counts().problem;
  render::RgbaImage broken_render = flat_image(64, 48, 30);
  broken_render.rgba.resize(10);
  publish(3, std::move(broken_render));
  publisher.set_bscan(flat_bscan(64, 48), 4, 16);
  publish(4, flat_image(64, 48, 40));
  publisher.close();
  const FramePublisher::FrameCounts counts = publisher.frame_counts();
  EXPECT_EQ(counts.errors, 2u);
  EXPECT_NE(counts.problem.find("render"), std::string::npos) << counts.problem;
  EXPECT_EQ(counts.written, 3u);
  std::vector<std::uint64_t> groups;
  shm::Frame frame;
  while (reader.read_next(frame)) {
    groups.push_back(frame.meta.group_index);
    SCOPED_TRACE(testing::Message() << "group " << frame.meta.group_index);
    if (frame.meta.group_index == 2) {
      EXPECT_EQ(frame.meta.bscan_bytes, 0u) << "no B-scan rather than B-scan 1 as if new";
      EXPECT_EQ(frame.meta.bscan_width, 0u);
    } else {
      EXPECT_GT(frame.meta.bscan_bytes, 0u);
      EXPECT_EQ(frame.meta.bscan_index, frame.meta.group_index);
    }
  }
  EXPECT_EQ(groups, (std::vector<std::uint64_t>{1, 2, 4})) << "the broken render's frame is lost";
}

// The instrument's tip B-scan pair goes with every frame from the pass that found it, and is gone
// from the frames after the tool left (set to none); the B-scan stays.
TEST(FramePublisher, TheTipPairGoesWithTheFramesUntilItIsNone) {
  const shm::FrameRingConfig config = ring_config(8ull << 20);
  FramePublisher publisher(config);
  shm::FrameRingReader reader = shm::FrameRingReader::attach(config.name);
  instruments::TipBscans pair;
  pair.width = 40;
  pair.height = 48;
  pair.pixels.assign(std::size_t{pair.stride()} * pair.height, 120);
  publisher.set_bscan(flat_bscan(64, 48), 7, 16);
  publisher.set_tip_bscans(&pair);
  const auto publish = [&](std::uint64_t group) {
    publish_one(publisher, group, flat_image(64, 48, static_cast<std::uint8_t>(group)));
  };
  publish(1);
  publish(2);  // nothing new: the same pair again
  publisher.set_tip_bscans(nullptr);
  publish(3);
  publisher.close();
  std::vector<std::uint32_t> pair_widths, bscan_indices;
  shm::Frame frame;
  while (reader.read_next(frame)) {
    pair_widths.push_back(frame.meta.tip_bscan_width);
    bscan_indices.push_back(frame.meta.bscan_index);
    EXPECT_EQ(frame.meta.tip_bscans_bytes > 0, frame.meta.tip_bscan_width > 0);
  }
  EXPECT_EQ(pair_widths, (std::vector<std::uint32_t>{40, 40, 0}));
  EXPECT_EQ(bscan_indices, (std::vector<std::uint32_t>{7, 7, 7}));
}

}  // namespace
}  // namespace ioct::gpu::live
