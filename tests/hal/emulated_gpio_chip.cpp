#include "emulated_gpio_chip.hpp"

#include <fcntl.h>
#include <linux/gpio.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace ioct::hal::gpio::test {
namespace {

template <typename T>
T* resolve(UMockdevIoctlClient* client, UMockdevIoctlData** data) {
  *data = umockdev_ioctl_data_resolve(umockdev_ioctl_client_get_arg(client), 0, sizeof(T), nullptr);
  return *data != nullptr ? reinterpret_cast<T*>((*data)->data) : nullptr;
}

void complete(UMockdevIoctlClient* client, UMockdevIoctlData* data, long result, int error) {
  if (data != nullptr) g_object_unref(data);
  umockdev_ioctl_client_complete(client, result, error);
}

void add(UMockdevTestbed* testbed, const std::string& description) {
  GError* error = nullptr;
  if (umockdev_testbed_add_from_string(testbed, description.c_str(), &error) == 0) {
    const std::string text = error != nullptr ? error->message : "unknown error";
    g_clear_error(&error);
    throw std::runtime_error("umockdev: cannot add a GPIO node: " + text);
  }
}

void attach(UMockdevTestbed* testbed, const std::string& node, UMockdevIoctlBase* handler) {
  GError* error = nullptr;
  if (umockdev_testbed_attach_ioctl(testbed, node.c_str(), handler, &error) == 0) {
    const std::string text = error != nullptr ? error->message : "unknown error";
    g_clear_error(&error);
    throw std::runtime_error("umockdev: cannot attach " + node + ": " + text);
  }
}

}  // namespace

bool EmulatedGpioChip::in_mock_environment() {
  return umockdev_in_mock_environment() != 0;
}

std::string EmulatedGpioChip::line_node(unsigned offset) {
  return "/dev/ioct-gpio-line" + std::to_string(offset);
}

EmulatedGpioChip::EmulatedGpioChip() {
  testbed_ = umockdev_testbed_new();
  chip_handler_ = umockdev_ioctl_base_new();
  g_signal_connect(chip_handler_, "handle-ioctl", G_CALLBACK(on_chip_ioctl), this);
  attach(testbed_, kDevice, chip_handler_);
  for (unsigned i = 0; i < kLines; ++i) {
    LineNode& node = nodes_[i];
    node.chip = this;
    node.offset = i;
    node.handler = umockdev_ioctl_base_new();
    g_signal_connect(node.handler, "handle-ioctl", G_CALLBACK(on_line_ioctl), &node);
    g_signal_connect(node.handler, "handle-read", G_CALLBACK(on_line_read), &node);
    attach(testbed_, line_node(i), node.handler);
  }
  // libgpiod accepts a character device only when sysfs has it under the gpio bus with the
  // same device number.
  add(testbed_,
      "P: /devices/platform/gpio-emulator/gpiochip0\nN: gpiochip0\nE: SUBSYSTEM=gpio\n"
      "E: DEVNAME=/dev/gpiochip0\nA: dev=254:0\\n\n");
  for (unsigned i = 0; i < kLines; ++i) {
    add(testbed_, "P: /devices/platform/gpio-emulator/line" + std::to_string(i) +
                      "\nN: ioct-gpio-line" + std::to_string(i) +
                      "\nE: SUBSYSTEM=ioct-test\nA: dev=254:" + std::to_string(i + 1) + "\\n\n");
  }
}

EmulatedGpioChip::~EmulatedGpioChip() {
  {
    std::lock_guard lock(mutex_);
    for (Line& line : lines_) {
      if (line.pipe_write >= 0) close(line.pipe_write);
      line.pipe_write = -1;
    }
  }
  for (LineNode& node : nodes_) g_clear_object(&node.handler);
  g_clear_object(&chip_handler_);
  g_clear_object(&testbed_);
}

// --- test side ---

void EmulatedGpioChip::hold(unsigned offset, const std::string& consumer) {
  std::lock_guard lock(mutex_);
  lines_.at(offset).held = true;
  lines_.at(offset).consumer = consumer;
}

void EmulatedGpioChip::drive(unsigned offset, bool high, std::uint64_t timestamp_ns) {
  std::lock_guard lock(mutex_);
  Line& line = lines_.at(offset);
  refresh(line);
  if (line.high == high) return;
  line.high = high;
  if (!line.requested || !line.events || line.pipe_write < 0) return;
  const bool rising = logical(line);  // edges are logical, as the kernel reports them
  const std::uint32_t wanted =
      rising ? GPIOEVENT_REQUEST_RISING_EDGE : GPIOEVENT_REQUEST_FALLING_EDGE;
  if ((line.event_flags & wanted) == 0) return;
  gpioevent_data event{};
  event.timestamp = timestamp_ns;
  event.id = rising ? GPIOEVENT_EVENT_RISING_EDGE : GPIOEVENT_EVENT_FALLING_EDGE;
  std::array<std::uint8_t, 16> bytes{};
  static_assert(sizeof(event) == bytes.size());
  std::memcpy(bytes.data(), &event, sizeof(event));
  line.queued.push_back(bytes);
  const char one = 1;
  if (write(line.pipe_write, &one, 1) != 1) throw std::runtime_error("emulated GPIO: pipe full");
}

