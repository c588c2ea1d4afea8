// ioct-rt's control protocol (rt/src/control_protocol): one line as a client sends it, parsed,
// and a scan command's changes applied to the default scan as the server does. Every line gets
// an answer: a request or an error with a message, and the reply built from it is one JSON line.
#include <cstddef>
#include <cstdint>
#include <string_view>
#include <variant>

#include "control_protocol.hpp"
#include "refusal.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view line(reinterpret_cast<const char*>(data), size);
  // Never throws (its contract): an exception escaping here is a finding.
  const auto parsed = ioct::rt::parse_control_line(line);
  if (const auto* error = std::get_if<ioct::rt::ControlParseError>(&parsed)) {
    ioct::fuzz::check_message(error->message);
    const std::string reply = ioct::rt::error_reply(error->message, error->id);
    if (reply.empty() || reply.find('\n') != std::string::npos) {
      ioct::fuzz::finding("an error reply that is not one line", reply);
    }
    return 0;
  }
  const auto& request = std::get<ioct::rt::ControlRequest>(parsed);
  if (request.verb == ioct::rt::ControlVerb::scan) {
    ioct::fuzz::expect_accept_or_refuse([&] {
      const ioct::scan::ScanSpec spec =
          ioct::rt::apply_scan_changes(ioct::scan::ScanSpec{}, request.scan_changes);
      spec.validate();
    });
  }
  return 0;
}
