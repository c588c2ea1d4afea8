// ioct-bench-live-chain: the whole live chain of ioct-gpu --backend cuda at the default geometry
// (1376 samples x 512 A-scans x 16 B-scans per group, 128 B-scans per volume), group by group:
// ring -> device (DMA from the registered ring) -> processed into the live volume -> filtered ->
// segmented -> the live view rendered into device memory, the volume never leaving the device.
//
// A ring of 8 slots is filled once with simulated retina groups; a writer thread re-publishes
// them (headers only), so the simulator's CPU cost is not in the figures. The reader is
// CudaLivePipeline and the stages are VolumeStages (CUDA), as in ioct-gpu.
//   latency      one group every --period-us: per group, publish -> processed (in the device
//                volume), -> filtered, -> segmented, -> frame rendered in device memory
//                (p50 / p99 / max over --groups groups; a stage's time is when the device
//                finished it); with --instruments also -> tips found (the classes on the
//                device beside the filter and the segmentation, the tips located on the host
//                meanwhile and their distances added while the device renders; the pass ends
//                with both, so "rendered" is then the later of the frame and the tips).
//   throughput   a closed loop at the maximum rate: the writer publishes as soon as the stages
//                are at most --ahead groups behind (and a ring slot is free), so every group gets
//                processing, filters, segmentation and a render (and with --instruments the
//                detection); A-scans/s over --seconds, with the passes that folded groups (should
//                be none) and the drops.
// Anchors measured in the same run: the pinned host -> device copy of one group, and each stage's
// own kernels on a group already on the device (processing, filters, segmentation, the renderer's
// update and one render of the live view; in a mode rendered from Weiss's per-B-scan median,
// --render-mode, that median too; with --instruments the detection of a group, tips included),
// whose sum is what the chain would take with nothing between the kernels and no two kernels at
// once. --instruments puts a tool in the simulated scene (--sim-instrument, ioct-rt's syntax; by
// default the appliance's forceps over the retina) and runs the detection on every pass, as
// ioct-gpu --instruments does.
#include <cuda_runtime.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "device_timing.hpp"
#include "host_description.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/gpu/cuda/cuda_support.hpp"
#include "ioct/gpu/filters/cuda_volume_filter.hpp"
#include "ioct/gpu/ingest/live_pipeline.hpp"
#include "ioct/gpu/instruments/instrument_detector.hpp"
#include "ioct/gpu/live_stages/render_filter.hpp"
#include "ioct/gpu/live_stages/volume_stages.hpp"
#include "ioct/gpu/processing/cuda_oct_processor.hpp"
#include "ioct/gpu/render/cuda_renderer.hpp"
#include "ioct/gpu/segmentation/cuda_segmenter.hpp"
#include "ioct/sim/instrument_spec.hpp"
#include "latency_summary.hpp"
#include "simulated_group_ring.hpp"

namespace {

using namespace ioct;
using namespace ioct::gpu;

struct Options {
  double seconds = 5.0;
  std::uint32_t slots = 8;
  std::uint32_t groups = 1000;
  std::uint32_t period_us = 5000;
  std::uint32_t ahead = 2;
  std::string render_mode = "enhanced";
  std::string json_path;
  double spin_window_s = live::VolumeStagesConfig{}.spin_window_s;
  bool instruments = false;
  // The tools of the simulated scene with --instruments (ioct-rt's --sim-instrument syntax).
  std::vector<std::string> sim_instruments;
};

// The scene's tools when none is named: the forceps of the appliance's instrument scene
// (docs/live-view.md), jaws over the retina.
constexpr const char* kDefaultSimInstrument = "forceps:x=0.15,y=0,depth=0.49,yaw=200,pitch=20";

// Per group: publish and processed times from the live loop, the stages' times from their pass.
class ChainRecorder final : public LiveEvents {
 public:
  LivePipeline* pipeline = nullptr;
  live::VolumeStages* stages = nullptr;

