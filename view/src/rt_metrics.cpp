#include "rt_metrics.hpp"

#include <cstdint>
#include <optional>
#include <vector>

#include "prometheus_text.hpp"
#include "status_number.hpp"

namespace ioct::view {
namespace {

// status[section][key] as status_number reads it.
std::optional<double> number_at(const nlohmann::json& status, const char* section,
                                const char* key) {
  const auto it = status.find(section);
  return it == status.end() ? std::nullopt : status_number(*it, key);
}

// A non-negative integer (a count, a pid): unsigned as parsed from text, or signed and >= 0.
std::optional<std::uint64_t> count_of(const nlohmann::json& v) {
  if (v.is_number_unsigned()) return v.get<std::uint64_t>();
  if (v.is_number_integer() && v.get<std::int64_t>() >= 0) {
    return static_cast<std::uint64_t>(v.get<std::int64_t>());
  }
  return std::nullopt;
}

void figure(std::string& out, const nlohmann::json& status, const char* section, const char* key,
            const char* name, const char* type, const char* help, double scale = 1.0) {
  if (const std::optional<double> v = number_at(status, section, key)) {
    prom::single(out, name, type, help, *v * scale);
  }
}

// The wake-up latency: ioct-rt's power-of-two microsecond buckets (bucket i below 2^i us, the
// last one everything above), all of them with the exact sum.
void wake_latency(std::string& out, const nlohmann::json& status) {
  if (!status.contains("wake_latency") || !status["wake_latency"].is_object()) return;
  const nlohmann::json& w = status["wake_latency"];
  if (!w.contains("counts") || !w["counts"].is_array() || w["counts"].size() < 2 ||
      w["counts"].size() > 64 || !w.contains("total_ns")) {
    return;
  }
  const std::optional<std::uint64_t> total_ns = count_of(w["total_ns"]);
  if (!total_ns) return;
  std::vector<std::uint64_t> counts;
  std::vector<double> edges_s;
  for (const nlohmann::json& c : w["counts"]) {
    const std::optional<std::uint64_t> n = count_of(c);
    if (!n) return;
    counts.push_back(*n);
  }
  for (std::size_t i = 0; i + 1 < counts.size(); ++i) {
    edges_s.push_back(static_cast<double>(std::uint64_t{1} << i) * 1e-6);
  }
  prom::family(out, "ioct_rt_wake_latency_seconds", "histogram",
               "how late the acquisition thread woke for a group, against its planned wake-up");
  prom::histogram_samples(out, "ioct_rt_wake_latency_seconds", {}, edges_s, counts,
                          static_cast<double>(*total_ns) * 1e-9);
}

void readers(std::string& out, const nlohmann::json& status) {
  if (!status.contains("readers") || !status["readers"].is_array()) return;
  const nlohmann::json& list = status["readers"];
  double alive = 0;
  for (const nlohmann::json& r : list) {
    if (r.is_object() && r.contains("alive") && r["alive"] == true) ++alive;
  }
  prom::single(out, "ioct_rt_readers", "gauge", "ring readers registered with a live process",
               alive);
  const auto per_reader = [&](const char* name, const char* help,
                              const std::vector<std::pair<const char*, const char*>>& keys) {
    std::string samples;  // the family only with samples: a strict reader wants both
    for (const nlohmann::json& r : list) {
      const std::optional<std::uint64_t> pid =
          r.is_object() && r.contains("pid") ? count_of(r["pid"]) : std::nullopt;
      if (!pid) continue;
      const std::string label = r.contains("label") && r["label"].is_string()
                                    ? r["label"].get<std::string>()
                                    : std::string();
      for (const auto& [key, cause] : keys) {
        const std::optional<std::uint64_t> n = r.contains(key) ? count_of(r[key]) : std::nullopt;
        if (!n) continue;
        prom::Labels labels{{"reader", label}, {"pid", std::to_string(*pid)}};
        if (cause != nullptr) labels.emplace_back("cause", cause);
        prom::sample(samples, name, labels, static_cast<double>(*n));
      }
    }
    if (samples.empty()) return;
    prom::family(out, name, "counter", help);
    out += samples;
  };
  per_reader("ioct_rt_reader_groups_consumed_total", "groups a ring reader read intact",
             {{"consumed", nullptr}});
  per_reader("ioct_rt_reader_groups_dropped_total",
             "groups a ring reader lost: lapped by the writer, or too far behind",
             {{"dropped_lapped", "lapped"}, {"dropped_behind", "behind"}});
}

}  // namespace

void append_rt_metrics(std::string& out, const nlohmann::json& status) {
  const bool up = status.is_object();
  prom::single(out, "ioct_rt_up", "gauge",
               "1 while ioct-rt answers on its control socket; 0: its figures are not shown",
               up ? 1 : 0);
  if (!up) return;
  if (status.contains("uptime_s") && status["uptime_s"].is_number()) {
    prom::single(out, "ioct_rt_uptime_seconds", "gauge", "time since ioct-rt started",
                 status["uptime_s"].get<double>());
  }
  const char* a = "acquisition";
  figure(out, status, a, "groups_published", "ioct_rt_groups_published_total", "counter",
         "groups published into the ring");
  figure(out, status, a, "groups_dropped", "ioct_rt_groups_dropped_total", "counter",
         "groups claimed but not published (incomplete, parked)");
  figure(out, status, a, "deadline_misses", "ioct_rt_deadline_misses_total", "counter",
         "groups the acquisition loop published after their deadline");
  figure(out, status, a, "worst_lateness_ms", "ioct_rt_worst_lateness_seconds", "gauge",
         "the furthest past its deadline a group was ready", 1e-3);
  figure(out, status, a, "missed_sweeps", "ioct_rt_missed_sweeps_total", "counter",
         "sweeps the digitizer reported missed");
  figure(out, status, a, "simulator_late_groups", "ioct_rt_simulator_late_groups_total", "counter",
         "groups the simulator's workers delivered late (not the loop's misses)");
  figure(out, status, a, "simulator_worst_lateness_ms", "ioct_rt_simulator_worst_lateness_seconds",
         "gauge", "the furthest past its last sweep a late simulated group was", 1e-3);
  figure(out, status, a, "group_budget_ms", "ioct_rt_group_budget_seconds", "gauge",
         "time one group takes to acquire (the deadline budget)", 1e-3);
  figure(out, status, a, "generation_ms_max", "ioct_rt_group_generation_max_seconds", "gauge",
         "longest time the digitizer took to hand the loop a group", 1e-3);
  figure(out, status, a, "replay", "ioct_rt_replay", "gauge",
         "1 while the groups come from a recording (ioct-rt --replay)");
  figure(out, status, a, "simulated", "ioct_rt_simulated", "gauge",
         "1 while the groups come from the simulator");
  figure(out, status, "safety", "faults_total", "ioct_rt_safety_faults_total", "counter",
         "safety faults raised");
  if (status.contains("safety") && status["safety"].is_object() &&
      status["safety"].contains("state") && status["safety"]["state"].is_string()) {
    prom::family(out, "ioct_rt_safety_state", "gauge", "the safety state ioct-rt is in (1)");
    prom::sample(out, "ioct_rt_safety_state",
                 {{"state", status["safety"]["state"].get<std::string>()}}, 1);
  }
  wake_latency(out, status);
  readers(out, status);
}

}  // namespace ioct::view
