#include "host_description.hpp"

#include <sys/resource.h>
#include <sys/utsname.h>

#include <ctime>
#include <fstream>
#include <limits>
#include <sstream>

#include "bench_ring_fixture.hpp"
#include "cpu_pinning.hpp"

namespace ioct::bench {
namespace {

std::string read_cpu_model() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string line;
  while (std::getline(cpuinfo, line)) {
    if (line.rfind("model name", 0) != 0) continue;
    const auto colon = line.find(':');
    if (colon != std::string::npos && colon + 2 <= line.size()) return line.substr(colon + 2);
  }
  return "unknown";
}

std::string utc_now() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  ::gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

std::string mib(std::uint64_t bytes) {
  if (bytes == std::numeric_limits<std::uint64_t>::max()) return "unlimited";
  std::ostringstream out;
  out << bytes / (1024 * 1024) << " MiB";
  return out.str();
}

}  // namespace

HostDescription describe_host() {
  HostDescription host;
  host.cpu_model = read_cpu_model();
  utsname names{};
  if (::uname(&names) == 0) host.kernel = std::string(names.sysname) + " " + names.release;
  host.allowed_cpus = static_cast<int>(allowed_cpus().size());
  host.shm_free_bytes = shm_free_bytes();
  rlimit limit{};
  if (::getrlimit(RLIMIT_MEMLOCK, &limit) == 0) {
    host.memlock_limit_bytes = limit.rlim_cur == RLIM_INFINITY
                                   ? std::numeric_limits<std::uint64_t>::max()
                                   : static_cast<std::uint64_t>(limit.rlim_cur);
  }
  host.utc_time = utc_now();
  return host;
}

std::string to_text(const HostDescription& host) {
  std::ostringstream out;
  out << "host: " << host.cpu_model << ", " << host.allowed_cpus << " CPUs usable, " << host.kernel
      << "\n"
      << "      /dev/shm free " << mib(host.shm_free_bytes) << ", RLIMIT_MEMLOCK "
      << mib(host.memlock_limit_bytes) << ", started " << host.utc_time << "\n";
  return out.str();
}

nlohmann::json to_json(const HostDescription& host) {
  return {{"cpu_model", host.cpu_model},
          {"kernel", host.kernel},
          {"allowed_cpus", host.allowed_cpus},
          {"shm_free_bytes", host.shm_free_bytes},
          {"memlock_limit_bytes", host.memlock_limit_bytes},
          {"utc_time", host.utc_time}};
}

}  // namespace ioct::bench
