#include "ioct/common/stop_signals.hpp"

#include <signal.h>

namespace ioct {

void install_stop_handler(void (*on_stop)(int)) {
  struct sigaction action {};
  action.sa_handler = on_stop;
  action.sa_flags = SA_RESETHAND;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

}  // namespace ioct