  void on_volume(const Volume&, const VolumeInfo&) override {}
  void on_group(const shm::SlotHeader& h, const PlacementResult& placed) override {
    const std::uint64_t now = ioct::monotonic_ns();
    {
      std::lock_guard lock(mutex_);
      waiting_.push_back({h.t_publish_ns, now});
    }
    ++groups_processed;
    if (placed.end_position > placed.first_position) {
      GroupStamp stamp;
      stamp.group_index = h.group_index;
      stamp.t_published_ns = h.t_publish_ns;
      stamp.t_processed_ns = now;
      stages->on_bscans(*pipeline, placed.first_position,
                        placed.end_position - placed.first_position, stamp);
    }
  }
  void on_rejected(const shm::SlotHeader&, const std::string& problem) override {
    throw std::runtime_error("bench group rejected: " + problem);
  }
  void on_restart(bool) override {}

  // The stages' thread.
  void on_pass(const live::StagesPass& pass) {
    std::lock_guard lock(mutex_);
    if (pass.groups > 1) ++folded_passes;
    for (std::uint64_t i = 0; i < pass.groups && !waiting_.empty(); ++i) {
      const Waiting w = waiting_.front();
      waiting_.pop_front();
      const auto since = [&](std::uint64_t t) { return t > w.publish_ns ? t - w.publish_ns : 0; };
      processed.push_back(since(w.processed_ns));
      filtered.push_back(since(pass.filtered_ns));
      segmented.push_back(since(pass.segmented_ns));
      rendered.push_back(since(pass.rendered_ns));
      if (pass.detected_ns != 0) detected.push_back(since(pass.detected_ns));
    }
    groups_through_stages.fetch_add(pass.groups, std::memory_order_release);
  }

  void reset() {
    std::lock_guard lock(mutex_);
    processed.clear();
    filtered.clear();
    segmented.clear();
    rendered.clear();
    detected.clear();
    folded_passes = 0;
  }

  std::atomic<std::uint64_t> groups_processed{0};
  std::atomic<std::uint64_t> groups_through_stages{0};
  std::vector<std::uint64_t> processed, filtered, segmented, rendered, detected;  // since publish
  std::uint64_t folded_passes = 0;
  std::mutex mutex_;

