// The cases the stress tests hope to hit, made to happen for sure: a slot overwritten before,
// during and after a copy. end_read() must reject each copy, and the checks the stress tests rely
// on (group_verifier.hpp) must see the damage in it -- so a torn read that end_read() wrongly
// accepted could not pass the stress tests unnoticed.
#include <gtest/gtest.h>

#include <span>
#include <string>
#include <vector>

#include "group_verifier.hpp"
#include "ioct/shm/ring_reader.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "test_group.hpp"

namespace ioct::ring_test {
namespace {

using test_support::ScopedShmName;

class RingTornRead : public ::testing::Test {
 protected:
  RingTornRead()
      : writer_(shm::RingWriter::create(small_test_config(name_.str(), kSlots))),
        reader_(shm::RingReader::attach(name_.str())),
        copy_(reader_.layout().group_payload_bytes) {}

  // A ticket for the next group, which the writer has published.
  shm::ReadTicket take_ticket() {
    publish_test_group(writer_);
    shm::ReadTicket ticket;
    EXPECT_EQ(reader_.begin_read(ticket), shm::PollStatus::ready);
    return ticket;
  }
  void copy(const shm::ReadTicket& t, std::size_t from, std::size_t to) {
    shm::seqlock_copy(copy_.data() + from, t.payload + from, to - from);
  }
  std::string damage(const shm::ReadTicket& t) {
    return describe_damage(t.header, copy_, t.group, t.epoch);
  }
  void lap() {
    for (std::uint64_t i = 0; i < kSlots; ++i) publish_test_group(writer_);
  }

  static constexpr std::uint64_t kSlots = 4;
  ScopedShmName name_{"torn"};
  shm::RingWriter writer_;
  shm::RingReader reader_;
  std::vector<std::byte> copy_;
};

TEST_F(RingTornRead, UndisturbedCopyIsAcceptedAndIntact) {
  const shm::ReadTicket t = take_ticket();
  copy(t, 0, copy_.size());
  EXPECT_TRUE(reader_.end_read(t));
  EXPECT_EQ(damage(t), "");
  EXPECT_EQ(reader_.counters().consumed, 1u);
}

TEST_F(RingTornRead, SlotOverwrittenBeforeTheCopyIsRejected) {
  const shm::ReadTicket t = take_ticket();
  lap();
  copy(t, 0, copy_.size());
  EXPECT_FALSE(reader_.end_read(t));
  EXPECT_NE(damage(t).find("payload holds group " + std::to_string(t.group + kSlots)),
            std::string::npos)
      << damage(t);
  EXPECT_EQ(reader_.counters().consumed, 0u);
  EXPECT_EQ(reader_.counters().dropped_lapped, 1u);
}

TEST_F(RingTornRead, SlotOverwrittenInMidCopyIsRejected) {
  const shm::ReadTicket t = take_ticket();
  const std::size_t half = copy_.size() / 2;
  copy(t, 0, half);
  lap();
  copy(t, half, copy_.size());
  EXPECT_FALSE(reader_.end_read(t));
  EXPECT_NE(damage(t).find("torn payload"), std::string::npos) << damage(t);
  EXPECT_EQ(reader_.counters().dropped_lapped, 1u);
}

TEST_F(RingTornRead, SlotBeingWrittenDuringTheCopyIsRejected) {
  const shm::ReadTicket t = take_ticket();
  for (std::uint64_t i = 0; i + 1 < kSlots; ++i) publish_test_group(writer_);
  // The writer claims the ticket's slot for a newer group and has written half of it.
  const shm::RingWriter::Claim claim = writer_.claim();
  ASSERT_EQ(claim.group % kSlots, t.slot_index);
  write_test_payload(claim.payload, claim.group, writer_.epoch());
  std::fill(claim.payload.begin() + static_cast<std::ptrdiff_t>(claim.payload.size() / 2),
            claim.payload.end(), std::byte{0});
  copy(t, 0, copy_.size());
  EXPECT_FALSE(reader_.end_read(t)) << "the slot was mid-write (odd sequence)";
  EXPECT_NE(damage(t), "");
  writer_.publish(claim);
}

TEST_F(RingTornRead, VerifierRejectsStaleAndForeignGroups) {
  const shm::ReadTicket t = take_ticket();
  copy(t, 0, copy_.size());
  ASSERT_TRUE(reader_.end_read(t));
  GroupVerifier verifier;
  EXPECT_TRUE(verifier.check(t.header, copy_, t.group, t.epoch));
  EXPECT_FALSE(verifier.check(t.header, copy_, t.group, t.epoch)) << "the same group twice";
  EXPECT_NE(verifier.first_failure().find("stale or out of order"), std::string::npos);
  EXPECT_FALSE(verifier.check(t.header, copy_, t.group, t.epoch + 1)) << "another epoch";
  EXPECT_EQ(verifier.verified(), 1u);
  EXPECT_EQ(verifier.failures(), 2u);

  shm::SlotHeader mixed = t.header;
  mixed.first_sweep_counter += 1;  // a header field of another group
  EXPECT_NE(describe_damage(mixed, copy_, t.group, t.epoch).find("torn slot header"),
            std::string::npos);
}

}  // namespace
}  // namespace ioct::ring_test
