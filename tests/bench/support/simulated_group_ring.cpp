#include "simulated_group_ring.hpp"

#include <cstdio>
#include <span>
#include <stdexcept>
#include <string>

#include "ioct/hal/digitizer.hpp"
#include "ioct/shm/ring_error.hpp"
#include "ioct/sim/simulated_digitizer.hpp"
#include "synthetic_spectra.hpp"

namespace ioct::bench {

void describe_group(shm::SlotHeader& header, const shm::RingGeometry& geometry,
                    std::uint64_t group) {
  header.bscan_count = geometry.bscans_per_group;
  header.active_ascan_begin = 0;
  header.active_ascan_end = geometry.ascans_per_bscan;
  header.status_flags = shm::kStatusSimulated;
  const std::uint64_t first = group * geometry.bscans_per_group;
  for (std::uint32_t b = 0; b < geometry.bscans_per_group; ++b) {
    const std::uint64_t bscan = first + b;
    header.bscans[b] =
        gpu::testing::marker_for(bscan / geometry.bscans_per_volume,
                                 static_cast<std::uint32_t>(bscan % geometry.bscans_per_volume),
                                 geometry.bscans_per_volume, false);
  }
}

SimulatedGroupRing::SimulatedGroupRing(const std::string& tag, const shm::RingGeometry& geometry,
                                       std::uint32_t slots,
                                       const std::vector<sim::InstrumentConfig>& instruments)
    : geometry_(geometry) {
  // publish() labels slot g % slots as group g of its volume: with tools in the scene the slots
  // must hold whole volumes, or a tool's B-scans would land in others' places.
  const std::uint32_t per_volume = geometry.bscans_per_volume / geometry.bscans_per_group;
  const std::uint32_t step = instruments.empty() ? 1 : per_volume;
  if (slots % step != 0) {
    throw std::invalid_argument("a scene with instruments needs ring slots in whole volumes (" +
                                std::to_string(per_volume) + " groups), not " +
                                std::to_string(slots));
  }
  for (std::uint32_t count = slots;; count -= step) {
    try {
      ring_.emplace(tag, geometry, count, SlotFill::none);
      slots_ = count;
      break;
    } catch (const shm::RingError& e) {
      if (count <= 4 || count <= step) throw;
      std::fprintf(stderr, "ring of %u slots refused (%s); trying fewer\n", count, e.what());
    }
  }
  hal::DigitizerConfig acquisition;
  acquisition.samples_per_ascan = geometry.samples_per_ascan;
  acquisition.ascans_per_bscan = geometry.ascans_per_bscan;
  acquisition.bscans_per_group = geometry.bscans_per_group;
  sim::SimulationConfig simulation;
  simulation.scan.ascans_per_bscan = geometry.ascans_per_bscan;
  simulation.scan.bscans_per_volume = geometry.bscans_per_volume;
  simulation.instruments = instruments;
  sim::SimulatedDigitizer digitizer(simulation);
  digitizer.prepare(acquisition);
  digitizer.start();
  shm::RingWriter& writer = ring_->writer();
  for (std::uint32_t s = 0; s < slots_; ++s) {
    shm::RingWriter::Claim claim = writer.claim();
    hal::GroupInfo info;
    digitizer.acquire_group(
        std::span(reinterpret_cast<std::uint16_t*>(claim.payload.data()), claim.payload.size() / 2),
        info);
    describe_group(*claim.header, geometry_, claim.group);
    writer.publish(claim);
  }
}

void SimulatedGroupRing::publish() {
  shm::RingWriter& writer = ring_->writer();
  shm::RingWriter::Claim claim = writer.claim();
  describe_group(*claim.header, geometry_, claim.group);
  writer.publish(claim);
}

}  // namespace ioct::bench
