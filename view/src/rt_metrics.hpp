// ioct-rt's figures for /metrics, with their own names and types, from the status ioct-view polls
// on ioct-rt's control socket (built there off the real-time thread; ioct-rt keeps no web stack).
// While ioct-rt cannot be reached only ioct_rt_up 0 is written; a figure missing from the status
// (an older ioct-rt) is left out rather than shown as 0. Names, types and units: docs/metrics.md.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace ioct::view {

// `status`: the status reply's "status" object, or null when ioct-rt is not reachable.
void append_rt_metrics(std::string& out, const nlohmann::json& status);

}  // namespace ioct::view
