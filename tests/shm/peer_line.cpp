#include "peer_line.hpp"

#include <sstream>
#include <stdexcept>

namespace ioct::ring_test {

const std::string& PeerLine::field(const std::string& key) const {
  const auto it = fields.find(key);
  if (it == fields.end()) throw std::runtime_error("peer line '" + kind + "' has no " + key);
  return it->second;
}

std::uint64_t PeerLine::number(const std::string& key) const {
  const std::string& value = field(key);
  std::size_t used = 0;
  const std::uint64_t n = std::stoull(value, &used);
  if (used != value.size()) {
    throw std::runtime_error("peer line '" + kind + "': " + key + "=" + value + " is no number");
  }
  return n;
}

std::optional<PeerLine> parse_peer_line(const std::string& line) {
  PeerLine parsed;
  std::string head = line;
  if (const auto bar = line.find(" | "); bar != std::string::npos) {
    head = line.substr(0, bar);
    parsed.text = line.substr(bar + 3);
  }
  std::istringstream tokens(head);
  if (!(tokens >> parsed.kind)) return std::nullopt;
  std::string token;
  while (tokens >> token) {
    const auto eq = token.find('=');
    if (eq == std::string::npos) return std::nullopt;
    parsed.fields[token.substr(0, eq)] = token.substr(eq + 1);
  }
  return parsed;
}

}  // namespace ioct::ring_test
