// ioct-rt's configuration keys, each declared once (rt_keys.cpp): the file, validate()'s ranges,
// the command line, --check-config's printout and docs/config-keys.md read from here.
#pragma once

#include "ioct/config/key_table.hpp"
#include "rt_config.hpp"

namespace ioct::rt {

const config::KeyTable<RtConfig>& rt_keys();

}  // namespace ioct::rt
