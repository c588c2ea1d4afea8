#include "ioct/sim/simulation_config.hpp"

namespace ioct::sim {

void SimulationConfig::validate() const {
  source.validate();
  detector.validate();
  retina.validate();
  scan.validate();
}

}  // namespace ioct::sim
