#include "ioct/hal/usb/record_plan.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "ioct/hal/usb/usb_protocol.hpp"

namespace ioct::hal::usb {

RecordPlan RecordPlan::make(std::uint32_t packet_bytes, std::uint64_t payload_bytes,
                            std::uint32_t records_per_group, std::uint32_t transfer_bytes) {
  if (packet_bytes < protocol::kRecordHeaderBytes) {
    throw std::invalid_argument("record endpoint's wMaxPacketSize " + std::to_string(packet_bytes) +
                                " is smaller than the " +
                                std::to_string(protocol::kRecordHeaderBytes) +
                                "-byte record header");
  }
  if (payload_bytes == 0 || records_per_group == 0) {
    throw std::invalid_argument("a record plan needs a payload and at least one record");
  }
  if (transfer_bytes < packet_bytes) {
    throw std::invalid_argument("usb.transfer_bytes " + std::to_string(transfer_bytes) +
                                " is smaller than one packet (" + std::to_string(packet_bytes) +
                                " bytes)");
  }
  RecordPlan plan;
  plan.packet_bytes = packet_bytes;
  plan.payload_bytes = payload_bytes;
  plan.records_per_group = records_per_group;
  plan.chunk_bytes = transfer_bytes / packet_bytes * packet_bytes;
  plan.body_bytes = payload_bytes / packet_bytes * packet_bytes;
  plan.body_chunks =
      static_cast<std::uint32_t>((plan.body_bytes + plan.chunk_bytes - 1) / plan.chunk_bytes);
  plan.tail_copy_bytes = static_cast<std::uint32_t>(payload_bytes - plan.body_bytes);
  plan.parts_per_record = 1 + plan.body_chunks + (plan.tail_copy_bytes != 0 ? 1 : 0);
  return plan;
}

RecordPart RecordPlan::part(std::uint64_t part_in_group) const noexcept {
  RecordPart p;
  p.record = static_cast<std::uint32_t>(part_in_group / parts_per_record);
  const auto index = static_cast<std::uint32_t>(part_in_group % parts_per_record);
  const std::uint64_t record_offset = std::uint64_t{p.record} * payload_bytes;
  if (index == 0) {
    p.kind = PartKind::header;
    p.length = packet_bytes;
  } else if (index <= body_chunks) {
    const std::uint64_t start = std::uint64_t{index - 1} * chunk_bytes;
    p.kind = PartKind::body;
    p.slot_offset = record_offset + start;
    p.length = static_cast<std::uint32_t>(std::min<std::uint64_t>(chunk_bytes, body_bytes - start));
  } else {
    p.kind = PartKind::tail;
    p.slot_offset = record_offset + body_bytes;
    p.length = packet_bytes;
    p.copy_bytes = tail_copy_bytes;
  }
  return p;
}

}  // namespace ioct::hal::usb
