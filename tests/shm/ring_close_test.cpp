// An orderly stop loses nothing: a reader that is behind when the producer closes the ring still
// reads every group the producer published, and only then hears producer_gone.
#include <gtest/gtest.h>

#include <vector>

#include "ioct/shm/ring_reader.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "test_group.hpp"

namespace ioct::ring_test {
namespace {

TEST(RingClose, ReaderDrainsEveryPublishedGroupBeforeProducerGone) {
  const test_support::ScopedShmName name("close-drain");
  shm::RingWriter writer = shm::RingWriter::create(small_test_config(name.str(), 8));
  shm::RingReader reader = shm::RingReader::attach(name.str());
  constexpr std::uint64_t kPublished = 5;  // fewer than the slots: nothing is overwritten
  for (std::uint64_t i = 0; i < kPublished; ++i) publish_test_group(writer);
  writer.close();

  std::vector<std::byte> payload(reader.layout().group_payload_bytes);
  shm::SlotHeader header{};
  for (std::uint64_t group = 0; group < kPublished; ++group) {
    ASSERT_EQ(reader.read_next(payload, header), shm::PollStatus::ready) << "group " << group;
    EXPECT_EQ(header.group_index, group);
    const TestPayload p = read_test_payload(payload);
    EXPECT_TRUE(p.checksum_ok);
    EXPECT_EQ(p.group, group);
  }
  EXPECT_EQ(reader.read_next(payload, header), shm::PollStatus::producer_gone);
  EXPECT_EQ(reader.counters().consumed, kPublished);
  EXPECT_EQ(reader.counters().dropped(), 0u);
}

TEST(RingClose, ReaderFarBehindAtCloseCountsWhatWasOverwritten) {
  const test_support::ScopedShmName name("close-behind");
  shm::RingWriter writer = shm::RingWriter::create(small_test_config(name.str(), 4));
  shm::RingReader reader = shm::RingReader::attach(name.str());
  constexpr std::uint64_t kPublished = 11;
  for (std::uint64_t i = 0; i < kPublished; ++i) publish_test_group(writer);
  writer.close();

  std::vector<std::byte> payload(reader.layout().group_payload_bytes);
  shm::SlotHeader header{};
  shm::PollStatus status;
  while ((status = reader.read_next(payload, header)) != shm::PollStatus::producer_gone) {
    ASSERT_EQ(status, shm::PollStatus::ready);
    EXPECT_TRUE(read_test_payload(payload).checksum_ok);
  }
  const shm::ReaderCounters& c = reader.counters();
  EXPECT_GT(c.consumed, 0u);
  EXPECT_GT(c.dropped_behind, 0u);
  EXPECT_EQ(c.consumed + c.dropped(), kPublished);
}

}  // namespace
}  // namespace ioct::ring_test
