// A benchmark's ring of simulated groups: every slot is filled once with a group of the
// simulator's default scene (with instruments if asked), then publish() hands the slots out again
// and again with the headers of a continuous scan (groups 0, 1, 2, ... of consecutive volumes), so
// a consumer sees the default geometry at any rate without the simulator's cost in the figure.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "bench_ring_fixture.hpp"
#include "ioct/shm/ring_layout.hpp"
#include "ioct/sim/simulation_config.hpp"

namespace ioct::bench {

// The header of group `group` of a continuous unidirectional scan at `geometry`: every A-scan
// active, the B-scans' places in their volumes and the volumes' first and last B-scans marked.
void describe_group(shm::SlotHeader& header, const shm::RingGeometry& geometry,
                    std::uint64_t group);

class SimulatedGroupRing {
 public:
  // The ring "ioct-bench-<pid>-<tag>" with `slots` slots, or fewer (down to 4, said on stderr)
  // where /dev/shm cannot hold them.
  // `instruments`: tools in the scene (none: the default retina alone).
  SimulatedGroupRing(const std::string& tag, const shm::RingGeometry& geometry, std::uint32_t slots,
                     const std::vector<sim::InstrumentConfig>& instruments = {});

  // Publishes the next group (the payload its slot holds; a new header).
  void publish();

  std::uint64_t published() const { return ring_->writer().published(); }
  std::uint32_t slots() const { return slots_; }
  const std::string& name() const { return ring_->name(); }

 private:
  shm::RingGeometry geometry_;
  std::uint32_t slots_ = 0;
  std::optional<BenchRing> ring_;
};

}  // namespace ioct::bench
