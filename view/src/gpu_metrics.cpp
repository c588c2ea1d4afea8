#include "gpu_metrics.hpp"

#include <array>
#include <span>

#include "ioct/shm/stage_histogram.hpp"
#include "prometheus_text.hpp"

namespace ioct::view {
namespace {

const std::array<double, shm::kStageBucketUpperNs.size()>& stage_edges_s() {
  static const auto edges = [] {
    std::array<double, shm::kStageBucketUpperNs.size()> e{};
    for (std::size_t i = 0; i < e.size(); ++i) {
      e[i] = static_cast<double>(shm::kStageBucketUpperNs[i]) * 1e-9;
    }
    return e;
  }();
  return edges;
}

void stage_samples(std::string& out, const std::string& name, const prom::Labels& labels,
                   const shm::StageHistogram& h) {
  prom::histogram_samples(out, name, labels, stage_edges_s(),
                          std::span<const std::uint64_t>(h.counts, shm::kStageBuckets),
                          static_cast<double>(h.sum_ns) * 1e-9);
}

void counter(std::string& out, const char* name, const char* help, std::uint64_t value) {
  prom::single(out, name, "counter", help, static_cast<double>(value));
}

}  // namespace

void append_gpu_metrics(std::string& out, const FollowerSnapshot& f) {
  const bool up = f.attached && f.writer_responding;
  prom::single(out, "ioct_gpu_up", "gauge",
               "1 while ioct-gpu runs and beats in its frame ring; 0: its figures are not shown",
               up ? 1 : 0);
  if (!up) return;
  const shm::FrameRingStatus& s = f.status;
  counter(out, "ioct_gpu_groups_consumed_total", "ring groups ioct-gpu read intact",
          s.groups_consumed);
  counter(out, "ioct_gpu_groups_dropped_total", "ring groups ioct-gpu lost (lapped or behind)",
          s.groups_dropped);
  counter(out, "ioct_gpu_volumes_completed_total", "volumes completed", s.volumes_completed);
  counter(out, "ioct_gpu_passes_total", "live-stage passes (filter, segmentation, render)",
          s.passes);
  counter(out, "ioct_gpu_renders_total", "frames rendered and published, all views", s.renders);
  prom::single(out, "ioct_gpu_group_period_seconds", "gauge",
               "measured time between groups (0: not known yet)",
               static_cast<double>(s.group_period_ns) * 1e-9);
  prom::single(out, "ioct_gpu_producer_live", "gauge",
               "1 while ioct-gpu is attached to a live ioct-rt ring",
               s.source_state == static_cast<std::uint64_t>(shm::SourceState::live) ? 1 : 0);

  prom::family(out, "ioct_gpu_stage_seconds", "histogram",
               "time of one stage: ingest (ring read, processing, placement of a group), filter "
               "and segmentation (per pass), render (per render), publish (a frame encoded into "
               "the frame ring)");
  const std::pair<const char*, const shm::StageHistogram*> stages[] = {
      {"ingest", &s.ingest},
      {"filter", &s.filter},
      {"segmentation", &s.segmentation},
      {"render", &s.render},
      {"publish", &s.publish}};
  for (const auto& [stage, h] : stages) {
    stage_samples(out, "ioct_gpu_stage_seconds", {{"stage", stage}}, *h);
  }
  prom::family(out, "ioct_gpu_published_to_processed_seconds", "histogram",
               "a group's publication by ioct-rt to its placement into the live volume");
  stage_samples(out, "ioct_gpu_published_to_processed_seconds", {}, s.published_to_processed);
  prom::family(out, "ioct_gpu_published_to_rendered_seconds", "histogram",
               "a group's publication by ioct-rt to the render of the pass that took it");
  stage_samples(out, "ioct_gpu_published_to_rendered_seconds", {}, s.published_to_rendered);

  // Absent on the CPU backend: there is no device memory to report, not none in use.
  if (s.device_memory_known != 0) {
    prom::single(out, "ioct_gpu_device_memory_used_bytes", "gauge",
                 "GPU memory in use (all processes on the device)",
                 static_cast<double>(s.device_memory_used_bytes));
    prom::single(out, "ioct_gpu_device_memory_total_bytes", "gauge", "GPU memory in all",
                 static_cast<double>(s.device_memory_total_bytes));
  }
}

}  // namespace ioct::view
