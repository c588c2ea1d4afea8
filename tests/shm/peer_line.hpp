// The line protocol between the ring tests and ring_stress_peer: each line the peer prints is
//   <kind> key=value key=value ... [| free text]
// e.g. "ready epoch=17 action=created" or "error code=foreign | ring 'x': ...".
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>

namespace ioct::ring_test {

struct PeerLine {
  std::string kind;
  std::map<std::string, std::string> fields;
  std::string text;  // after " | ", may hold spaces

  bool has(const std::string& key) const { return fields.count(key) != 0; }
  // Throws std::runtime_error naming the key when it is missing or not a number.
  const std::string& field(const std::string& key) const;
  std::uint64_t number(const std::string& key) const;
};

std::optional<PeerLine> parse_peer_line(const std::string& line);

}  // namespace ioct::ring_test
