#include "status_report.hpp"

#include <sys/resource.h>

#include <cstdio>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "wake_latency_buckets.hpp"

namespace ioct::rt {
namespace {

std::string printf_string(const char* format, auto... values) {
  char text[256];
  const int length = std::snprintf(text, sizeof(text), format, values...);
  return std::string(text, static_cast<std::size_t>(length < 0 ? 0 : std::min(length, 255)));
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
double us(std::uint64_t ns) {
  return static_cast<double>(ns) * 1e-3;
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
  text += printf_string(" | gen %.2f ms avg, %.2f ms max of %.2f ms",
                        ratio(generation, generated) * 1e-6, ms(now.counters.generation_ns_max),
                        ms(group_budget_ns));
  if (now.wake_latency.count() != 0) {
    text += printf_string(" | wake p99 <%.0f us, max %.0f us",
                          us(now.wake_latency.quantile_upper(0.99)), us(now.wake_latency.max()));
  }
  text += printf_string(" | cpu %.1f%%", 100.0 * ratio(now.cpu_ns - previous.cpu_ns, wall));
  if (now.counters.simulator_late_groups != 0) {
    text += printf_string(" | simulator late %llu (worst %.1f ms)",
                          static_cast<unsigned long long>(now.counters.simulator_late_groups),
                          ms(now.counters.simulator_worst_lateness_ns));
  }
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
  return {ioct::monotonic_ns(), process_cpu_ns(), loop.counters(), loop.wake_latency()};
}

std::string format_status(const StatusSample& now, const StatusSample& previous,
                          std::uint64_t started_ns, std::uint64_t group_budget_ns,
                          const SafetyStatus& safety, std::span<const shm::ReaderReport> readers,
                          std::size_t reaped) {
  std::string line = printf_string("%.1f s | %s", seconds(now.wall_ns - started_ns),
                                   std::string(to_string(safety.state)).c_str());
  if (safety.state == SafetyState::fault || safety.state == SafetyState::safe) {
    line += " (" + describe_faults(safety.record.faults) + ")";
  }
  line += " | " + timing(now, previous, group_budget_ns);
  line +=
      printf_string(" | dac min %llu", static_cast<unsigned long long>(now.counters.dac_fill_min));
  if (now.counters.page_faults_steady != 0) {
    line += printf_string(" | rt page faults %llu",
                          static_cast<unsigned long long>(now.counters.page_faults_steady));
  }
  line += " | readers:";
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

nlohmann::json status_json(const StatusSample& now, std::uint64_t started_ns,
                           std::uint64_t group_budget_ns, const SafetyStatus& safety,
                           std::span<const shm::ReaderReport> readers) {
  const LoopCounters& c = now.counters;
  const LatencyHistogram& w = now.wake_latency;
  const std::array<std::uint64_t, kWakeBuckets> counts = wake_bucket_counts(w);
  nlohmann::json histogram = nlohmann::json::array();
  for (std::size_t i = 0; i < kWakeBuckets; ++i) {
    if (counts[i] != 0) {
      histogram.push_back({{"below_us", wake_bucket_upper_ns(i) / 1000}, {"count", counts[i]}});
    }
  }
  nlohmann::json readers_json = nlohmann::json::array();
  for (const shm::ReaderReport& r : readers) {
    readers_json.push_back({{"label", printable(r.label)},
                            {"pid", r.pid},
                            {"alive", r.alive},
                            {"heartbeat_age_ms", ms(r.heartbeat_age_ns)},
                            {"consumed", r.counters.consumed},
                            {"dropped_lapped", r.counters.dropped_lapped},
                            {"dropped_behind", r.counters.dropped_behind},
                            {"resyncs", r.counters.resyncs}});
  }
  const SafetyRecord& s = safety.record;
  const auto since_fault = [&](std::uint64_t t) {
    return t == 0 || s.fault_ns == 0 || t < s.fault_ns ? nlohmann::json(nullptr)
                                                       : nlohmann::json(ms(t - s.fault_ns));
  };
  return {
      {"uptime_s", seconds(now.wall_ns - started_ns)},
      {"safety",
       {{"state", std::string(to_string(safety.state))},
        {"faults", describe_faults(s.faults)},
        {"faults_total", s.faults_total},
        {"arms_total", s.arms_total},
        {"emission_commanded", safety.emission_commanded},
        {"emission_readback", safety.emission_readback},
        {"emission_off_after_fault_ms", since_fault(s.emission_off_ns)},
        {"parked_after_fault_ms", since_fault(s.parked_ns)},
        {"emission_off_unverified", s.emission_off_unverified},
        {"inputs",
         {{"laser_ready", safety.inputs.laser_ready},
          {"sweep_trigger_present", safety.inputs.sweep_trigger_present},
          {"k_clock_valid", safety.inputs.k_clock_valid},
          {"footswitch", safety.inputs.footswitch}}},
        {"footswitch_presses", safety.footswitch_presses},
        {"watchdog_toggles", safety.watchdog_toggles}}},
      {"acquisition",
       {{"groups_published", c.groups_published},
        {"groups_generated", c.groups_generated},
        {"groups_dropped", c.groups_dropped},
        {"deadline_misses", c.deadline_misses},
        {"worst_lateness_ms", ms(c.worst_lateness_ns)},
        {"generation_ms_mean",
         c.groups_generated == 0
             ? 0.0
             : ms(c.generation_ns_total) / static_cast<double>(c.groups_generated)},
        {"generation_ms_max", ms(c.generation_ns_max)},
        {"group_budget_ms", ms(group_budget_ns)},
        {"missed_sweeps", c.missed_sweeps},
        {"simulator_late_groups", c.simulator_late_groups},
        {"simulator_worst_lateness_ms", ms(c.simulator_worst_lateness_ns)},
        {"arms", c.arms},
        {"parks", c.parks},
        {"rt_page_faults", c.page_faults},
        {"rt_page_faults_steady", c.page_faults_steady},
        {"dac_fifo_fill_min", c.dac_fill_min},
        {"dac_fifo_fill_last", c.dac_fill_last},
        {"dac_underruns", c.dac_underruns}}},
      {"scan",
       {{"generation", c.scan_generation},
        {"pattern_id", c.scan_pattern_id},
        {"changes", c.scan_changes}}},
      {"wake_latency",
       {{"samples", w.count()},
        {"mean_us", w.mean_ns() * 1e-3},
        {"p99_below_us", us(w.quantile_upper(0.99))},
        {"max_us", us(w.max())},
        {"histogram", histogram},
        // Every bucket (bucket i below 2^i us, the last one the overflow) and the exact sum,
        // for a Prometheus histogram (ioct-view's /metrics).
        {"counts", counts},
        {"total_ns", w.sum_ns()}}},
      {"readers", readers_json},
  };
}

}  // namespace ioct::rt
