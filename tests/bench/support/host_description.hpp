// What a figure was measured on, printed at the top of every report and stored in its JSON, so
// a number in docs can be traced to a machine.
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

namespace ioct::bench {

struct HostDescription {
  std::string cpu_model;  // /proc/cpuinfo "model name"
  std::string kernel;     // uname -sr
  int allowed_cpus = 0;   // in this process's affinity mask
  std::uint64_t shm_free_bytes = 0;
  std::uint64_t memlock_limit_bytes = 0;  // RLIMIT_MEMLOCK; UINT64_MAX when unlimited
  std::string utc_time;                   // ISO 8601, when the run started
};

HostDescription describe_host();

std::string to_text(const HostDescription& host);
nlohmann::json to_json(const HostDescription& host);

}  // namespace ioct::bench
