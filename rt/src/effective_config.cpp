#include "effective_config.hpp"

#include "rt_keys.hpp"

namespace ioct::rt {

std::string effective_config_toml(const RtConfig& c) {
  std::string out = "# effective configuration (file, then flags, then defaults)\n";
  out += rt_keys().to_toml(c);
  if (c.simulation_workers < 0) {
    out += "# simulation.workers = \"auto\" is " + std::to_string(c.resolved_simulation_workers()) +
           " on this host\n";
  }
  return out;
}

}  // namespace ioct::rt
