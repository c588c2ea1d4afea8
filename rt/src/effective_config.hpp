// The configuration ioct-rt would run with, every key after the file and the flags, as TOML that
// reads back: what `--check-config` prints so a person sees the defaults that filled the gaps.
#pragma once

#include <string>

#include "rt_config.hpp"

namespace ioct::rt {

std::string effective_config_toml(const RtConfig& config);

}  // namespace ioct::rt
