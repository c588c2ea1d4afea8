// ArrivalForecast and idle_sleep_ns: the period from the last intervals, the next due time
// (skipping missed events), and the sleep-or-look decision around it.
#include "ioct/concurrency/arrival_forecast.hpp"

#include <gtest/gtest.h>

namespace {

constexpr std::uint64_t kMs = 1'000'000;

TEST(ArrivalForecast, NoForecastUntilTwoEvents) {
  ioct::ArrivalForecast f;
  EXPECT_EQ(f.period_ns(), 0u);
  EXPECT_EQ(f.next_due_ns(0, 0), 0u);
  f.observe(100 * kMs, 1);
  EXPECT_EQ(f.period_ns(), 0u);
  EXPECT_EQ(f.next_due_ns(100 * kMs, 0), 0u);
  f.observe(150 * kMs, 2);
  EXPECT_EQ(f.period_ns(), 50 * kMs);
  EXPECT_EQ(f.next_due_ns(150 * kMs, 0), 200 * kMs);
}

TEST(ArrivalForecast, AMissedEventsIntervalIsSharedAmongTheEventsItSpans) {
  ioct::ArrivalForecast f;
  f.observe(0, 10);
  f.observe(100 * kMs, 12);  // event 11 was missed
  EXPECT_EQ(f.period_ns(), 50 * kMs);
  EXPECT_EQ(f.next_due_ns(100 * kMs, 0), 150 * kMs);
}

TEST(ArrivalForecast, PeriodIsTheShortestRecentInterval) {
  ioct::ArrivalForecast f;
  std::uint64_t n = 0;
  for (std::uint64_t t : {0u, 50u, 101u, 152u}) f.observe(t * kMs, n++);
  EXPECT_EQ(f.period_ns(), 50 * kMs);
  // Four longer intervals push the short ones out: the producer slowed down.
  for (std::uint64_t t : {252u, 352u, 452u, 552u}) f.observe(t * kMs, n++);
  EXPECT_EQ(f.period_ns(), 100 * kMs);
}

TEST(ArrivalForecast, PastDueTimesAreSkippedByWholePeriods) {
  ioct::ArrivalForecast f;
  f.observe(0, 0);
  f.observe(10 * kMs, 1);
  EXPECT_EQ(f.next_due_ns(20 * kMs, kMs), 20 * kMs);      // due now
  EXPECT_EQ(f.next_due_ns(21 * kMs, kMs), 20 * kMs);      // late, but within late_ns
  EXPECT_EQ(f.next_due_ns(21 * kMs + 1, kMs), 30 * kMs);  // missed: the next one
  EXPECT_EQ(f.next_due_ns(45 * kMs, kMs), 50 * kMs);
}

TEST(ArrivalForecast, AStreamSilentForItsAwaitedEventsHasNoForecast) {
  ioct::ArrivalForecast f;
  f.observe(0, 0);
  f.observe(10 * kMs, 1);
  const std::uint64_t last_awaited = 10 * kMs + ioct::ArrivalForecast::kAwaitedEvents * 10 * kMs;
  EXPECT_EQ(f.next_due_ns(last_awaited, kMs), last_awaited);
  EXPECT_EQ(f.next_due_ns(last_awaited + kMs + 1, kMs), 0u);  // stopped
  f.observe(200 * kMs, 19);                                   // it comes back: forecast again
  EXPECT_EQ(f.next_due_ns(200 * kMs, kMs), 210 * kMs);
}

TEST(IdleSleep, AStoppedStreamWithAPeriodShorterThanTheWindowsLetsTheThreadSleep) {
  // Groups 1 ms apart with a 1 ms window on each side: the windows cover all time while they
  // come, but once they stop the thread must go back to sleeping.
  ioct::ArrivalForecast f;
  for (std::uint64_t n = 0; n < 5; ++n) f.observe(100 * kMs + n * kMs, n);
  const std::uint64_t last = 104 * kMs;
  const std::uint64_t poll = 250'000;
  for (std::uint64_t now = last; now <= last + 4 * kMs; now += 100'000) {
    EXPECT_EQ(ioct::idle_sleep_ns(f, now, kMs, poll), 0u) << now - last;
  }
  EXPECT_EQ(ioct::idle_sleep_ns(f, last + 6 * kMs, kMs, poll), poll);
  EXPECT_EQ(ioct::idle_sleep_ns(f, last + 1'000 * kMs, kMs, poll), poll);
}

TEST(ArrivalForecast, TimeGoingBackwardsStartsAfresh) {
  ioct::ArrivalForecast f;
  f.observe(100 * kMs, 7);
  f.observe(110 * kMs, 8);
  f.observe(115 * kMs, 0);  // a producer restarted: its numbers begin again
  EXPECT_EQ(f.period_ns(), 0u);
  f.observe(135 * kMs, 1);
  EXPECT_EQ(f.period_ns(), 20 * kMs);
  f.observe(130 * kMs, 2);  // a time going backwards, too
  EXPECT_EQ(f.period_ns(), 0u);
}

TEST(IdleSleep, SleepsUntilTheWindowThenLooksWithoutSleepingThenSleepsAgain) {
  ioct::ArrivalForecast f;
  f.observe(0, 0);
  f.observe(50 * kMs, 1);  // next due at 100 ms
  const std::uint64_t spin = kMs;
  const std::uint64_t poll = 250'000;
  EXPECT_EQ(ioct::idle_sleep_ns(f, 60 * kMs, spin, poll), poll);  // far: a poll's sleep
  EXPECT_EQ(ioct::idle_sleep_ns(f, 99 * kMs - 100'000, spin, poll), 100'000u);  // to the window
  EXPECT_EQ(ioct::idle_sleep_ns(f, 99 * kMs, spin, poll), 0u);                  // the window opens
  EXPECT_EQ(ioct::idle_sleep_ns(f, 100 * kMs + kMs, spin, poll), 0u);           // and closes
  // Past the window the next event's comes into view: sleep towards it.
  EXPECT_EQ(ioct::idle_sleep_ns(f, 101 * kMs + 1, spin, poll), poll);
}

TEST(IdleSleep, WithoutAWindowOrAForecastItIsThePollInterval) {
  ioct::ArrivalForecast f;
  EXPECT_EQ(ioct::idle_sleep_ns(f, 5 * kMs, kMs, 250'000), 250'000u);
  f.observe(0, 0);
  f.observe(10 * kMs, 1);
  EXPECT_EQ(ioct::idle_sleep_ns(f, 20 * kMs, 0, 250'000), 250'000u);
}

}  // namespace