bool EmulatedGpioChip::physical_level(unsigned offset) const {
  std::lock_guard lock(mutex_);
  return lines_.at(offset).high;
}

bool EmulatedGpioChip::requested(unsigned offset) const {
  std::lock_guard lock(mutex_);
  refresh(lines_.at(offset));
  return lines_.at(offset).requested;
}

std::uint32_t EmulatedGpioChip::request_flags(unsigned offset) const {
  std::lock_guard lock(mutex_);
  return lines_.at(offset).flags;
}

std::string EmulatedGpioChip::consumer(unsigned offset) const {
  std::lock_guard lock(mutex_);
  return lines_.at(offset).consumer;
}

std::vector<bool> EmulatedGpioChip::output_history(unsigned offset) const {
  std::lock_guard lock(mutex_);
  return lines_.at(offset).history;
}

void EmulatedGpioChip::remember(Line& line, int fd) {
  struct stat st {};
  syscall(SYS_fstat, fd, &st);
  line.fd_dev = st.st_dev;
  line.fd_ino = st.st_ino;
}

bool EmulatedGpioChip::logical(const Line& line) const {
  return line.high != ((line.flags & GPIOHANDLE_REQUEST_ACTIVE_LOW) != 0);
}

// --- the chip's ioctls (umockdev's worker thread) ---

gboolean EmulatedGpioChip::on_chip_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* client,
                                         gpointer self) {
  return static_cast<EmulatedGpioChip*>(self)->chip_ioctl(client) ? TRUE : FALSE;
}

int EmulatedGpioChip::open_line_node(unsigned offset, bool events) {
  // Opened from this (the emulator's) thread of the same process: the descriptor is valid for
  // the client, and umockdev routes its ioctls and reads to this line's handler.
  const int fd = open(line_node(offset).c_str(), O_RDWR | O_CLOEXEC);
  if (fd < 0) return fd;
  if (!events) {
    remember(lines_[offset], fd);
    return fd;
  }
  int pipe_fds[2];
  if (pipe2(pipe_fds, O_CLOEXEC | O_NONBLOCK) != 0) return -1;
  // The pipe's read end takes the descriptor's place: poll() sees queued events natively.
  dup3(pipe_fds[0], fd, O_CLOEXEC);
  close(pipe_fds[0]);
  lines_[offset].pipe_write = pipe_fds[1];
  remember(lines_[offset], fd);
  return fd;
}

bool EmulatedGpioChip::chip_ioctl(UMockdevIoctlClient* client) {
  const gulong request = umockdev_ioctl_client_get_request(client);
  UMockdevIoctlData* data = nullptr;
  std::lock_guard lock(mutex_);
  switch (request) {
    case GPIO_GET_CHIPINFO_IOCTL: {
      gpiochip_info info{};
      std::memcpy(info.name, "gpiochip0", sizeof("gpiochip0"));
      std::memcpy(info.label, kLabel, std::strlen(kLabel) + 1);
      info.lines = kLines;
      std::memcpy(resolve<gpiochip_info>(client, &data), &info, sizeof(info));
      complete(client, data, 0, 0);
      return true;
    }
    case GPIO_GET_LINEINFO_IOCTL: {
      auto* info = resolve<gpioline_info>(client, &data);
      if (info->line_offset >= kLines) {
        complete(client, data, -1, EINVAL);
        return true;
      }
      Line& line = lines_[info->line_offset];
      refresh(line);
      std::snprintf(info->name, sizeof(info->name), "line%u", info->line_offset);
      info->flags = 0;
      if (line.held || line.requested) info->flags |= GPIOLINE_FLAG_KERNEL;
      if (line.requested && (line.flags & GPIOHANDLE_REQUEST_OUTPUT) != 0) {
        info->flags |= GPIOLINE_FLAG_IS_OUT;
      }
      if ((line.flags & GPIOHANDLE_REQUEST_ACTIVE_LOW) != 0)
        info->flags |= GPIOLINE_FLAG_ACTIVE_LOW;
      std::snprintf(info->consumer, sizeof(info->consumer), "%s",
                    line.held || line.requested ? line.consumer.c_str() : "");
      complete(client, data, 0, 0);
      return true;
    }
    case GPIO_GET_LINEHANDLE_IOCTL: {
      auto* r = resolve<gpiohandle_request>(client, &data);
      if (r->lines != 1 || r->lineoffsets[0] >= kLines) {
        complete(client, data, -1, EINVAL);
        return true;
      }
      Line& line = lines_[r->lineoffsets[0]];
      refresh(line);
      if (line.held || line.requested) {
        complete(client, data, -1, EBUSY);
        return true;
      }
      const bool high = line.high;
      line = Line{};
      line.high = high;
      line.requested = true;
      line.flags = r->flags;
      line.consumer = r->consumer_label;
      if ((r->flags & GPIOHANDLE_REQUEST_OUTPUT) != 0) {
        line.high =
            (r->default_values[0] != 0) != ((r->flags & GPIOHANDLE_REQUEST_ACTIVE_LOW) != 0);
        line.history.push_back(line.high);
      }
      r->fd = line.fd = open_line_node(r->lineoffsets[0], false);
      complete(client, data, 0, 0);
      return true;
    }
    case GPIO_GET_LINEEVENT_IOCTL: {
      auto* r = resolve<gpioevent_request>(client, &data);
      if (r->lineoffset >= kLines) {
        complete(client, data, -1, EINVAL);
        return true;
      }
      Line& line = lines_[r->lineoffset];
      refresh(line);
      if (line.held || line.requested) {
        complete(client, data, -1, EBUSY);
        return true;
      }
      const bool high = line.high;
      line = Line{};
      line.high = high;
      line.requested = true;
      line.events = true;
      line.flags = r->handleflags;
      line.event_flags = r->eventflags;
      line.consumer = r->consumer_label;
      r->fd = line.fd = open_line_node(r->lineoffset, true);
      complete(client, data, 0, 0);
      return true;
    }
    default:
      complete(client, nullptr, -1, ENOTTY);
      return true;
  }
}

