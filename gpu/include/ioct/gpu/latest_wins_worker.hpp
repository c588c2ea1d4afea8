// A thread of its own that runs the newest task handed to it: for files a person looks at
// (render.png, bscan.png, enface.png) that the live threads must never wait for. Writing a file
// can block for hundreds of milliseconds while another process keeps the disk busy: the live
// loop that wrote bscan.png and enface.png itself let the ring run past it (measured on two
// cores beside a large file being written: 8 and 18 groups dropped in two 12 s runs out of
// three, none with the files on tmpfs). Latest
// wins: a task handed over while another runs replaces the one waiting, if any (counted), since
// only the newest picture of a live volume is worth writing.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace ioct::gpu {

class LatestWinsWorker {
 public:
  LatestWinsWorker();   // starts the thread
  ~LatestWinsWorker();  // stop()
  LatestWinsWorker(const LatestWinsWorker&) = delete;
  LatestWinsWorker& operator=(const LatestWinsWorker&) = delete;

  // Hands `task` over; the caller returns at once. Ignored after stop().
  void submit(std::function<void()> task);
  // Runs the task waiting, if any, then ends the thread; returns when it has. Idempotent.
  void stop();

  struct Counts {
    std::uint64_t done = 0;      // tasks that returned
    std::uint64_t failed = 0;    // tasks that threw
    std::uint64_t replaced = 0;  // tasks replaced by a newer one before they started
    std::string problem;         // what the last failed task threw
  };
  Counts counts() const;

 private:
  void work();

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::function<void()> waiting_;
  bool stopping_ = false;
  Counts counts_;
  std::thread thread_;
};

}  // namespace ioct::gpu