 private:
  struct Waiting {
    std::uint64_t publish_ns, processed_ns;
  };
  std::deque<Waiting> waiting_;
};

double ms(double ns) {
  return ns * 1e-6;
}

// Median device time of `work` enqueued on `stream`, over `repetitions` (after one warm-up).
template <class Work>
double kernel_ms(cudaStream_t stream, int repetitions, Work&& work) {
  return bench::median(bench::device_ms_each(stream, 1, repetitions, work));
}

struct KernelAnchors {
  double processing = 0, filter = 0, segment = 0, render_update = 0, render = 0;
  double render_filter = 0;  // the renderer's per-B-scan median (Weiss's modes; else 0)
  double detect = 0;         // instrument detection of a group, tips included (else 0)
  double sum() const {
    return processing + filter + segment + render_filter + render_update + render + detect;
  }
};

// Each stage's own kernels for one group of `volume` (the live volume after the run, so the
// segmentation and the renderer see a real retina), the data already on the device.
KernelAnchors measure_kernels(const shm::RingGeometry& g, const Volume& volume,
                              const live::VolumeStagesConfig& config) {
  KernelAnchors k;
  const VolumeDims dims = VolumeDims::of(volume);
  cuda::Stream stream;
  {
    CudaOctProcessor processor(OctProcessorConfig{});
    processor.prepare(g);
    cuda::DeviceArray<std::uint16_t> raw(g.group_payload_bytes() / 2);
    IOCT_CUDA_CHECK(cudaMemset(raw.data(), 0x11, raw.bytes()));
    cuda::DeviceArray<std::uint8_t> pixels(dims.bytes());
    shm::SlotHeader header{};
    DevicePixelTarget target;
    target.pixels = pixels.data();
    k.processing = kernel_ms(processor.stream(), 20, [&](int r) {
      bench::describe_group(header, g, static_cast<std::uint64_t>(r % 8));
      for (std::uint32_t b = 0; b < g.bscans_per_group; ++b) {
        target.position[b] = static_cast<std::int32_t>(header.bscans[b].bscan_in_volume);
      }
      processor.enqueue_transform(header, raw.data(), nullptr);
      processor.enqueue_pixels(header, 0, g.bscans_per_group, target);
    });
  }
  cuda::DeviceArray<std::uint8_t> in(dims.bytes()), out(dims.bytes());
  IOCT_CUDA_CHECK(
      cudaMemcpy(in.data(), volume.pixels().data(), dims.bytes(), cudaMemcpyHostToDevice));
  const VolumeRef in_ref = VolumeRef::on_device(in.data(), dims, stream.get());
  const VolumeRef out_ref = VolumeRef::on_device(out.data(), dims, stream.get());
  const MutableVolumeRef out_mut = MutableVolumeRef::on_device(out.data(), dims, stream.get());
  const std::uint32_t group = g.bscans_per_group;
  const std::uint32_t groups = dims.bscans / group;
  filters::CudaVolumeFilter filter(config.filter);
  filter.filter_group(in_ref, out_mut, {0, dims.bscans});
  k.filter = kernel_ms(stream.get(), 40, [&](int r) {
    filter.filter_group(in_ref, out_mut, {(r % groups) * group, group});
  });
  segmentation::CudaSegmenter segmenter(config.segmentation, config.sampling);
  for (std::uint32_t b = 0; b < dims.bscans; b += group) {
    segmenter.segment_group(out_ref, {b, group}, nullptr);
  }
  k.segment = kernel_ms(stream.get(), 40, [&](int r) {
    segmenter.segment_group(out_ref, {(r % groups) * group, group}, nullptr);
  });
  // Weiss's modes render a second volume, the input's median per B-scan (render_filter.hpp).
  cuda::DeviceArray<std::uint8_t> median(dims.bytes());
  const VolumeRef median_ref = VolumeRef::on_device(median.data(), dims, stream.get());
  const bool bscan_median =
      config.render_filter_by_mode && live::renders_from_bscan_median(config.render.mode);
  if (bscan_median) {
    const MutableVolumeRef median_mut =
        MutableVolumeRef::on_device(median.data(), dims, stream.get());
    filters::CudaVolumeFilter median_filter(
        live::render_filter_for(config.render.mode, config.filter));
    median_filter.filter_group(in_ref, median_mut, {0, dims.bscans});
    k.render_filter = kernel_ms(stream.get(), 40, [&](int r) {
      median_filter.filter_group(in_ref, median_mut, {(r % groups) * group, group});
    });
  }
  const VolumeRef rendered_ref = bscan_median ? median_ref : out_ref;
  render::CudaRenderer renderer;
  renderer.use_stream(stream.get());
  renderer.update_bscans(rendered_ref, 0, dims.bscans, segmenter.device_surfaces());
  k.render_update = kernel_ms(stream.get(), 40, [&](int r) {
    renderer.update_bscans(rendered_ref, (r % groups) * group, group, segmenter.device_surfaces());
  });
  k.render = kernel_ms(stream.get(), 40, [&](int) { renderer.render_on_device(config.render); });
  if (config.instruments.enabled) {
    // As in the chain: the unfiltered input read in place, the surfaces on the host; the call
    // returns with the tips, so its time is taken on the host clock.
    const auto detector = instruments::make_instrument_detector(Backend::cuda, config.instruments,
                                                                config.sampling, 1);
    segmentation::Surfaces surfaces;
    segmenter.download_surfaces(surfaces, stream.get());
    instruments::InstrumentFindings findings;
    detector->detect_group(in_ref, {0, dims.bscans}, surfaces, findings);
    std::vector<double> detect_ms;
    for (int r = 0; r < 40; ++r) {
      const std::uint64_t t0 = ioct::monotonic_ns();
      detector->detect_group(in_ref, {(r % groups) * group, group}, surfaces, findings);
      detect_ms.push_back(ms(static_cast<double>(ioct::monotonic_ns() - t0)));
    }
    k.detect = bench::median(detect_ms);
  }
  return k;
}

struct Quantiles {
  double p50, p99, max;
};
Quantiles quantiles(const std::vector<std::uint64_t>& samples) {
  const bench::LatencySummary s = bench::summarize(samples);
  return {ms(s.p50_ns), ms(s.p99_ns), ms(s.max_ns)};
}

int run(const Options& o) {
  if (const std::optional<std::string> problem = cuda_device_problem()) {
    std::fprintf(stderr, "ioct-bench-live-chain: %s\n", problem->c_str());
    return 2;
  }
  cudaDeviceProp props{};
  IOCT_CUDA_CHECK(cudaGetDeviceProperties(&props, 0));
  const bench::HostDescription host = bench::describe_host();
  std::printf("ioct-bench-live-chain\n%sGPU: %s, %d SMs\n", bench::to_text(host).c_str(),
              props.name, props.multiProcessorCount);
  const shm::RingGeometry g;  // the default geometry
  std::printf("the stages' thread awake %.3f ms on each side of a group's expected hand-over\n",
              o.spin_window_s * 1e3);
  std::printf("geometry: %u samples x %u A-scans x %u B-scans per group, %u per volume\n",
              g.samples_per_ascan, g.ascans_per_bscan, g.bscans_per_group, g.bscans_per_volume);
  std::vector<sim::InstrumentConfig> tools;
  if (o.instruments) {
    const std::vector<std::string> specs = o.sim_instruments.empty()
                                               ? std::vector<std::string>{kDefaultSimInstrument}
                                               : o.sim_instruments;
    for (std::size_t i = 0; i < specs.size(); ++i) {
      try {
        tools.push_back(
            sim::parse_instrument_spec(specs[i], "--sim-instrument[" + std::to_string(i) + "]"));
      } catch (const std::exception& e) {
        std::fprintf(stderr, "ioct-bench-live-chain: %s\n", e.what());
        return 2;
      }
      std::printf("instrument in the scene: %s\n", specs[i].c_str());
    }
  }
  bench::SimulatedGroupRing ring("live", g, o.slots, tools);

  ChainRecorder recorder;
  live::VolumeStagesConfig config;
  config.backend = Backend::cuda;
  config.render.mode = render::parse_render_mode(o.render_mode);
  config.final_modes = {};
  config.nice = 0;
  config.spin_window_s = o.spin_window_s;
  config.instruments.enabled = o.instruments;
  config.on_pass = [&recorder](const live::StagesPass& pass) { recorder.on_pass(pass); };
  live::VolumeStages stages(config);
  LivePipelineOptions options;
  options.host_volumes = false;
  auto pipeline =
      make_live_pipeline(Backend::cuda, OctProcessorConfig{},
                         shm::RingReader::attach(ring.name(), {"bench", false}), options);
  recorder.pipeline = pipeline.get();
  recorder.stages = &stages;

  // Polls until the ring is empty and the stages have had every group handed over; throws when
  // nothing moves for 10 s.
  const auto settle = [&] {
    std::uint64_t last = 0;
    std::uint64_t since = ioct::monotonic_ns();
    for (;;) {
      const bool idle = pipeline->poll(recorder) == shm::PollStatus::empty;
      const std::uint64_t through = recorder.groups_through_stages.load();
      if (idle && through >= recorder.groups_processed.load()) return;
      if (through != last) {
        last = through;
        since = ioct::monotonic_ns();
      } else if (ioct::monotonic_ns() - since > 10'000'000'000ull) {
        throw std::runtime_error("the chain made no progress for 10 s (" + std::to_string(through) +
                                 " groups through the stages, " +
                                 std::to_string(recorder.groups_processed.load()) +
                                 " processed): " + stages.status());
      }
    }
  };

  // Catch up with the groups the fill published, then a paced warm-up (graphs, allocations).
  std::atomic<bool> stop{false};
  const auto paced = [&](std::uint32_t groups, std::uint32_t period_us) {
    std::atomic<bool> finished{false};
    std::thread writer([&] {
      auto next = std::chrono::steady_clock::now();
      for (std::uint32_t i = 0; i < groups; ++i) {
        next += std::chrono::microseconds(period_us);
        std::this_thread::sleep_until(next);
        ring.publish();
      }
      finished.store(true);
    });
    const std::uint64_t dropped_before = pipeline->reader().counters().dropped();
    while (!finished.load()) pipeline->poll(recorder);
    writer.join();
    settle();
    return pipeline->reader().counters().dropped() - dropped_before;
  };
  settle();
  std::fprintf(stderr, "caught up: %llu groups through the stages; warming up\n",
               static_cast<unsigned long long>(recorder.groups_through_stages.load()));
  paced(2 * g.bscans_per_volume / g.bscans_per_group, 5000);
  recorder.reset();
  std::fprintf(stderr, "latency: %u groups, one every %u us\n", o.groups, o.period_us);

  // Latency, one group every period.
  const std::uint64_t latency_dropped = paced(o.groups, o.period_us);
  std::vector<std::uint64_t> processed, filtered, segmented, rendered, detected;
  std::uint64_t latency_folded = 0;
  {
    std::lock_guard lock(recorder.mutex_);
    processed = recorder.processed;
    filtered = recorder.filtered;
    segmented = recorder.segmented;
    rendered = recorder.rendered;
    detected = recorder.detected;
    latency_folded = recorder.folded_passes;
  }
  recorder.reset();

  // Throughput, closed loop at the maximum rate.
  std::fprintf(stderr, "throughput: %.1f s closed loop\n", o.seconds);
  const std::uint64_t margin = ring.slots() - 2;
  std::atomic<std::uint64_t> reader_at{pipeline->reader().position()};
  const std::uint64_t base_published = ring.published();
  const std::uint64_t base_staged = recorder.groups_through_stages.load();
  std::thread writer([&] {
    while (!stop.load(std::memory_order_relaxed)) {
      // (The ring's own slot limit: the reader must have copied all but `margin` groups.)
      const std::uint64_t ahead =
          (ring.published() - base_published) -
          (recorder.groups_through_stages.load(std::memory_order_acquire) - base_staged);
      if (ahead < o.ahead &&
          ring.published() < reader_at.load(std::memory_order_acquire) + margin) {
        ring.publish();
      } else {
        std::this_thread::yield();
      }
    }
  });
  const auto step = [&] {
    pipeline->poll(recorder);
    reader_at.store(pipeline->reader().position(), std::memory_order_release);
  };
  for (const std::uint64_t warm = recorder.groups_through_stages.load() + 50;
       recorder.groups_through_stages.load() < warm;) {
    step();
  }
  recorder.reset();
  const shm::ReaderCounters r0 = pipeline->reader().counters();
  const std::uint64_t s0 = recorder.groups_through_stages.load();
  const std::uint64_t t0 = ioct::monotonic_ns();
  std::uint64_t now = t0;
  while (now - t0 < static_cast<std::uint64_t>(o.seconds * 1e9)) {
    step();
    now = ioct::monotonic_ns();
  }
  const std::uint64_t staged = recorder.groups_through_stages.load() - s0;
  const shm::ReaderCounters r1 = pipeline->reader().counters();
  stop.store(true);
  writer.join();
  pipeline->drain(recorder);
  settle();
  const double seconds = static_cast<double>(now - t0) * 1e-9;
  const double ascans_per_s = static_cast<double>(staged * g.ascans_per_group()) / seconds;
  const std::uint64_t dropped = r1.dropped() - r0.dropped();
  std::uint64_t throughput_folded = 0;
  {
    std::lock_guard lock(recorder.mutex_);
    throughput_folded = recorder.folded_passes;
  }

  // The live volume as it ended, for the kernel anchors.
  Volume live_volume;
  pipeline->copy_bscans(0, pipeline->shape().bscans, live_volume);
  const std::filesystem::path out =
      std::filesystem::temp_directory_path() / ("ioct-bench-live-" + std::to_string(::getpid()));
  std::filesystem::create_directories(out);
  const nlohmann::json stages_summary = stages.finish(out);
  std::filesystem::remove_all(out);
  if (!stages_summary.at("problem").get<std::string>().empty()) {
    std::fprintf(stderr, "stages failed: %s\n", stages_summary.at("problem").dump().c_str());
    return 1;
  }

  const double pinned = bench::pinned_h2d_copy_ms(g.group_payload_bytes());
  const KernelAnchors k = measure_kernels(g, live_volume, config);

  const Quantiles qp = quantiles(processed), qf = quantiles(filtered), qs = quantiles(segmented),
                  qr = quantiles(rendered);
  std::printf(
      "\nlatency from publish, one group every %u us (%zu groups, %llu dropped, %llu "
      "passes folded):\n",
      o.period_us, rendered.size(), static_cast<unsigned long long>(latency_dropped),
      static_cast<unsigned long long>(latency_folded));
  std::printf("  %-36s p50 %7.3f ms  p99 %7.3f ms  max %7.3f ms\n", "-> processed (device volume)",
              qp.p50, qp.p99, qp.max);
  std::printf("  %-36s p50 %7.3f ms  p99 %7.3f ms  max %7.3f ms\n", "-> filtered", qf.p50, qf.p99,
              qf.max);
  std::printf("  %-36s p50 %7.3f ms  p99 %7.3f ms  max %7.3f ms\n", "-> segmented", qs.p50, qs.p99,
              qs.max);
  std::printf(
      "  %-36s p50 %7.3f ms  p99 %7.3f ms  max %7.3f ms   target p99 <= 2 ms: %s\n",
      o.instruments ? "-> frame rendered and tips found" : "-> frame rendered (device memory)",
      qr.p50, qr.p99, qr.max, qr.p99 <= 2.0 ? "met" : "NOT met");
  std::optional<Quantiles> qd;
  if (o.instruments) {
    if (detected.size() != rendered.size()) {
      std::fprintf(stderr, "%zu passes found tips of %zu rendered\n", detected.size(),
                   rendered.size());
      return 1;
    }
    qd = quantiles(detected);
    std::printf(
        "  %-36s p50 %7.3f ms  p99 %7.3f ms  max %7.3f ms   (found while the device works on the "
        "pass; the frame is published after both)\n",
        "-> tips found", qd->p50, qd->p99, qd->max);
  }
  std::printf(
      "  anchor: pinned H2D copy of a group %.3f ms (%.1f GB/s); stages' own kernels "
      "per group: processing %.3f + filters %.3f + segmentation %.3f + the renderer's "
      "per-B-scan median %.3f + the renderer's update (texture, bricks, sums, layer reference) "
      "%.3f + render %.3f + instrument detection with its tips %.3f = %.3f ms (ratio of the "
      "p50 to %s / sum %.2f)\n",
      pinned, static_cast<double>(g.group_payload_bytes()) / (pinned * 1e6), k.processing, k.filter,
      k.segment, k.render_filter, k.render_update, k.render, k.detect, k.sum(),
      qd ? "rendered and tips found" : "frame rendered", qr.p50 / k.sum());
  const double anchor_rate = static_cast<double>(g.ascans_per_group()) / (k.sum() * 1e-3);
  const double pinned_rate = static_cast<double>(g.ascans_per_group()) / (pinned * 1e-3);
  std::printf(
      "\nfull chain, closed loop at the maximum rate (at most %u groups ahead of the "
      "stages):\n  %.2f M A-scans/s with every stage on every group (%llu groups in "
      "%.2f s, %llu passes folded groups, %llu dropped)   target >= 10 M/s, 0 drops: %s\n",
      o.ahead, ascans_per_s / 1e6, static_cast<unsigned long long>(staged), seconds,
      static_cast<unsigned long long>(throughput_folded), static_cast<unsigned long long>(dropped),
      ascans_per_s >= 10e6 && dropped == 0 && throughput_folded == 0 ? "met" : "NOT met");
  std::printf(
      "  anchor: the kernels' sum as a rate %.2f M A-scans/s (%.1f %%); pinned H2D alone "
      "%.2f M A-scans/s\n",
      anchor_rate / 1e6, 100.0 * ascans_per_s / anchor_rate, pinned_rate / 1e6);
  std::printf("stages: %s; render mode %s; instruments %s\n",
              stages_summary.at("backends").get<std::string>().c_str(), o.render_mode.c_str(),
              o.instruments ? "on" : "off");

  if (!o.json_path.empty()) {
    const auto q = [](const Quantiles& x) {
      return nlohmann::json{{"p50", x.p50}, {"p99", x.p99}, {"max", x.max}};
    };
    nlohmann::json report = {{"benchmark", "ioct-bench-live-chain"},
                             {"host", bench::to_json(host)},
                             {"gpu", props.name},
                             {"spin_window_s", o.spin_window_s},
                             {"render_mode", o.render_mode},
                             {"instruments", o.instruments},
                             {"latency",
                              {{"period_us", o.period_us},
                               {"groups", rendered.size()},
                               {"dropped", latency_dropped},
                               {"folded_passes", latency_folded},
                               {"processed_ms", q(qp)},
                               {"filtered_ms", q(qf)},
                               {"segmented_ms", q(qs)},
                               {"rendered_ms", q(qr)},
                               {"detected_ms", qd ? q(*qd) : nlohmann::json()}}},
                             {"throughput",
                              {{"ascans_per_s", ascans_per_s},
                               {"groups", staged},
                               {"seconds", seconds},
                               {"folded_passes", throughput_folded},
                               {"dropped", dropped},
                               {"ahead", o.ahead}}},
                             {"anchors",
                              {{"pinned_h2d_group_ms", pinned},
                               {"processing_ms", k.processing},
                               {"filter_ms", k.filter},
                               {"segment_ms", k.segment},
                               {"render_ms", k.render},
                               {"render_update_ms", k.render_update},
                               {"render_filter_ms", k.render_filter},
                               {"detect_ms", k.detect},
                               {"kernel_sum_ms", k.sum()}}},
                             {"stages", stages_summary}};
    std::ofstream(o.json_path) << report.dump(2) << "\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // lines reach a log even if the run is cut short
  Options o;
  CLI::App app{
      "The live chain of ioct-gpu (CUDA) group by group: publish -> frame latency and "
      "full-chain throughput at the default geometry, beside same-run anchors"};
  app.add_option("--seconds", o.seconds, "throughput run")->check(CLI::Range(0.5, 600.0));
  app.add_option("--groups", o.groups, "latency samples")->check(CLI::Range(10u, 100000u));
  app.add_option("--period-us", o.period_us, "latency: one group every")
      ->check(CLI::Range(500u, 1000000u));
  app.add_option("--ahead", o.ahead, "throughput: groups the writer may be ahead of the stages")
      ->check(CLI::Range(1u, 6u));
  app.add_option("--slots", o.slots, "ring slots")->check(CLI::Range(4u, 64u));
  app.add_option("--spin-window-s", o.spin_window_s,
                 "the stages' thread awake this long around a group's expected hand-over (0: "
                 "asleep until it comes, as before ring.spin_window_s)")
      ->check(CLI::Range(0.0, 0.1));
  app.add_option("--render-mode", o.render_mode,
                 "the live view's mode (ioct-gpu's render.mode); layer-aware, la-mip and "
                 "axial-colorization add the renderer's per-B-scan median");
  CLI::Option* instruments =
      app.add_flag("--instruments", o.instruments,
                   "a tool in the simulated scene and the instrument detection on every pass");
  app.add_option("--sim-instrument", o.sim_instruments,
                 "with --instruments: a tool of the scene, as ioct-rt's --sim-instrument (default "
                 "the appliance's forceps; repeat for more)")
      ->needs(instruments);
  app.add_option("--json", o.json_path, "also write the figures as JSON");
  CLI11_PARSE(app, argc, argv);
  try {
    return run(o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ioct-bench-live-chain: %s\n", e.what());
    return 1;
  }
}