// --- a requested line's ioctls and reads ---

gboolean EmulatedGpioChip::on_line_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* client,
                                         gpointer node) {
  auto* n = static_cast<LineNode*>(node);
  return n->chip->line_ioctl(n->offset, client) ? TRUE : FALSE;
}

gboolean EmulatedGpioChip::on_line_read(UMockdevIoctlBase*, UMockdevIoctlClient* client,
                                        gpointer node) {
  auto* n = static_cast<LineNode*>(node);
  return n->chip->line_read(n->offset, client) ? TRUE : FALSE;
}

bool EmulatedGpioChip::line_ioctl(unsigned offset, UMockdevIoctlClient* client) {
  const gulong request = umockdev_ioctl_client_get_request(client);
  UMockdevIoctlData* data = nullptr;
  std::lock_guard lock(mutex_);
  Line& line = lines_[offset];
  switch (request) {
    case GPIOHANDLE_GET_LINE_VALUES_IOCTL: {
      auto* values = resolve<gpiohandle_data>(client, &data);
      values->values[0] = logical(line) ? 1 : 0;
      complete(client, data, 0, 0);
      return true;
    }
    case GPIOHANDLE_SET_LINE_VALUES_IOCTL: {
      if ((line.flags & GPIOHANDLE_REQUEST_OUTPUT) == 0) {
        complete(client, nullptr, -1, EPERM);
        return true;
      }
      auto* values = resolve<gpiohandle_data>(client, &data);
      line.high = (values->values[0] != 0) != ((line.flags & GPIOHANDLE_REQUEST_ACTIVE_LOW) != 0);
      line.history.push_back(line.high);
      complete(client, data, 0, 0);
      return true;
    }
    default:
      complete(client, nullptr, -1, ENOTTY);
      return true;
  }
}

bool EmulatedGpioChip::line_read(unsigned offset, UMockdevIoctlClient* client) {
  std::lock_guard lock(mutex_);
  Line& line = lines_[offset];
  UMockdevIoctlData* buffer = umockdev_ioctl_client_get_arg(client);
  const std::size_t wanted = std::min<std::size_t>(buffer->data_len / 16, line.queued.size());
  if (wanted == 0) {
    umockdev_ioctl_client_complete(client, -1, EAGAIN);
    return true;
  }
  std::vector<std::uint8_t> bytes;
  for (std::size_t i = 0; i < wanted; ++i) {
    bytes.insert(bytes.end(), line.queued.front().begin(), line.queued.front().end());
    line.queued.pop_front();
  }
  // Take the events' bytes out of the pipe with the raw system call: read() from this process
  // would be routed back here by umockdev.
  std::vector<char> drained(wanted);
  syscall(SYS_read, line.fd, drained.data(), wanted);
  umockdev_ioctl_data_update(buffer, 0, bytes.data(), static_cast<gint>(bytes.size()));
  umockdev_ioctl_client_complete(client, static_cast<long>(bytes.size()), 0);
  return true;
}

bool EmulatedGpioChip::still_open(const Line& line) {
  // umockdev 0.17 does not report closed descriptors reliably: a request is released when its
  // descriptor no longer refers to what the handler opened (raw fstat: the preload wraps stat).
  struct stat now {};
  return line.fd >= 0 && syscall(SYS_fstat, line.fd, &now) == 0 && now.st_dev == line.fd_dev &&
         now.st_ino == line.fd_ino;
}

void EmulatedGpioChip::refresh(Line& line) {
  if (!line.requested || still_open(line)) return;
  if (line.pipe_write >= 0) close(line.pipe_write);
  const bool high = line.high;
  std::vector<bool> history = std::move(line.history);
  line = Line{};
  line.high = high;
  line.history = std::move(history);
}

}  // namespace ioct::hal::gpio::test
