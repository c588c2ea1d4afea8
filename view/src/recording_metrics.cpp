#include "recording_metrics.hpp"

#include <optional>

#include "prometheus_text.hpp"

namespace ioct::view {
namespace {

// A number (or boolean, as 0/1) of the status; nullopt when absent or of another type (left out,
// as the other processes' figures are, rather than shown as 0).
std::optional<double> number_at(const nlohmann::json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end()) return std::nullopt;
  if (it->is_boolean()) return it->get<bool>() ? 1.0 : 0.0;
  if (it->is_number()) return it->get<double>();
  return std::nullopt;
}

void figure(std::string& out, const nlohmann::json& j, const char* key, const char* name,
            const char* type, const char* help) {
  if (const std::optional<double> v = number_at(j, key)) prom::single(out, name, type, help, *v);
}

}  // namespace

void write_recording_metrics(const nlohmann::json& s, std::string& out) {
  if (!s.is_object()) return;
  figure(out, s, "recording", "ioct_record_recording", "gauge",
         "whether ioct-record writes a recording (1) or not (0)");
  figure(out, s, "attached", "ioct_record_attached", "gauge",
         "whether ioct-record reads the ring (1) or waits for its producer (0)");
  figure(out, s, "seconds", "ioct_record_seconds", "gauge",
         "time since the recording under way started");
  // Of the recording under way: they start again from 0 with each recording (a counter reset).
  figure(out, s, "groups_written", "ioct_record_groups_written_total", "counter",
         "groups in the recording under way's file");
  figure(out, s, "bytes_written", "ioct_record_bytes_written_total", "counter",
         "payload and slot-header bytes in the recording under way's file");
  const auto dropped = s.find("dropped");
  if (dropped != s.end() && dropped->is_object()) {
    prom::family(out, "ioct_record_dropped_total", "counter",
                 "groups the recording under way lost, by cause (lapped, behind: the ring; "
                 "queue_full: the disk too slow; disk_full: no room or past --max-mb)");
    for (const char* cause : {"lapped", "behind", "queue_full", "disk_full"}) {
      if (const std::optional<double> n = number_at(*dropped, cause)) {
        prom::sample(out, "ioct_record_dropped_total", {{"cause", cause}}, *n);
      }
    }
  }
  const auto queue = s.find("queue");
  if (queue != s.end() && queue->is_object()) {
    figure(out, *queue, "queued", "ioct_record_queue_groups", "gauge",
           "groups waiting for the disk");
    figure(out, *queue, "capacity", "ioct_record_queue_capacity_groups", "gauge",
           "groups that may wait for the disk");
  }
}

}  // namespace ioct::view
