// What the record path costs the real-time thread: the copy a "one memcpy per record" design
// would make, against what UsbDigitizer copies (staged body parts at group boundaries and the
// tail packets), measured on the default geometry. Prints one figure per line.
//
//   bench_usb_records [groups]      (re-executes itself under libumockdev-preload)
//
// Part 1 times memcpy of one record (one B-scan) into a slot-sized buffer on this machine.
// Part 2 streams the default geometry from the emulated instrument through libusb and reports
// the real-time thread's CPU time per group (CLOCK_THREAD_CPUTIME_ID, so waiting is excluded)
// and how many payload bytes it copied. The emulated transport itself (umockdev's socket) is
// far slower than USB 3; its throughput is printed only to show what the run was.
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "emulated_instrument.hpp"
#include "ioct/hal/usb/usb_digitizer.hpp"
#include "umockdev_reexec.hpp"

namespace {

double thread_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) / 1e6;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  using namespace ioct::hal;
  using namespace ioct::hal::usb;
  test::reexec_under_umockdev(argv);
  const int groups = argc > 1 ? std::max(2, std::atoi(argv[1])) : 6;

  DigitizerConfig config;  // 1376 samples x 512 A-scans (+26) x 16 B-scans
  config.timeout_ms = 5000;
  const std::size_t record_bytes = config.samples_per_bscan() * 2;
  const std::size_t group_bytes = config.samples_per_group() * 2;

  // Part 1: one memcpy per record, warm (both buffers in cache) and cold (sources and slots
  // cycling through far more memory than the caches hold, as a ring of slots does).
  {
    const std::size_t sources = 32;  // 45 MB of staging
    const std::size_t slots = 8;     // 180 MB of slots
    std::vector<std::uint8_t> staging(sources * record_bytes, 1);
    std::vector<std::uint8_t> ring(slots * group_bytes, 0);
    const auto time_copies = [&](bool cold) {
      std::vector<double> per_record_us;
      for (std::size_t rep = 0; rep < 400; ++rep) {
        const std::size_t from = cold ? (rep % sources) * record_bytes : 0;
        const std::size_t to = cold ? (rep % (slots * config.bscans_per_group)) * record_bytes : 0;
        const auto t0 = std::chrono::steady_clock::now();
        std::memcpy(ring.data() + to, staging.data() + from, record_bytes);
        const auto t1 = std::chrono::steady_clock::now();
        per_record_us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
        staging[rep % staging.size()] ^= ring[to];  // keep the copies live
      }
      return median(per_record_us);
    };
    for (const bool cold : {false, true}) {
      const double us = time_copies(cold);
      std::printf(
          "memcpy of one record (%zu bytes), %s: %.1f us median, %.2f GB/s; one memcpy "
          "per record: %.2f ms per group of %.2f ms\n",
          record_bytes, cold ? "cold" : "warm", us, static_cast<double>(record_bytes) / us / 1e3,
          us * config.bscans_per_group / 1e3,
          static_cast<double>(config.sweeps_per_group()) / config.ascan_rate_hz * 1e3);
    }
  }

  // Part 2: the real path, libusb's asynchronous transfers against the emulated firmware.
  test::EmulatedInstrument::Options options;
  options.bulk_packet_bytes = 1024;  // SuperSpeed bulk
  test::EmulatedInstrument emulator(options);
  if (!test::EmulatedInstrument::in_mock_environment()) {
    std::printf("umockdev not in effect: part 2 skipped\n");
    return 0;
  }
  UsbInstrumentConfig usb;  // defaults: 16 transfers of 256 KiB, 32 staging buffers
  auto instrument = UsbInstrument::open(usb);
  UsbDigitizer digitizer(instrument);
  digitizer.prepare(config);
  digitizer.start();
  std::vector<std::uint16_t> slot(config.samples_per_group());
  std::vector<double> cpu_ms;
  GroupInfo info;
  const auto start = std::chrono::steady_clock::now();
  for (int g = 0; g < groups; ++g) {
    const double c0 = thread_cpu_ms();
    digitizer.acquire_group(slot, info);
    cpu_ms.push_back(thread_cpu_ms() - c0);
    if (info.status != 0) {
      std::printf("group %d: status 0x%x (%s)\n", g, info.status,
                  digitizer.describe_last_fault().c_str());
      return 1;
    }
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  digitizer.stop();
  const RecordCounters counters = digitizer.counters();
  const double payload = static_cast<double>(counters.direct_bytes + counters.staged_bytes);
  std::printf("plan: %u transfers per record (header, %u body of %u bytes%s)\n",
              digitizer.plan().parts_per_record, digitizer.plan().body_chunks,
              digitizer.plan().chunk_bytes, digitizer.plan().tail_copy_bytes ? ", tail" : "");
  std::printf(
      "payload straight into slots: %.1f%%, copied from staging: %.1f%% (%.2f MB per "
      "group)\n",
      100.0 * static_cast<double>(counters.direct_bytes) / payload,
      100.0 * static_cast<double>(counters.staged_bytes) / payload,
      static_cast<double>(counters.staged_bytes) / groups / 1e6);
  cpu_ms.erase(cpu_ms.begin());  // the first group includes start-up
  std::printf("real-time thread CPU per group: %.2f ms median, %.2f ms max (%d groups)\n",
              median(cpu_ms), *std::max_element(cpu_ms.begin(), cpu_ms.end()), groups - 1);
  std::printf("emulated transport (umockdev socket, not USB): %.0f MB/s, %zu staging starvations\n",
              payload / seconds / 1e6, static_cast<std::size_t>(counters.starvations));
  return 0;
}
