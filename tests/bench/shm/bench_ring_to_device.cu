// bench_ring_to_device: how fast groups travel from the ring straight to the GPU.
//
// A ring at the default geometry is created and every slot filled; a RingReader maps it read-only
// and the whole mapping is registered with cudaHostRegister (read-only), as ioct-gpu does. Each
// copy is begin_read -> cudaMemcpyAsync slot -> device -> stream synchronize -> end_read, so the
// seqlock check is inside what is timed. The anchor is a pinned (cudaMallocHost) buffer of the
// same size copied to the device by the very same loop in the same run; pinned back-to-back,
// pageable and device-to-device copies are printed for context. Times come from CUDA events;
// each path runs a few warm-up repetitions and the median repetition is reported.
#include <cuda_runtime.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "bench_ring_fixture.hpp"
#include "host_description.hpp"
#include "ioct/gpu/cuda/cuda_support.hpp"
#include "ioct/shm/ring_layout.hpp"
#include "ioct/shm/ring_reader.hpp"
#include "latency_summary.hpp"
#include "slot_pattern.hpp"

#ifndef IOCT_BENCH_CUDA_ARCHITECTURES
#define IOCT_BENCH_CUDA_ARCHITECTURES "unknown"
#endif

namespace {

using ioct::bench::BenchRing;
using ioct::bench::SlotFill;

// Exit status when this machine cannot run the benchmark at all (no GPU, no code for its GPU).
constexpr int kExitNoUsableDevice = 2;

// The GPU is missing or unusable: a fact about the machine, not a failure of what is measured.
class NoUsableDevice : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

using ioct::gpu::cuda::describe;

// Counts the words of `words` that differ from slot `slot`'s pattern.
__global__ void count_pattern_mismatches(const std::uint64_t* words, std::uint64_t count,
                                         std::uint64_t slot, unsigned long long* mismatches) {
  const std::uint64_t stride = std::uint64_t{gridDim.x} * blockDim.x;
  for (std::uint64_t i = std::uint64_t{blockIdx.x} * blockDim.x + threadIdx.x; i < count;
       i += stride) {
    if (words[i] != ioct::bench::slot_pattern_word(slot, i)) atomicAdd(mismatches, 1ull);
  }
}

// How the read-only ring mapping ended up registered with CUDA.
enum class Registration { read_only, default_flags, none };

const char* to_string(Registration r) {
  switch (r) {
    case Registration::read_only:
      return "registered read-only (cudaHostRegisterReadOnly)";
    case Registration::default_flags:
      return "registered with default flags (read-only flag refused)";
    case Registration::none:
      return "NOT registered: copies are staged by the driver like pageable memory";
  }
  return "?";
}

// Registers the mapping for the lifetime of the object, falling back as far as it must; `note`
// says what was refused and why.
class HostRegistration {
 public:
  HostRegistration(const void* address, std::size_t bytes, int device) : address_(address) {
    int supported = 0;
    IOCT_CUDA_CHECK(cudaDeviceGetAttribute(&supported, cudaDevAttrHostRegisterSupported, device));
    if (supported == 0) {
      note_ = "the device does not support cudaHostRegister (cudaDevAttrHostRegisterSupported = 0)";
      return;
    }
    void* target = const_cast<void*>(address);
    int read_only_supported = 0;
    IOCT_CUDA_CHECK(cudaDeviceGetAttribute(&read_only_supported,
                                           cudaDevAttrHostRegisterReadOnlySupported, device));
    if (read_only_supported != 0) {
      const cudaError_t status = cudaHostRegister(target, bytes, cudaHostRegisterReadOnly);
      if (status == cudaSuccess) {
        kind_ = Registration::read_only;
        return;
      }
      cudaGetLastError();  // clear it: the fallback below decides
      note_ = "cudaHostRegister(cudaHostRegisterReadOnly) failed: " + describe(status);
    } else {
      note_ =
          "the device does not support cudaHostRegisterReadOnly "
          "(cudaDevAttrHostRegisterReadOnlySupported = 0)";
    }
    // A read-only mapping can usually not be pinned for writing; try, and say so either way.
    const cudaError_t status = cudaHostRegister(target, bytes, cudaHostRegisterDefault);
    if (status == cudaSuccess) {
      kind_ = Registration::default_flags;
      return;
    }
    cudaGetLastError();
    note_ += "; cudaHostRegister(cudaHostRegisterDefault) failed too: " + describe(status);
  }
  ~HostRegistration() {
    if (kind_ != Registration::none) cudaHostUnregister(const_cast<void*>(address_));
  }
  HostRegistration(const HostRegistration&) = delete;
  HostRegistration& operator=(const HostRegistration&) = delete;

