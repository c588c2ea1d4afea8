// The live pipelines driven directly through a real ring: the CUDA pipeline builds the same
// volumes as the CPU one, its books balance when it falls behind, and readers of its device
// volume see it as of whole groups. Skipped, saying why, where the cuda backend cannot run.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include "ioct/gpu/ingest/live_pipeline.hpp"
#include "live_ring_fixture.hpp"
#if IOCT_GPU_WITH_CUDA
#include <cuda_runtime.h>

#include "ioct/gpu/ingest/cuda_live_pipeline.hpp"
#endif

namespace ioct::gpu {
namespace {

using testing::LiveRing;

// Records what a pipeline reports.
class Recorder final : public LiveEvents {
 public:
  void on_volume(const Volume& volume, const VolumeInfo& info) override {
    volumes.push_back(volume);
    infos.push_back(info);
  }
  void on_group(const shm::SlotHeader& header, const PlacementResult& placed) override {
    groups.push_back(header.group_index);
    bscans_placed += placed.bscans_placed;
  }
  void on_rejected(const shm::SlotHeader&, const std::string&) override { ++rejected; }
  void on_restart(bool) override { ++restarts; }

  std::vector<Volume> volumes;
  std::vector<VolumeInfo> infos;
  std::vector<std::uint64_t> groups;
  std::uint32_t bscans_placed = 0;
  std::uint32_t rejected = 0;
  std::uint32_t restarts = 0;
};

class CudaLive : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const std::optional<std::string> reason = cuda_unavailable_reason()) {
      GTEST_SKIP() << "cuda backend not tested: " << *reason;
    }
  }

  static OctProcessorConfig config() {
    OctProcessorConfig c;
    c.fft.rigor = FftRigor::estimate;
    return c;
  }

  static std::unique_ptr<LivePipeline> attach(Backend backend, const LiveRing& ring,
                                              const std::string& label) {
    return make_live_pipeline(backend, config(),
                              shm::RingReader::attach(ring.name(), {label, false}));
  }

  // Polls until `recorder` has seen `groups` groups (or the time runs out).
  static bool poll_until(LivePipeline& pipeline, Recorder& recorder, std::size_t groups) {
    return testing::wait_until([&] {
      pipeline.poll(recorder);
      return recorder.groups.size() + recorder.rejected >= groups;
    });
  }
};

TEST_F(CudaLive, BuildsTheSameVolumesAsTheCpuPipeline) {
  LiveRing ring;
  ring.create(8);
  const auto cpu = attach(Backend::cpu, ring, "cpu");
  const auto cuda = attach(Backend::cuda, ring, "cuda");
  ASSERT_EQ(cuda->backend_name(), "cuda");
  Recorder cpu_events;
  Recorder cuda_events;
  std::size_t published = 0;
  for (std::uint64_t volume = 0; volume < 3; ++volume) {
    for (std::uint32_t first = 0; first < 8; first += 4) {
      ring.publish(volume, first);
      ++published;
      ASSERT_TRUE(poll_until(*cpu, cpu_events, published));
      ASSERT_TRUE(poll_until(*cuda, cuda_events, published));
    }
  }
  EXPECT_EQ(cuda_events.groups, cpu_events.groups);
  EXPECT_EQ(cuda_events.bscans_placed, cpu_events.bscans_placed);
  ASSERT_EQ(cuda_events.volumes.size(), 3u);
  ASSERT_EQ(cpu_events.volumes.size(), 3u);
  for (std::size_t v = 0; v < 3; ++v) {
    EXPECT_EQ(cuda_events.infos[v].volume_index, cpu_events.infos[v].volume_index);
    EXPECT_TRUE(cuda_events.infos[v].complete());
    const Volume& a = cpu_events.volumes[v];
    const Volume& b = cuda_events.volumes[v];
    ASSERT_EQ(a.bscans(), b.bscans());
    ASSERT_EQ(a.ascans(), b.ascans());
    ASSERT_EQ(a.depth(), b.depth());
    std::size_t off = 0;
    for (std::size_t i = 0; i < a.pixels().size(); ++i) {
      off += std::abs(int{a.pixels()[i]} - int{b.pixels()[i]}) > 1 ? 1 : 0;
    }
    EXPECT_LE(static_cast<double>(off) / static_cast<double>(a.pixels().size()), 0.001)
        << "volume " << v;
  }
  ring.close();
  EXPECT_TRUE(testing::wait_until(
      [&] { return cuda->poll(cuda_events) == shm::PollStatus::producer_gone; }));
}

