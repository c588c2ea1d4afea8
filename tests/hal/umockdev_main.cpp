// main() of the USB tests: re-executes the binary with libumockdev-preload in LD_PRELOAD, so the
// tests can build a umockdev testbed in-process whether ctest or a person started them. When the
// preload cannot take effect, the tests that need it skip with the reason.
#include <gtest/gtest.h>

#include "umockdev_reexec.hpp"

int main(int argc, char** argv) {
  ioct::hal::usb::test::reexec_under_umockdev(argv);
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
