#include <gtest/gtest.h>

#include "signal_verdict.hpp"

namespace ioct::view {
namespace {

constexpr std::uint64_t kMs = 1'000'000;

SignalInputs live_inputs() {
  SignalInputs in;
  in.attached = true;
  in.health.alive = true;
  in.health.heartbeat_age_ns = 5 * kMs;
  in.status.source_state = static_cast<std::uint64_t>(shm::SourceState::live);
  in.status.group_period_ns = 86 * kMs;
  in.now_ns = 10'000 * kMs;
  in.status.last_group_published_ns = in.now_ns - 40 * kMs;
  return in;
}

TEST(SignalVerdict, FreshGroupsAreLive) {
  const SignalVerdict v = judge_signal(live_inputs(), {});
  EXPECT_EQ(v.signal, Signal::live);
  EXPECT_EQ(v.age_ns, 40 * kMs);
  EXPECT_EQ(v.bound_ns, 3 * 86 * kMs);
}

TEST(SignalVerdict, StaleJustPastThreeGroupPeriods) {
  SignalInputs in = live_inputs();
  in.status.last_group_published_ns = in.now_ns - 3 * 86 * kMs;
  EXPECT_EQ(judge_signal(in, {}).signal, Signal::live) << "at the bound it is still live";
  in.status.last_group_published_ns = in.now_ns - 3 * 86 * kMs - 1;
  const SignalVerdict v = judge_signal(in, {});
  EXPECT_EQ(v.signal, Signal::stale);
  EXPECT_NE(v.reason.find("no new group"), std::string::npos);
}

TEST(SignalVerdict, AFixedBoundOverridesThePeriod) {
  SignalInputs in = live_inputs();
  StalePolicy policy;
  policy.stale_after_s = 0.03;
  EXPECT_EQ(judge_signal(in, policy).signal, Signal::stale);
  policy.stale_after_s = 0.05;
  EXPECT_EQ(judge_signal(in, policy).signal, Signal::live);
}

TEST(SignalVerdict, NoSignalWhenAnyLinkIsMissing) {
  SignalInputs in = live_inputs();
  in.attached = false;
  EXPECT_EQ(judge_signal(in, {}).signal, Signal::no_signal);

  in = live_inputs();
  in.health.alive = false;
  EXPECT_EQ(judge_signal(in, {}).signal, Signal::no_signal);

  in = live_inputs();
  in.health.heartbeat_age_ns = 1500 * kMs;
  EXPECT_EQ(judge_signal(in, {}).reason, "ioct-gpu is not responding");

  in = live_inputs();
  in.status.source_state = static_cast<std::uint64_t>(shm::SourceState::producer_gone);
  EXPECT_EQ(judge_signal(in, {}).signal, Signal::no_signal);

  in = live_inputs();
  in.status.source_state = static_cast<std::uint64_t>(shm::SourceState::waiting);
  EXPECT_EQ(judge_signal(in, {}).signal, Signal::no_signal);

  in = live_inputs();
  in.status.last_group_published_ns = 0;
  EXPECT_EQ(judge_signal(in, {}).reason, "no group acquired yet");
}

TEST(SignalVerdict, AnUnknownPeriodFallsBackToTheAssumedOne) {
  SignalInputs in = live_inputs();
  in.status.group_period_ns = 0;
  in.status.last_group_published_ns = in.now_ns - 2500 * kMs;
  EXPECT_EQ(judge_signal(in, {}).signal, Signal::live);  // 3 x 1 s assumed
  in.status.last_group_published_ns = in.now_ns - 3500 * kMs;
  EXPECT_EQ(judge_signal(in, {}).signal, Signal::stale);
}

}  // namespace
}  // namespace ioct::view