  Registration kind() const { return kind_; }
  const std::string& note() const { return note_; }

 private:
  const void* address_;
  Registration kind_ = Registration::none;
  std::string note_;
};

// --- The device ---

struct DeviceInfo {
  int index = 0;
  cudaDeviceProp props{};
  int driver_version = 0;
  int runtime_version = 0;
};

// Fails with NoUsableDevice when there is no GPU, or when this binary has no code for it.
DeviceInfo select_device(int index) {
  int count = 0;
  const cudaError_t status = cudaGetDeviceCount(&count);
  if (status != cudaSuccess) {
    throw NoUsableDevice("no usable CUDA device: cudaGetDeviceCount failed: " + describe(status) +
                         ". This benchmark needs an NVIDIA GPU and its driver.");
  }
  if (count == 0) throw NoUsableDevice("no CUDA device found");
  if (index < 0 || index >= count) {
    throw NoUsableDevice("--device " + std::to_string(index) + " does not exist (" +
                         std::to_string(count) + " device(s))");
  }
  DeviceInfo info;
  info.index = index;
  IOCT_CUDA_CHECK(cudaSetDevice(index));
  IOCT_CUDA_CHECK(cudaGetDeviceProperties(&info.props, index));
  IOCT_CUDA_CHECK(cudaDriverGetVersion(&info.driver_version));
  IOCT_CUDA_CHECK(cudaRuntimeGetVersion(&info.runtime_version));
  // The kernel can only run if the binary carries code (SASS or PTX) this GPU can use.
  cudaFuncAttributes attributes{};
  const cudaError_t image = cudaFuncGetAttributes(&attributes, count_pattern_mismatches);
  if (image != cudaSuccess) {
    cudaGetLastError();
    const std::string cc =
        std::to_string(info.props.major) + "." + std::to_string(info.props.minor);
    throw NoUsableDevice(
        "GPU " + std::to_string(index) + " (" + info.props.name + ", compute capability " + cc +
        ") is not supported by this build: it "
        "carries code for CUDA architectures " IOCT_BENCH_CUDA_ARCHITECTURES " only (" +
        describe(image) +
        "); rebuild with "
        "-DCMAKE_CUDA_ARCHITECTURES=" +
        std::to_string(info.props.major) + std::to_string(info.props.minor));
  }
  return info;
}

std::string version_text(int version) {
  return std::to_string(version / 1000) + "." + std::to_string(version % 1000 / 10);
}

// --- Timing ---

// One way of moving a group to the device. `copy` issues one copy and whatever protocol goes
// with it; `prepare` runs before each batch, outside the timed region.
struct CopyPath {
  std::string name;
  std::string key;  // for JSON
  std::function<void()> prepare;
  std::function<void()> copy;
  std::vector<double> gbps;  // one per timed repetition
};

// Runs `batches` batches of `per_batch` copies, each batch between two events on `stream`;
// returns the summed event time in ms.
double time_batches(CopyPath& path, std::uint64_t batches, std::uint64_t per_batch,
                    cudaStream_t stream, const ioct::gpu::cuda::TimingEvent& start,
                    const ioct::gpu::cuda::TimingEvent& stop) {
  double total_ms = 0;
  for (std::uint64_t b = 0; b < batches; ++b) {
    if (path.prepare) path.prepare();
    IOCT_CUDA_CHECK(cudaEventRecord(start.get(), stream));
    for (std::uint64_t k = 0; k < per_batch; ++k) path.copy();
    IOCT_CUDA_CHECK(cudaEventRecord(stop.get(), stream));
    IOCT_CUDA_CHECK(cudaEventSynchronize(stop.get()));
    float ms = 0;
    IOCT_CUDA_CHECK(cudaEventElapsedTime(&ms, start.get(), stop.get()));
    total_ms += ms;
  }
  return total_ms;
}

// Words of `device_words` (a group on the device) that are not slot `slot`'s pattern.
unsigned long long count_mismatches(const void* device_words, std::uint64_t bytes,
                                    std::uint64_t slot, cudaStream_t stream) {
  ioct::gpu::cuda::DeviceArray<unsigned long long> counter(1);
  IOCT_CUDA_CHECK(cudaMemsetAsync(counter.data(), 0, counter.bytes(), stream));
  count_pattern_mismatches<<<264, 256, 0, stream>>>(static_cast<const std::uint64_t*>(device_words),
                                                    bytes / sizeof(std::uint64_t), slot,
                                                    counter.data());
  IOCT_CUDA_CHECK(cudaGetLastError());
  unsigned long long mismatches = 0;
  IOCT_CUDA_CHECK(cudaMemcpyAsync(&mismatches, counter.data(), sizeof(mismatches),
                                  cudaMemcpyDeviceToHost, stream));
  IOCT_CUDA_CHECK(cudaStreamSynchronize(stream));
  return mismatches;
}

struct Options {
  std::uint64_t groups = 70;
  int repetitions = 10;
  int warmup = 2;
  std::uint64_t slots = 8;
  int device = 0;
  bool quick = false;
  std::string json_path;
};

// The most slots (2..wanted) whose ring fits in /dev/shm with some room to spare; `wanted`
// when the free space is unknown (0), leaving the verdict to the ring's own creation.
std::uint64_t slots_that_fit(const ioct::shm::RingGeometry& geometry, std::uint64_t wanted,
                             std::uint64_t shm_free) {
  if (shm_free == 0) return wanted;
  constexpr std::uint64_t kSpare = 16ull << 20;  // reader status objects, other users
  for (std::uint64_t slots = wanted; slots >= 2; --slots) {
    if (ioct::shm::RingLayout::compute(geometry, slots).total_bytes + kSpare <= shm_free) {
      return slots;
    }
  }
  return 0;
}

int run(const Options& options) {
  const DeviceInfo device = select_device(options.device);
  const ioct::bench::HostDescription host = ioct::bench::describe_host();
  std::printf("bench_ring_to_device: ring slot -> GPU copies\n%s", to_text(host).c_str());
  std::printf(
      "GPU %d: %s, compute capability %d.%d, %d SMs, PCI %04x:%02x:%02x, driver %s, "
      "runtime %s\n",
      device.index, device.props.name, device.props.major, device.props.minor,
      device.props.multiProcessorCount, device.props.pciDomainID, device.props.pciBusID,
      device.props.pciDeviceID, version_text(device.driver_version).c_str(),
      version_text(device.runtime_version).c_str());

  const ioct::shm::RingGeometry geometry{};
  const std::uint64_t shm_free = ioct::bench::shm_free_bytes();
  const std::uint64_t slots = slots_that_fit(geometry, options.slots, shm_free);
  const auto mib = [](std::uint64_t bytes) { return static_cast<double>(bytes) / (1 << 20); };
  if (slots == 0) {
    throw std::runtime_error(
        "/dev/shm has " + std::to_string(shm_free >> 20) + " MiB free; a ring of 2 slots needs " +
        std::to_string(ioct::shm::RingLayout::compute(geometry, 2).total_bytes >> 20) +
        " MiB (enlarge /dev/shm)");
  }
  const std::uint64_t ring_bytes = ioct::shm::RingLayout::compute(geometry, slots).total_bytes;
  std::printf("/dev/shm: %.0f MiB free; ring of %llu slots needs %.0f MiB%s\n", mib(shm_free),
              static_cast<unsigned long long>(slots), mib(ring_bytes),
              slots < options.slots ? " (fewer slots than asked: /dev/shm is small)" : "");

  BenchRing ring("to-device", geometry, slots, SlotFill::pattern);
  ioct::shm::RingReader reader = ring.attach_reader("bench-to-device");
  const std::uint64_t group_bytes = ring.layout().group_payload_bytes;
  HostRegistration registration(reader.mapping(), reader.mapping_bytes(), device.index);
  std::printf("ring mapping: %.1f MB read-only, %s\n",
              static_cast<double>(reader.mapping_bytes()) / 1e6, to_string(registration.kind()));
  if (!registration.note().empty()) std::printf("  note: %s\n", registration.note().c_str());

  ioct::gpu::cuda::Stream stream;
  ioct::gpu::cuda::TimingEvent start;
  ioct::gpu::cuda::TimingEvent stop;
  ioct::gpu::cuda::DeviceArray<std::byte> device_destination(group_bytes);
  ioct::gpu::cuda::DeviceArray<std::byte> device_source(group_bytes);
  ioct::gpu::cuda::PinnedArray<std::byte> pinned(group_bytes);
  std::memcpy(pinned.data(), ioct::bench::slot_payload(reader, 0).data(), group_bytes);
  std::vector<std::byte> pageable(pinned.data(), pinned.data() + group_bytes);
  IOCT_CUDA_CHECK(
      cudaMemcpy(device_source.data(), pinned.data(), group_bytes, cudaMemcpyHostToDevice));

  // Catch the reader up (it starts at the newest group).
  {
    std::vector<std::byte> scratch(group_bytes);
    ioct::shm::SlotHeader header{};
    while (reader.read_next(scratch, header) == ioct::shm::PollStatus::ready) {
    }
  }

  const std::uint64_t per_batch = slots - 1;  // groups the writer can publish without lapping
  const std::uint64_t batches = (options.groups + per_batch - 1) / per_batch;
  const std::uint64_t copies = batches * per_batch;
  cudaStream_t s = stream.get();
  std::uint64_t unexpected_polls = 0;

  const auto synced_h2d = [&, s](const void* source) {
    IOCT_CUDA_CHECK(
        cudaMemcpyAsync(device_destination.data(), source, group_bytes, cudaMemcpyHostToDevice, s));
    IOCT_CUDA_CHECK(cudaStreamSynchronize(s));
  };
  std::vector<CopyPath> paths;
  paths.push_back({"ring slot -> device (seqlock checked)",
                   "ring_to_device",
                   [&] { ring.publish(per_batch); },
                   [&, s] {
                     ioct::shm::ReadTicket ticket;
                     if (reader.begin_read(ticket) != ioct::shm::PollStatus::ready) {
                       ++unexpected_polls;
                       return;
                     }
                     IOCT_CUDA_CHECK(cudaMemcpyAsync(device_destination.data(), ticket.payload,
                                                     ticket.payload_bytes, cudaMemcpyHostToDevice,
                                                     s));
                     // The copy must have landed before end_read can vouch for it.
                     IOCT_CUDA_CHECK(cudaStreamSynchronize(s));
                     reader.end_read(ticket);  // a false return is counted in the drops
                   },
                   {}});
  paths.push_back({"anchor: pinned -> device, same loop",
                   "pinned_to_device",
                   {},
                   [&] { synced_h2d(pinned.data()); },
                   {}});
  paths.push_back({"pinned -> device, back to back",
                   "pinned_to_device_back_to_back",
                   {},
                   [&, s] {
                     IOCT_CUDA_CHECK(cudaMemcpyAsync(device_destination.data(), pinned.data(),
                                                     group_bytes, cudaMemcpyHostToDevice, s));
                   },
                   {}});
  paths.push_back(
      {"pageable -> device", "pageable_to_device", {}, [&] { synced_h2d(pageable.data()); }, {}});
  paths.push_back({"device -> device, back to back",
                   "device_to_device",
                   {},
                   [&, s] {
                     IOCT_CUDA_CHECK(cudaMemcpyAsync(device_destination.data(),
                                                     device_source.data(), group_bytes,
                                                     cudaMemcpyDeviceToDevice, s));
                   },
                   {}});

  // Repetitions interleave the paths, so a drift of clocks or load touches all alike.
  for (int rep = 0; rep < options.warmup + options.repetitions; ++rep) {
    for (CopyPath& path : paths) {
      const double ms = time_batches(path, batches, per_batch, s, start, stop);
      if (rep >= options.warmup) {
        path.gbps.push_back(static_cast<double>(copies * group_bytes) / (ms * 1e6));
      }
    }
  }

  // Check what the timed loops moved: one more ring copy, and the pinned buffer's.
  ring.publish(1);
  ioct::shm::ReadTicket ticket;
  bool ring_copy_intact = false;
  unsigned long long ring_mismatches = 0;
  if (reader.begin_read(ticket) == ioct::shm::PollStatus::ready) {
    IOCT_CUDA_CHECK(cudaMemcpyAsync(device_destination.data(), ticket.payload, ticket.payload_bytes,
                                    cudaMemcpyHostToDevice, s));
    IOCT_CUDA_CHECK(cudaStreamSynchronize(s));
    ring_copy_intact = reader.end_read(ticket);
    ring_mismatches =
        count_mismatches(device_destination.data(), group_bytes, ticket.slot_index, s);
  }
  synced_h2d(pinned.data());
  const unsigned long long pinned_mismatches =
      count_mismatches(device_destination.data(), group_bytes, 0, s);
  const std::uint64_t drops = reader.counters().dropped();

  // Report.
  std::printf(
      "\n%llu copies of %.3f MB per path and repetition (sync after each copy unless "
      "back to back), %d repetitions after %d warm-up; GB = 1e9 bytes\n",
      static_cast<unsigned long long>(copies), static_cast<double>(group_bytes) / 1e6,
      options.repetitions, options.warmup);
  std::printf("  %-40s %12s %10s %10s\n", "", "GB/s median", "min", "max");
  nlohmann::json path_reports = nlohmann::json::array();
  for (const CopyPath& path : paths) {
    const double med = ioct::bench::median(path.gbps);
    const auto [lo, hi] = std::minmax_element(path.gbps.begin(), path.gbps.end());
    std::printf("  %-40s %12.2f %10.2f %10.2f\n", path.name.c_str(), med, *lo, *hi);
    path_reports.push_back({{"path", path.key},
                            {"description", path.name},
                            {"gbps_median", med},
                            {"gbps_min", *lo},
                            {"gbps_max", *hi},
                            {"gbps_per_repetition", path.gbps}});
  }
  const auto median_of = [&](std::size_t i) { return ioct::bench::median(paths[i].gbps); };
  const double ratio_same_loop = median_of(1) > 0 ? median_of(0) / median_of(1) : 0;
  const double ratio_back_to_back = median_of(2) > 0 ? median_of(0) / median_of(2) : 0;
  std::printf("  device -> device counting bytes read and written: %.0f GB/s\n", 2 * median_of(4));
  std::printf(
      "ratio ring / pinned (same loop): %.1f%% (target >= 90%%: %s); ring / pinned back "
      "to back: %.1f%%\n",
      100 * ratio_same_loop, ratio_same_loop >= 0.9 ? "met" : "NOT met", 100 * ratio_back_to_back);
  const bool verified = ring_copy_intact && ring_mismatches == 0 && pinned_mismatches == 0 &&
                        drops == 0 && unexpected_polls == 0;
  std::printf(
      "verification: ring copy %s with %llu wrong words, pinned copy %llu wrong words, "
      "%llu groups dropped, %llu polls not ready: %s\n",
      ring_copy_intact ? "intact" : "LAPPED", ring_mismatches, pinned_mismatches,
      static_cast<unsigned long long>(drops), static_cast<unsigned long long>(unexpected_polls),
      verified ? "ok" : "FAILED");

  if (!options.json_path.empty()) {
    const nlohmann::json report = {
        {"benchmark", "bench_ring_to_device"},
        {"host", to_json(host)},
        {"device",
         {{"index", device.index},
          {"name", device.props.name},
          {"compute_capability",
           std::to_string(device.props.major) + "." + std::to_string(device.props.minor)},
          {"multiprocessors", device.props.multiProcessorCount},
          {"driver", version_text(device.driver_version)},
          {"runtime", version_text(device.runtime_version)},
          {"architectures_built", IOCT_BENCH_CUDA_ARCHITECTURES}}},
        {"ring",
         {{"slots", slots},
          {"slots_asked", options.slots},
          {"group_bytes", group_bytes},
          {"mapping_bytes", reader.mapping_bytes()},
          {"shm_free_bytes", shm_free},
          {"registration", to_string(registration.kind())},
          {"registration_note", registration.note()}}},
        {"options",
         {{"copies_per_repetition", copies},
          {"repetitions", options.repetitions},
          {"warmup", options.warmup},
          {"quick", options.quick}}},
        {"paths", path_reports},
        {"ratio_ring_to_pinned_same_loop", ratio_same_loop},
        {"ratio_ring_to_pinned_back_to_back", ratio_back_to_back},
        {"verified", verified}};
    std::ofstream out(options.json_path);
    out << report.dump(2) << "\n";
    if (!out) throw std::runtime_error("cannot write " + options.json_path);
    std::printf("results written to %s\n", options.json_path.c_str());
  }
  return verified ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  CLI::App app{
      "Ring slot -> GPU copy bandwidth from the registered read-only ring mapping, "
      "beside pinned, pageable and device-to-device copies measured in the same run"};
  app.add_option("--groups", options.groups, "22.5 MB groups copied per path and repetition")
      ->check(CLI::PositiveNumber);
  app.add_option("--reps", options.repetitions, "timed repetitions (the median is reported)")
      ->check(CLI::Range(1, 1000));
  app.add_option("--warmup", options.warmup, "untimed repetitions first")
      ->check(CLI::Range(0, 100));
  app.add_option("--slots", options.slots, "ring slots (fewer if /dev/shm is small)")
      ->check(CLI::Range(2, 64));
  app.add_option("--device", options.device, "CUDA device index");
  app.add_option("--json", options.json_path, "also write the results to this JSON file");
  app.add_flag("--quick", options.quick, "a short run (14 groups, 3 repetitions, 1 warm-up)");
  CLI11_PARSE(app, argc, argv);
  if (options.quick) {
    options.groups = std::min<std::uint64_t>(options.groups, 14);
    options.repetitions = std::min(options.repetitions, 3);
    options.warmup = std::min(options.warmup, 1);
  }
  try {
    return run(options);
  } catch (const NoUsableDevice& e) {
    std::fprintf(stderr, "bench_ring_to_device: %s\n", e.what());
    return kExitNoUsableDevice;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_ring_to_device: %s\n", e.what());
    return 1;
  }
}
