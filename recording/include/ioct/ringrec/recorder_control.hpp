// ioct-record's control socket: one JSON object per line in, one per line out, served by
// common/line_server (the code of ioct-rt's control channel) on a thread of its own.
//
//   {"cmd": "record-start", "name": "run-7", "seconds": 30}  → {"ok": true, "cmd": ..., "status":
//   {...}}
//   {"cmd": "record-stop"}                                   → the file finished in order
//   {"cmd": "record-status"}                                 → {"ok": true, ..., "status": {...}}
//   anything else, or a refusal                              → {"ok": false, "error": "..."}
// An "id" member (any JSON value) is echoed in the reply.
#pragma once

#include <atomic>
#include <nlohmann/json.hpp>
#include <string>

#include "ioct/common/line_server.hpp"
#include "ioct/ringrec/ring_recorder.hpp"

namespace ioct::ringrec {

// The recorder's status as record-status shows it (docs: recording/README.md).
nlohmann::json recorder_status_json(const RecorderStatus& status);

// The reply line (no newline) to one request line. Never throws.
std::string recorder_control_reply(RingRecorder& recorder, const std::string& line);

// Serves `server` until `done` is set: the control thread of ioct-record.
void serve_recorder_control(LineServer& server, RingRecorder& recorder,
                            const std::atomic<bool>& done);

}  // namespace ioct::ringrec
