// ViewSet: when each view falls due (a change, the frame rate while it rotates, a pass for the
// private views, full size once it stops moving) and what it renders with.
#include <gtest/gtest.h>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/live_stages/view_set.hpp"

namespace ioct::gpu::live {
namespace {

constexpr std::uint64_t kMs = 1'000'000;
constexpr std::uint64_t kStart = 1'000 * kMs;

render::RenderConfig still_view() {
  render::RenderConfig config;
  config.view.auto_rotate = false;
  config.view.azimuth_deg = 30.0;
  return config;
}

TEST(ViewSet, AStillViewIsDueOnlyAfterAChange) {
  ViewSet views(still_view(), ViewTiming{}, kStart);
  (void)views.take_shared(kStart);  // the first pass
  EXPECT_EQ(views.next_due_ns(kStart + 500 * kMs), UINT64_MAX);
  EXPECT_TRUE(views.take_due(kStart + 500 * kMs).empty());

  const std::uint64_t generation = views.generation();
  EXPECT_EQ(views.set_shared({{"enhanced", {{"threshold", 0.5}}}}, kStart + 600 * kMs),
            generation + 1);
  const auto due = views.take_due(kStart + 600 * kMs);
  ASSERT_EQ(due.size(), 1u);
  EXPECT_EQ(due[0].view_id, kSharedView);
  EXPECT_DOUBLE_EQ(due[0].config.enhanced.threshold, 0.5);
  EXPECT_EQ(due[0].generation, generation + 1);
  EXPECT_FALSE(due[0].reduced);
  EXPECT_TRUE(views.take_due(kStart + 601 * kMs).empty());
}

TEST(ViewSet, ARotatingViewIsDueAtTheFrameRateAndTurns) {
  render::RenderConfig config = still_view();
  config.view.auto_rotate = true;
  config.view.rotation_deg_per_s = 45.0;
  ViewSet views(config, ViewTiming{.frame_rate_hz = 50.0}, kStart);
  (void)views.take_shared(kStart);
  EXPECT_EQ(views.next_due_ns(kStart), kStart + 20 * kMs);
  EXPECT_TRUE(views.take_due(kStart + 10 * kMs).empty());
  const auto due = views.take_due(kStart + 1000 * kMs);
  ASSERT_EQ(due.size(), 1u);
  EXPECT_NEAR(due[0].config.view.azimuth_deg, 75.0, 1e-9);  // 30 + 45 deg/s x 1 s
}

TEST(ViewSet, ChangesTurnFromWhereTheRotationIs) {
  render::RenderConfig config = still_view();
  config.view.auto_rotate = true;
  config.view.rotation_deg_per_s = 10.0;
  ViewSet views(config, ViewTiming{}, kStart);
  views.set_shared({{"view", {{"auto_rotate", false}}}}, kStart + 2000 * kMs);
  EXPECT_NEAR(views.shared(kStart + 9000 * kMs).view.azimuth_deg, 50.0, 1e-9);
}

TEST(ViewSet, TheCpuRendersSmallWhileMovingAndFullOnceStill) {
  ViewTiming timing;
  timing.reduce_while_moving = true;
  timing.moving_scale = 0.5;
  timing.settle_s = 0.3;
  ViewSet views(still_view(), timing, kStart);
  (void)views.take_shared(kStart);
  views.set_shared({{"view", {{"azimuth_deg", 40}}}}, kStart + 100 * kMs);
  auto due = views.take_due(kStart + 100 * kMs);
  ASSERT_EQ(due.size(), 1u);
  EXPECT_TRUE(due[0].reduced);
  EXPECT_EQ(due[0].config.view.output_width, 512u);
  EXPECT_EQ(due[0].config.view.output_height, 384u);
  // Still for the settling time: one more render, full size.
  EXPECT_EQ(views.next_due_ns(kStart + 200 * kMs), kStart + 400 * kMs);
  EXPECT_TRUE(views.take_due(kStart + 300 * kMs).empty());
  due = views.take_due(kStart + 400 * kMs);
  ASSERT_EQ(due.size(), 1u);
  EXPECT_FALSE(due[0].reduced);
  EXPECT_EQ(due[0].config.view.output_width, 1024u);
  EXPECT_EQ(views.next_due_ns(kStart + 500 * kMs), UINT64_MAX);
}

TEST(ViewSet, ASnapshotGetsAFullSizeRenderEvenWhileMoving) {
  ViewTiming timing;
  timing.reduce_while_moving = true;
  render::RenderConfig config = still_view();
  config.view.auto_rotate = true;
  ViewSet views(config, timing, kStart);
  (void)views.take_shared(kStart);
  views.want_full_shared();
  const auto due = views.take_due(kStart + 100 * kMs);
  ASSERT_EQ(due.size(), 1u);
  EXPECT_FALSE(due[0].reduced);
}

TEST(ViewSet, PrivateViewsHaveTheirOwnCameraAndTheSharedParameters) {
  ViewSet views(still_view(), ViewTiming{}, kStart);
  (void)views.take_shared(kStart);
  views.open(7, {{"view", {{"azimuth_deg", 120}}}}, kStart);
  EXPECT_TRUE(views.is_open(7));
  EXPECT_EQ(views.private_views(), 1u);
  auto due = views.take_due(kStart + 100 * kMs);
  ASSERT_EQ(due.size(), 1u);
  EXPECT_EQ(due[0].view_id, 7u);
  EXPECT_DOUBLE_EQ(due[0].config.view.azimuth_deg, 120.0);

  views.set_shared({{"enhanced", {{"kg1", 2}}}}, kStart + 200 * kMs);  // both render it
  due = views.take_due(kStart + 200 * kMs);
  ASSERT_EQ(due.size(), 2u);
  for (const DueRender& r : due) EXPECT_DOUBLE_EQ(r.config.enhanced.kg1, 2.0);
  EXPECT_DOUBLE_EQ(due[0].config.view.azimuth_deg, 30.0);
  EXPECT_DOUBLE_EQ(due[1].config.view.azimuth_deg, 120.0);

  views.volume_changed();  // a pass: the private view is due, the shared one is rendered by it
  due = views.take_due(kStart + 300 * kMs);
  ASSERT_EQ(due.size(), 1u);
  EXPECT_EQ(due[0].view_id, 7u);

  views.set_camera(7, {{"view", {{"zoom", 3}}}}, kStart + 400 * kMs);
  due = views.take_due(kStart + 400 * kMs);
  ASSERT_EQ(due.size(), 1u);
  EXPECT_DOUBLE_EQ(due[0].config.view.zoom, 3.0);
  EXPECT_DOUBLE_EQ(views.shared(kStart + 400 * kMs).view.zoom, 1.0);

  views.close(7);
  EXPECT_FALSE(views.is_open(7));
  EXPECT_THROW(views.set_camera(7, nlohmann::json::object(), kStart), std::out_of_range);
}

TEST(ViewSet, RefusesView0ABadCameraAndTooManyViews) {
  ViewSet views(still_view(), ViewTiming{}, kStart);
  EXPECT_THROW(views.open(0, nlohmann::json::object(), kStart), std::invalid_argument);
  EXPECT_THROW(views.open(1, {{"enhanced", {{"kg1", 1}}}}, kStart), ConfigError);
  EXPECT_FALSE(views.is_open(1));
  for (std::uint64_t id = 1; id <= ViewSet::kMaxPrivateViews; ++id) {
    views.open(id, nlohmann::json::object(), kStart);
  }
  EXPECT_THROW(views.open(100, nlohmann::json::object(), kStart), std::invalid_argument);
  views.open(1, nlohmann::json::object(), kStart);  // reopening one is not one more
  const std::uint64_t generation = views.generation();
  EXPECT_THROW(views.set_shared({{"view", {{"zoom", 0}}}}, kStart), ConfigError);
  EXPECT_EQ(views.generation(), generation);
}

}  // namespace
}  // namespace ioct::gpu::live
