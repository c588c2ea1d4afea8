// How the bulk IN byte stream of records is cut into transfers, and where each transfer lands.
//
// A record on the wire is [header packet][payload][zero pad to a whole packet]. The host reads it
// as: one header transfer (one packet) into a host buffer; body transfers of whole packets
// straight into the B-scan's place in the ring slot; one tail transfer (one packet) into a host
// buffer when the payload does not end on a packet boundary, whose first bytes are copied into
// the slot. So at most one packet per record is copied on the host; the rest is written into
// the slot by the kernel as the transfer completes.
#pragma once

#include <cstdint>

namespace ioct::hal::usb {

enum class PartKind : std::uint8_t { header, body, tail };

struct RecordPart {
  std::uint32_t record = 0;  // record (B-scan) of the group
  PartKind kind = PartKind::header;
  std::uint64_t slot_offset = 0;  // byte offset in the group's slot payload (body and tail)
  std::uint32_t length = 0;       // bytes of the transfer
  std::uint32_t copy_bytes = 0;   // tail: payload bytes to copy into the slot
};

struct RecordPlan {
  std::uint32_t packet_bytes = 0;      // wMaxPacketSize of the record endpoint
  std::uint64_t payload_bytes = 0;     // one B-scan: ascans x samples x 2
  std::uint32_t chunk_bytes = 0;       // body transfer size, whole packets
  std::uint64_t body_bytes = 0;        // the payload's whole packets
  std::uint32_t body_chunks = 0;       // body transfers per record
  std::uint32_t tail_copy_bytes = 0;   // payload bytes in the last, partial packet (0: none)
  std::uint32_t parts_per_record = 0;  // header + body chunks + tail
  std::uint32_t records_per_group = 0;

  // Requires packet_bytes >= the 64-byte header, a positive payload and group, and
  // transfer_bytes >= packet_bytes; throws std::invalid_argument otherwise.
  static RecordPlan make(std::uint32_t packet_bytes, std::uint64_t payload_bytes,
                         std::uint32_t records_per_group, std::uint32_t transfer_bytes);

  std::uint64_t parts_per_group() const noexcept {
    return std::uint64_t{parts_per_record} * records_per_group;
  }
  // Bytes one record takes on the wire, header packet and padding included.
  std::uint64_t record_wire_bytes() const noexcept {
    return packet_bytes + body_bytes + (tail_copy_bytes != 0 ? packet_bytes : 0);
  }
  // The part'th transfer of a group (0 <= part < parts_per_group()).
  RecordPart part(std::uint64_t part_in_group) const noexcept;
};

}  // namespace ioct::hal::usb
