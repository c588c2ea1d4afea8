// ProcessingViewControl: the dB range beside the render parameters. A change is checked whole
// (the dB range and the views' part) before anything is applied; errors name the key.
#include <gtest/gtest.h>

#include <optional>
#include <stdexcept>
#include <vector>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/live_stages/processing_view_control.hpp"

namespace ioct::gpu::live {
namespace {

using nlohmann::json;

// The views' side: records the changes it accepted, refuses {"mode": "bad"}.
class RecordingViews final : public ViewControl {
 public:
  ViewParams params() const override { return {generation, {{"mode", "enhanced"}}}; }
  std::uint64_t set_params(const json& changes) override {
    if (changes.contains("mode") && changes["mode"] == "bad") {
      throw ConfigError("render.mode", "\"bad\"", "is not a render mode");
    }
    accepted.push_back(changes);
    return ++generation;
  }
  std::uint64_t open_view(std::uint64_t, const json&) override { return generation; }
  std::uint64_t set_view(std::uint64_t, const json&) override { return generation; }
  void close_view(std::uint64_t) override {}
  ViewSnapshot snapshot(std::chrono::milliseconds) override {
    throw std::runtime_error("no frames here");
  }

  std::uint64_t generation = 0;
  std::vector<json> accepted;
};

struct Controls {
  RecordingViews views;
  DbScaleConfig range{0.0, 40.0};  // where the processing keeps it
  std::vector<DbScaleConfig> applied;
  ProcessingViewControl control{views, [this] { return range; },
                                [this](const DbScaleConfig& s) {
                                  applied.push_back(s);
                                  range = s;
                                }};
};

TEST(ProcessingViewControl, ShowsTheDbRangeBesideTheRenderParameters) {
  Controls c;
  const ViewParams p = c.control.params();
  EXPECT_EQ(p.params.at("mode"), "enhanced");
  EXPECT_EQ(p.params.at("processing"), json({{"db_min", 0.0}, {"db_max", 40.0}}));
}

TEST(ProcessingViewControl, AppliesTheDbRangeAndBumpsTheGeneration) {
  Controls c;
  const std::uint64_t generation = c.control.set_params({{"processing", {{"db_max", 30.0}}}});
  EXPECT_EQ(generation, 1u);
  ASSERT_EQ(c.applied.size(), 1u);
  EXPECT_EQ(c.applied[0].db_min, 0.0);
  EXPECT_EQ(c.applied[0].db_max, 30.0);
  ASSERT_EQ(c.views.accepted.size(), 1u);
  EXPECT_EQ(c.views.accepted[0], json::object());  // the views saw no processing key
  EXPECT_EQ(c.control.params().params.at("processing").at("db_max"), 30.0);

  // Both kinds at once: the views get theirs, the processing its own.
  c.control.set_params({{"mode", "layer-aware"}, {"processing", {{"db_min", 3.0}}}});
  EXPECT_EQ(c.views.accepted.back(), json({{"mode", "layer-aware"}}));
  EXPECT_EQ(c.applied.back().db_min, 3.0);
  EXPECT_EQ(c.applied.back().db_max, 30.0);
  // Render changes alone pass straight through.
  c.control.set_params({{"mode", "basic"}});
  EXPECT_EQ(c.applied.size(), 2u);
}

TEST(ProcessingViewControl, RefusesBadRangesNamingTheKeyAndChangesNothing) {
  struct Bad {
    json processing;
    const char* key;
  };
  const Bad cases[] = {
      {{{"db_max", 0.5}}, "processing.db_max"},     // under 1 dB above db_min
      {{{"db_min", -500.0}}, "processing.db_min"},  // out of range
      {{{"db_min", "low"}}, "processing.db_min"},   // not a number
      {{{"gain", 2.0}}, "processing.gain"},         // not a parameter
      {json::array({1, 2}), "processing"},          // not an object
  };
  for (const Bad& bad : cases) {
    Controls c;
    try {
      c.control.set_params({{"processing", bad.processing}});
      ADD_FAILURE() << "accepted " << bad.processing.dump();
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(bad.key), std::string::npos) << e.what();
    }
    EXPECT_TRUE(c.applied.empty()) << bad.processing.dump();
    EXPECT_TRUE(c.views.accepted.empty()) << bad.processing.dump();
  }
  // A refused render change keeps the dB range as it was.
  Controls c;
  EXPECT_THROW(c.control.set_params({{"mode", "bad"}, {"processing", {{"db_max", 20.0}}}}),
               ConfigError);
  EXPECT_TRUE(c.applied.empty());
  EXPECT_EQ(c.control.params().params.at("processing").at("db_max"), 40.0);
}

}  // namespace
}  // namespace ioct::gpu::live
