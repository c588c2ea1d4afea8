// SIGINT and SIGTERM as a request to stop, for the processes that stop by polling a flag
// (ioct-gpu, ioct-record; ioct-rt reads them from a signalfd instead, rt/src/shutdown_signals).
// `on_stop` runs in signal context: it may only set an atomic flag. The first signal asks; a
// second one ends the process at once (a second Ctrl-C), since the handler resets itself.
#pragma once

namespace ioct {

void install_stop_handler(void (*on_stop)(int));

}  // namespace ioct
