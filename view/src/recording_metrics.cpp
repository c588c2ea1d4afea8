#include "recording_metrics.hpp"

#include <optional>

#include "prometheus_text.hpp"
#include "status_number.hpp"

namespace ioct::view {
namespace {

void figure(std::string& out, const nlohmann::json& j, const char* key, const char* name,
            const char* type, const char* help) {
  if (const std::optional<double> v = status_number(j, key))
    prom::single(out, name, type, help, *v);
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
      if (const std::optional<double> n = status_number(*dropped, cause)) {
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
