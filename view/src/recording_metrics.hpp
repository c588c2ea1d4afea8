// The recorder's figures on /metrics: ioct-record's record-status (polled by Backends) as
// Prometheus text, ioct_record_*. Nothing when no recorder answers: a recorder is optional.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace ioct::view {

// Appends the ioct_record_* metrics of `record_status` (the "status" object of ioct-record's
// record-status reply; recording/README.md) to `out`; nothing when it is not an object.
void write_recording_metrics(const nlohmann::json& record_status, std::string& out);

}  // namespace ioct::view
