#include "status_report.hpp"

#include <sys/resource.h>

#include <cstdio>

#include "ioct/shm/monotonic_clock.hpp"

namespace ioct::rt {
namespace {

std::string printf_string(const char* format, auto... values) {
  char text[256];
  const int length = std::snprintf(text, sizeof(text), format, values...);
  return std::string(text, static_cast<std::size_t>(length < 0 ? 0 : length));
}

// A reader's label comes from its own shared memory: show only printable ASCII of it.
std::string printable(const std::string& text) {
  std::string shown = text;
  for (char& c : shown) {
    if (c < 0x20 || c > 0x7e) c = '?';
  }
  return shown;
}

double ms(std::uint64_t ns) {
  return static_cast<double>(ns) * 1e-6;
}
double seconds(std::uint64_t ns) {
  return static_cast<double>(ns) * 1e-9;
}

double ratio(std::uint64_t part, std::uint64_t whole) {
  return whole == 0 ? 0.0 : static_cast<double>(part) / static_cast<double>(whole);
}

std::string timing(const StatusSample& now, const StatusSample& previous,
                   std::uint64_t group_budget_ns) {
  const std::uint64_t wall = now.wall_ns - previous.wall_ns;
  const std::uint64_t groups = now.counters.groups_published - previous.counters.groups_published;
  const std::uint64_t generated =
      now.counters.groups_generated - previous.counters.groups_generated;
  const std::uint64_t generation =
      now.counters.generation_ns_total - previous.counters.generation_ns_total;
  std::string text = printf_string(
      "groups %llu (%.2f/s) | misses %llu", static_cast<unsigned long long>(groups),
      ratio(groups, wall) * 1e9, static_cast<unsigned long long>(now.counters.deadline_misses));
  if (now.counters.deadline_misses != 0) {
    text += printf_string(" (worst %.1f ms late)", ms(now.counters.worst_lateness_ns));
  }
  text += printf_string(" | gen %.2f ms avg, %.2f ms max of %.2f ms | cpu %.1f%%",
                        ratio(generation, generated) * 1e-6, ms(now.counters.generation_ns_max),
                        ms(group_budget_ns), 100.0 * ratio(now.cpu_ns - previous.cpu_ns, wall));
  if (now.counters.missed_sweeps != 0) {
    text += printf_string(" | missed sweeps %llu",
                          static_cast<unsigned long long>(now.counters.missed_sweeps));
  }
  return text;
}

}  // namespace

std::uint64_t process_cpu_ns() noexcept {
  rusage usage{};
  ::getrusage(RUSAGE_SELF, &usage);
  const auto ns = [](const timeval& tv) {
    return static_cast<std::uint64_t>(tv.tv_sec) * 1'000'000'000u +
           static_cast<std::uint64_t>(tv.tv_usec) * 1'000u;
  };
  return ns(usage.ru_utime) + ns(usage.ru_stime);
}

StatusSample sample_status(const AcquisitionLoop& loop) noexcept {
  return {shm::monotonic_ns(), process_cpu_ns(), loop.counters()};
}

std::string format_status(const StatusSample& now, const StatusSample& previous,
                          std::uint64_t started_ns, std::uint64_t group_budget_ns,
                          std::span<const shm::ReaderReport> readers, std::size_t reaped) {
  std::string line = printf_string("%.1f s | ", seconds(now.wall_ns - started_ns)) +
                     timing(now, previous, group_budget_ns) + " | readers:";
  if (readers.empty()) line += " none";
  for (const shm::ReaderReport& reader : readers) {
    line += printf_string(
        " %s pid %llu %s consumed %llu dropped %llu hb %.0f ms;", printable(reader.label).c_str(),
        static_cast<unsigned long long>(reader.pid), reader.alive ? "alive" : "dead",
        static_cast<unsigned long long>(reader.counters.consumed),
        static_cast<unsigned long long>(reader.counters.dropped()), ms(reader.heartbeat_age_ns));
  }
  if (!readers.empty()) line.pop_back();
  if (reaped != 0) line += printf_string(" | reaped %zu dead", reaped);
  return line;
}

std::string format_summary(const StatusSample& end, const StatusSample& start,
                           std::uint64_t group_budget_ns) {
  return printf_string("ran %.2f s | ", seconds(end.wall_ns - start.wall_ns)) +
         timing(end, start, group_budget_ns);
}

}  // namespace ioct::rt
