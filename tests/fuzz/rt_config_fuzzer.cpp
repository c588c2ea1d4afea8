// ioct-rt's TOML configuration (rt/src/rt_config), every table including [simulation], through
// load_config_text: what load_config_file does once it has read the file. An accepted file must
// leave a configuration that validates, and every refusal names the file.
#include <cstddef>
#include <cstdint>
#include <string>

#include "refusal.hpp"
#include "rt_config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // Larger files are refused by size before parsing (kMaxConfigBytes); nothing to learn there.
  if (size > ioct::rt::kMaxConfigBytes) return -1;
  const std::string text(reinterpret_cast<const char*>(data), size);
  ioct::rt::RtConfig config;
  bool loaded = false;
  ioct::fuzz::expect_accept_or_refuse(
      [&] {
        ioct::rt::KeyPositions positions;
        ioct::rt::load_config_text(text, "fuzz.toml", config, &positions);
        loaded = true;
      },
      "fuzz.toml");
  if (!loaded) return 0;
  // ioct-rt's cross-checks run after the command-line flags are applied, so they name the key
  // (the file's position is in KeyPositions) rather than the file.
  ioct::fuzz::expect_accept_or_refuse([&] {
    config.validate();
    (void)config.effective_stall_timeout_ms();
    (void)config.galvo_lead_samples();
  });
  return 0;
}
