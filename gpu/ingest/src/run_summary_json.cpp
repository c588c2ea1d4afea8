#include "ioct/gpu/ingest/run_summary_json.hpp"

#include <utility>

namespace ioct::gpu {
namespace {

double milliseconds(std::uint64_t nanoseconds) {
  return static_cast<double>(nanoseconds) * 1e-6;
}

nlohmann::json status_flag_names(std::uint32_t flags) {
  static constexpr std::pair<std::uint32_t, const char*> kNames[] = {
      {shm::kStatusMissedTriggers, "missed_triggers"},
      {shm::kStatusClockFault, "clock_fault"},
      {shm::kStatusOverrun, "overrun"},
      {shm::kStatusLaserOn, "laser_on"},
      {shm::kStatusGalvoFault, "galvo_fault"},
      {shm::kStatusSimulated, "simulated"}};
  nlohmann::json names = nlohmann::json::array();
  for (const auto& [bit, name] : kNames) {
    if ((flags & bit) != 0) names.push_back(name);
  }
  return names;
}

}  // namespace

nlohmann::json to_json(const RunSummary& s) {
  const LiveCounters& c = s.counters;
  nlohmann::json j;
  j["ring"] = s.ring_name;
  j["backend"] = s.backend;
  j["threads"] = s.threads;
  j["db_min"] = s.scale.db_min;
  j["db_max"] = s.scale.db_max;
  j["stop_reason"] = std::string(to_string(s.stop_reason));
  j["seconds"] = s.seconds;
  if (s.geometry) {
    const shm::RingGeometry& g = *s.geometry;
    j["geometry"] = {{"samples_per_ascan", g.samples_per_ascan},
                     {"ascans_per_bscan", g.ascans_per_bscan},
                     {"bscans_per_group", g.bscans_per_group},
                     {"bscans_per_volume", g.bscans_per_volume}};
  } else {
    j["geometry"] = nullptr;
  }
  j["groups"] = {{"consumed", c.groups_consumed},      {"processed", c.groups_processed},
                 {"dropped_lapped", c.dropped_lapped}, {"dropped_behind", c.dropped_behind},
                 {"rejected", c.groups_rejected},      {"resyncs", c.resyncs},
                 {"epoch_changes", c.epoch_changes}};
  const double seconds = s.seconds > 0.0 ? s.seconds : 1.0;
  j["groups_per_second"] = static_cast<double>(c.groups_processed) / seconds;
  j["ascans_per_second"] =
      s.geometry
          ? static_cast<double>(c.groups_processed * s.geometry->ascans_per_group()) / seconds
          : 0.0;
  j["bscans_rejected"] = c.bscans_rejected;
  j["volumes"] = {{"completed", c.volumes_completed},
                  {"with_gaps", c.volumes_with_gaps},
                  {"abandoned", c.volumes_abandoned}};
  j["latency_ms"] = {{"count", s.latency.count()},
                     {"p50", milliseconds(s.latency.quantile(0.50))},
                     {"p99", milliseconds(s.latency.quantile(0.99))},
                     {"max", milliseconds(s.latency.max())}};
  if (s.images) {
    const ImageSet& i = *s.images;
    j["images"] = {{"bscan", i.bscan_png.string()},
                   {"enface", i.enface_png.string()},
                   {"volume_index", i.volume.volume_index},
                   {"complete", i.volume.complete()},
                   {"bscans_missing", i.volume.bscans_missing},
                   {"bscan_shown", i.bscan_shown},
                   {"zero_fraction", i.zero_fraction},
                   {"saturated_fraction", i.saturated_fraction}};
  } else {
    j["images"] = nullptr;
  }
  j["images_written"] = c.images_written;
  j["images_replaced"] = c.images_replaced;
  j["image_errors"] = c.image_errors;
  j["status_flags_seen"] = status_flag_names(s.status_flags_seen);
  j["stage_errors"] = c.stage_errors;
  j["last_problem"] = s.last_problem;
  j["stages"] = s.stages;
  return j;
}

}  // namespace ioct::gpu