TEST_F(CudaLive, BooksBalanceWhenItFallsBehind) {
  LiveRing ring;
  ring.create(4);
  const auto cuda = attach(Backend::cuda, ring, "cuda");
  Recorder events;
  constexpr std::uint64_t kPublished = 40;
  // Bursts of 7 groups into 4 slots between polls: the reader falls a whole ring behind and
  // resyncs, and whatever it had copied of an overwritten slot is dropped.
  for (std::uint64_t g = 0; g < kPublished; ++g) {
    ring.publish(g / 2, (g % 2) * 4);
    if (g % 7 == 6) {
      for (int i = 0; i < 3; ++i) cuda->poll(events);
    }
  }
  ring.close();
  ASSERT_TRUE(
      testing::wait_until([&] { return cuda->poll(events) == shm::PollStatus::producer_gone; }));
  cuda->drain(events);
  const shm::ReaderCounters& c = cuda->reader().counters();
  EXPECT_GT(c.dropped(), 0u);
  EXPECT_GT(c.resyncs, 0u);
  EXPECT_EQ(c.consumed + c.dropped_lapped + c.dropped_behind, kPublished);
  EXPECT_EQ(events.groups.size() + events.rejected, c.consumed);
  // Groups land in ring order, each once.
  EXPECT_TRUE(std::ranges::is_sorted(events.groups));
  EXPECT_EQ(std::ranges::adjacent_find(events.groups), events.groups.end());
}

#if IOCT_GPU_WITH_CUDA
TEST_F(CudaLive, ReadersSeeTheDeviceVolumeAsOfWholeGroups) {
  LiveRing ring;
  ring.create(8);
  CudaLivePipeline pipeline(config(), shm::RingReader::attach(ring.name(), {"cuda", false}));
  EXPECT_FALSE(pipeline.ingest_note().empty());
  Recorder events;
  ring.publish(0, 0);
  ring.publish(0, 4);
  ASSERT_TRUE(poll_until(pipeline, events, 2));
  ASSERT_EQ(events.volumes.size(), 1u);

  cudaStream_t stream = nullptr;
  ASSERT_EQ(cudaStreamCreate(&stream), cudaSuccess);
  std::vector<std::uint8_t> seen;
  DeviceVolumeView view;
  pipeline.read_volume(stream, [&](const DeviceVolumeView& v) {
    view = v;
    seen.resize(std::size_t{v.bscans} * v.ascans * v.depth);
    ASSERT_EQ(cudaMemcpyAsync(seen.data(), v.pixels, seen.size(), cudaMemcpyDeviceToHost, stream),
              cudaSuccess);
  });
  // The next group is written only after the read: publish it before the read is done.
  ring.publish(1, 0);
  ASSERT_TRUE(poll_until(pipeline, events, 3));
  ASSERT_EQ(cudaStreamSynchronize(stream), cudaSuccess);
  cudaStreamDestroy(stream);
  EXPECT_EQ(view.version, 2u);
  EXPECT_EQ(view.bscans, 8u);
  EXPECT_EQ(view.ascans, testing::kActiveWidth);
  EXPECT_EQ(view.depth, 128u);
  const std::span<const std::uint8_t> completed = events.volumes[0].pixels();
  EXPECT_TRUE(std::equal(seen.begin(), seen.end(), completed.begin(), completed.end()))
      << "the reader saw something other than the completed volume 0";
}
#endif

}  // namespace
}  // namespace ioct::gpu
