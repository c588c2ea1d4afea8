// Re-executes the current program with libumockdev-preload in LD_PRELOAD (once), so that it can
// build a umockdev testbed in-process however it was started.
#pragma once

namespace ioct::hal::usb::test {

// Returns only when already re-executed, or when exec failed (the reason is on stderr).
void reexec_under_umockdev(char** argv);

}  // namespace ioct::hal::usb::test
