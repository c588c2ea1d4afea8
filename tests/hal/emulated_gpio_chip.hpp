// A GPIO chip emulated at the character-device ioctl level (the kernel's v1 uAPI, which libgpiod
// 1.6 speaks) inside a umockdev testbed, for machines whose kernel has no GPIO chips.
//
// /dev/gpiochip0 answers GPIO_GET_CHIPINFO, GPIO_GET_LINEINFO, GPIO_GET_LINEHANDLE and
// GPIO_GET_LINEEVENT. A line request gets a file descriptor of its own: the handler opens one
// more emulated node per line (so GPIOHANDLE_GET/SET_LINE_VALUES on it reach this emulator too),
// and for an event request puts a pipe under that descriptor, so poll() works natively while
// read() still reaches the emulator: a byte in the pipe means "an event is queued". Levels and
// edges are kept physical; active-low requests see them inverted, as the kernel does. A request
// ends when its descriptor is closed.
#pragma once

#include <umockdev.h>

#include <array>
#include <cstdint>
#include <deque>
#include <mutex>
#include <string>
#include <vector>

namespace ioct::hal::gpio::test {

class EmulatedGpioChip {
 public:
  static constexpr unsigned kLines = 8;

  EmulatedGpioChip();
  ~EmulatedGpioChip();
  EmulatedGpioChip(const EmulatedGpioChip&) = delete;
  EmulatedGpioChip& operator=(const EmulatedGpioChip&) = delete;

  static bool in_mock_environment();
  static constexpr const char* kDevice = "/dev/gpiochip0";
  static constexpr const char* kLabel = "ioct-emulated";

  // The line is in use by someone else: LINEINFO names `consumer`, requests fail with EBUSY.
  void hold(unsigned offset, const std::string& consumer);
  // Drives an input line's physical level; an edge queues an event (if the line is requested
  // for events) stamped `timestamp_ns` (the clock is the caller's choice).
  void drive(unsigned offset, bool high, std::uint64_t timestamp_ns);

  bool physical_level(unsigned offset) const;
  bool requested(unsigned offset) const;
  std::uint32_t request_flags(unsigned offset) const;  // GPIOHANDLE_REQUEST_* of the request
  std::string consumer(unsigned offset) const;
  // Physical levels an output line was driven to, in order, since it was requested.
  std::vector<bool> output_history(unsigned offset) const;

 private:
  struct Line {
    bool high = false;
    bool requested = false;
    bool events = false;
    std::uint32_t flags = 0;
    std::uint32_t event_flags = 0;
    std::string consumer;
    bool held = false;
    int fd = -1;               // the descriptor handed to the client
    int pipe_write = -1;       // event lines: one byte per queued event
    unsigned long fd_dev = 0;  // what `fd` referred to when handed out
    unsigned long fd_ino = 0;
    std::deque<std::array<std::uint8_t, 16>> queued;  // struct gpioevent_data
    std::vector<bool> history;
  };
  struct LineNode {
    EmulatedGpioChip* chip = nullptr;
    unsigned offset = 0;
    UMockdevIoctlBase* handler = nullptr;
  };

  static gboolean on_chip_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer self);
  static gboolean on_line_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer node);
  static gboolean on_line_read(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer node);

  bool chip_ioctl(UMockdevIoctlClient* client);
  bool line_ioctl(unsigned offset, UMockdevIoctlClient* client);
  bool line_read(unsigned offset, UMockdevIoctlClient* client);
  static bool still_open(const Line& line);
  static void refresh(Line& line);  // releases a request whose descriptor was closed
  static void remember(Line& line, int fd);
  int open_line_node(unsigned offset, bool events);
  bool logical(const Line& line) const;
  static std::string line_node(unsigned offset);

  UMockdevTestbed* testbed_ = nullptr;
  UMockdevIoctlBase* chip_handler_ = nullptr;
  std::array<LineNode, kLines> nodes_{};
  mutable std::mutex mutex_;
  mutable std::array<Line, kLines> lines_{};
};

}  // namespace ioct::hal::gpio::test
