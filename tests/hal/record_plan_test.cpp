// How records are cut into transfers: whole packets into the slot, at most one packet copied.
#include "ioct/hal/usb/record_plan.hpp"

#include <gtest/gtest.h>

#include <stdexcept>

namespace ioct::hal::usb {
namespace {

TEST(RecordPlan, DefaultGeometryOnSuperSpeedNeedsNoTail) {
  // 1376 samples x 512 A-scans x 2 bytes = 1376 packets of 1024 bytes.
  const RecordPlan plan = RecordPlan::make(1024, 1376u * 512u * 2u, 16, 256 * 1024);
  EXPECT_EQ(plan.tail_copy_bytes, 0u);
  EXPECT_EQ(plan.body_bytes, 1376u * 512u * 2u);
  EXPECT_EQ(plan.body_chunks, 6u);  // 5 x 256 KiB + 96 KiB
  EXPECT_EQ(plan.parts_per_record, 7u);
  EXPECT_EQ(plan.parts_per_group(), 7u * 16u);
  EXPECT_EQ(plan.record_wire_bytes(), 1024u + 1376u * 512u * 2u);
  const RecordPart last_body = plan.part(6);
  EXPECT_EQ(last_body.kind, PartKind::body);
  EXPECT_EQ(last_body.slot_offset, 5u * 256u * 1024u);
  EXPECT_EQ(last_body.length, 1376u * 1024u - 5u * 256u * 1024u);
}

TEST(RecordPlan, PartsTileEachRecordOfTheSlotExactlyOnce) {
  for (const std::uint32_t packet : {64u, 512u, 1024u}) {
    for (const std::uint64_t payload : {800ull, 2048ull, 4096ull + 6ull, 130000ull}) {
      SCOPED_TRACE(testing::Message() << "packet " << packet << " payload " << payload);
      const RecordPlan plan = RecordPlan::make(packet, payload, 3, 4096);
      std::vector<int> covered(payload * 3, 0);
      for (std::uint64_t p = 0; p < plan.parts_per_group(); ++p) {
        const RecordPart part = plan.part(p);
        EXPECT_EQ(part.length % packet, 0u) << "part " << p << " is not whole packets";
        EXPECT_LE(part.length, 4096u);
        if (part.kind == PartKind::header) continue;
        const std::uint64_t bytes = part.kind == PartKind::tail ? part.copy_bytes : part.length;
        EXPECT_EQ(part.slot_offset / payload, part.record);
        for (std::uint64_t b = 0; b < bytes; ++b) ++covered[part.slot_offset + b];
      }
      for (std::size_t b = 0; b < covered.size(); ++b) {
        ASSERT_EQ(covered[b], 1) << "slot byte " << b;
      }
      EXPECT_LT(plan.tail_copy_bytes, packet);  // at most one partial packet is copied
    }
  }
}

TEST(RecordPlan, RefusesPacketsSmallerThanTheHeader) {
  EXPECT_THROW(RecordPlan::make(32, 1024, 1, 1024), std::invalid_argument);
  EXPECT_THROW(RecordPlan::make(512, 1024, 1, 256), std::invalid_argument);
  EXPECT_THROW(RecordPlan::make(512, 0, 1, 1024), std::invalid_argument);
}

}  // namespace
}  // namespace ioct::hal::usb
