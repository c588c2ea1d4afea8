#include "recording_metrics.hpp"

#include <cmath>
#include <cstdio>

namespace ioct::view {
namespace {

// A number of the status, or 0 when the member is missing or not a number (an older recorder).
double number_at(const nlohmann::json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end()) return 0.0;
  if (it->is_boolean()) return it->get<bool>() ? 1.0 : 0.0;
  if (!it->is_number()) return 0.0;
  const double v = it->get<double>();
  return std::isfinite(v) ? v : 0.0;
}

void header(std::string& out, const char* name, const char* type, const char* help) {
  out += std::string("# HELP ") + name + " " + help + "\n# TYPE " + name + " " + type + "\n";
}

void sample(std::string& out, const std::string& name, double value) {
  char text[48];
  std::snprintf(text, sizeof text, " %.17g\n", value);
  out += name + text;
}

void metric(std::string& out, const char* name, const char* type, const char* help, double value) {
  header(out, name, type, help);
  sample(out, name, value);
}

}  // namespace

void write_recording_metrics(const nlohmann::json& s, std::string& out) {
  if (!s.is_object()) return;
  metric(out, "ioct_record_recording", "gauge",
         "whether ioct-record writes a recording (1) or not (0)", number_at(s, "recording"));
  metric(out, "ioct_record_attached", "gauge",
         "whether ioct-record reads the ring (1) or waits for its producer (0)",
         number_at(s, "attached"));
  metric(out, "ioct_record_seconds", "gauge", "time since the recording under way started",
         number_at(s, "seconds"));
  // Of the recording under way: they start again from 0 with each recording (a counter reset).
  metric(out, "ioct_record_groups_written_total", "counter",
         "groups in the recording under way's file", number_at(s, "groups_written"));
  metric(out, "ioct_record_bytes_written_total", "counter",
         "payload and slot-header bytes in the recording under way's file",
         number_at(s, "bytes_written"));
  header(out, "ioct_record_dropped_total", "counter",
         "groups the recording under way lost, by cause (lapped, behind: the ring; queue_full: "
         "the disk too slow; disk_full: no room or past --max-mb)");
  const auto dropped = s.find("dropped");
  for (const char* cause : {"lapped", "behind", "queue_full", "disk_full"}) {
    const double n = dropped != s.end() && dropped->is_object() ? number_at(*dropped, cause) : 0.0;
    sample(out, std::string("ioct_record_dropped_total{cause=\"") + cause + "\"}", n);
  }
  const auto queue = s.find("queue");
  const bool has_queue = queue != s.end() && queue->is_object();
  metric(out, "ioct_record_queue_groups", "gauge", "groups waiting for the disk",
         has_queue ? number_at(*queue, "queued") : 0.0);
  metric(out, "ioct_record_queue_capacity_groups", "gauge", "groups that may wait for the disk",
         has_queue ? number_at(*queue, "capacity") : 0.0);
}

}  // namespace ioct::view
