// Throughput of the CPU OCT chain on the default geometry (1376 samples, 512 A-scans, 16 B-scans
// per group), per thread count. The acquisition delivers 100k A-scans/s; "ascans/s" must stay
// above that with margin for the rest of the pipeline.
//
//   ioct-bench-cpu-oct --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <vector>

#include "ioct/gpu/processing/cpu_oct_processor.hpp"
#include "synthetic_spectra.hpp"

namespace ioct::gpu {
namespace {

struct DefaultGroup {
  shm::RingGeometry geometry;
  std::vector<std::uint16_t> payload;
  shm::SlotHeader header{};

  DefaultGroup() : payload(geometry.group_payload_bytes() / 2) {
    testing::SpectrumSynthesizer synthesizer(testing::SpectrumModel{geometry.samples_per_ascan}, 5);
    testing::fill_group(
        geometry, synthesizer,
        [](std::uint32_t b, std::uint32_t r) {
          return std::vector<testing::Reflector>{
              {150.0 + (r % 50), 30.0}, {300.0 + b, 10.0}, {420.0, 4.0}};
        },
        payload);
    header.bscan_count = geometry.bscans_per_group;
    header.active_ascan_begin = 0;
    header.active_ascan_end = geometry.ascans_per_bscan;
    for (std::uint32_t b = 0; b < geometry.bscans_per_group; ++b) {
      header.bscans[b] = testing::marker_for(0, b, geometry.bscans_per_volume, true);
    }
  }
};

void BM_CpuOctProcessor(benchmark::State& state) {
  static const DefaultGroup group;
  OctProcessorConfig config;
  config.threads = static_cast<std::uint32_t>(state.range(0));
  config.fft.rigor = FftRigor::measure;
  CpuOctProcessor processor(config);
  processor.prepare(group.geometry);
  ProcessedGroup out;
  for (auto _ : state) {
    processor.process(RawGroup{group.header, group.payload}, out);
    benchmark::DoNotOptimize(out.pixels.data());
  }
  const double ascans = static_cast<double>(group.geometry.ascans_per_group());
  state.counters["ascans/s"] = benchmark::Counter(ascans * static_cast<double>(state.iterations()),
                                                  benchmark::Counter::kIsRate);
  state.counters["x_100kHz"] = benchmark::Counter(
      ascans * static_cast<double>(state.iterations()) / 100e3, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_CpuOctProcessor)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace ioct::gpu

BENCHMARK_MAIN();
