// SIGINT and SIGTERM taken one way in every process: from a signalfd, never in signal context; the
// watcher's stop function at the first, the default action at the second. Each case runs in a
// child process (a death test), so the signals it blocks and sends never reach the test runner.
#include "ioct/common/stop_signals.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <thread>

namespace ioct {
namespace {

using namespace std::chrono_literals;

TEST(StopSignalsDeathTest, ASignalIsReadFromTheFdNotDelivered) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        const StopSignals signals;
        if (signals.take() != 0) std::_Exit(3);  // none pending yet
        ::kill(::getpid(), SIGTERM);             // blocked: pending, the process lives on
        std::_Exit(signals.wait_for(5'000'000'000ull) == SIGTERM ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

TEST(StopSignalsDeathTest, TheWatcherCallsStopAtTheFirstSignalOnItsOwnThread) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        const StopSignals signals;
        std::atomic<bool> stopped{false};
        const std::thread::id main_thread = std::this_thread::get_id();
        std::atomic<bool> on_main{false};
        std::atomic<int> signal_seen{0};
        const StopWatcher watcher(signals, [&](int signal) {
          on_main = std::this_thread::get_id() == main_thread;
          signal_seen = signal;
          stopped = true;
        });
        ::kill(::getpid(), SIGINT);
        for (int i = 0; i < 1000 && !stopped.load(); ++i) std::this_thread::sleep_for(10ms);
        std::_Exit(stopped.load() && !on_main.load() && signal_seen.load() == SIGINT ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

TEST(StopSignalsDeathTest, TheSecondSignalEndsTheProcessAtOnce) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        const StopSignals signals;
        std::atomic<bool> stopped{false};
        const StopWatcher watcher(signals, [&](int) { stopped = true; });
        ::kill(::getpid(), SIGTERM);
        for (int i = 0; i < 1000 && !stopped.load(); ++i) std::this_thread::sleep_for(10ms);
        if (!stopped.load()) std::_Exit(2);  // the first must only ask, not end the process
        ::kill(::getpid(), SIGTERM);         // the stop did not finish the process: this one does
        std::this_thread::sleep_for(10s);
        std::_Exit(1);
      },
      ::testing::KilledBySignal(SIGTERM), "");
}

TEST(StopSignalsDeathTest, EndByEndsTheProcessBySignalEvenWhileItIsBlocked) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        const StopSignals signals;  // SIGINT blocked, as in a process still starting
        StopWatcher::end_by(SIGINT);
      },
      ::testing::KilledBySignal(SIGINT), "");
}

TEST(StopSignalsDeathTest, AWatcherGoneLeavesTheSignalPendingForTheFd) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        const StopSignals signals;
        std::atomic<bool> stopped{false};
        {
          const StopWatcher watcher(signals, [&](int) { stopped = true; });
        }
        ::kill(::getpid(), SIGINT);
        const int taken = signals.wait_for(5'000'000'000ull);
        std::_Exit(taken == SIGINT && !stopped.load() ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

}  // namespace
}  // namespace ioct
